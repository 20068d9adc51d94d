"""Spin images (Johnson and Hebert, 1999) and a RANSAC rigid fit on their correspondences.

A spin image of an oriented point (p, n) is the 2-D histogram of its neighbours' distance
from the normal line (alpha) and height along the normal (beta): invariant to rotation about
the normal, so it matches a point of the query cloud to a point of the retrieved mesh.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from shape_completion.registration import apply, kabsch

ALPHA_BINS, BETA_BINS = 6, 12


def spin_images(points: np.ndarray, normals: np.ndarray, keypoints: np.ndarray, radius_m: float) -> np.ndarray:
    """(K, ALPHA_BINS * BETA_BINS) unit-norm spin images of `points[keypoints]`."""
    tree = cKDTree(points)
    images = np.zeros((len(keypoints), ALPHA_BINS * BETA_BINS))
    for row, index in enumerate(keypoints):
        neighbours = points[tree.query_ball_point(points[index], radius_m)] - points[index]
        beta = neighbours @ normals[index]
        alpha = np.sqrt(np.maximum(np.einsum("ni,ni->n", neighbours, neighbours) - beta**2, 0.0))
        histogram, _, _ = np.histogram2d(
            alpha, beta, bins=(ALPHA_BINS, BETA_BINS), range=((0.0, radius_m), (-radius_m, radius_m))
        )
        images[row] = histogram.ravel()
    norms = np.linalg.norm(images, axis=1, keepdims=True)
    return images / np.maximum(norms, 1e-12)


def ransac_rigid_fit(
    source: np.ndarray,
    target: np.ndarray,
    *,
    inlier_distance_m: float,
    iterations: int,
    rng: np.random.Generator,
) -> tuple[np.ndarray, int]:
    """The `target_from_source` with most paired points within `inlier_distance_m`, refit on its inliers."""
    best, best_inliers = np.eye(4), np.zeros(len(source), dtype=bool)
    if len(source) < 3:
        return best, 0
    for _ in range(iterations):
        sample = rng.choice(len(source), size=3, replace=False)
        transform = kabsch(source[sample], target[sample])
        inliers = np.linalg.norm(apply(transform, source) - target, axis=1) < inlier_distance_m
        if inliers.sum() > best_inliers.sum():
            best, best_inliers = transform, inliers
    if best_inliers.sum() >= 3:
        best = kabsch(source[best_inliers], target[best_inliers])
    return best, int(best_inliers.sum())


def spin_image_alignment(
    query: np.ndarray,
    query_normals: np.ndarray,
    model: np.ndarray,
    model_normals: np.ndarray,
    *,
    radius_m: float,
    n_keypoints: int,
    rng: np.random.Generator,
) -> tuple[np.ndarray, int]:
    """`query_from_model` from spin-image correspondences (mutual nearest descriptors) and RANSAC."""
    query_keys = rng.choice(len(query), size=min(n_keypoints, len(query)), replace=False)
    model_keys = rng.choice(len(model), size=min(2 * n_keypoints, len(model)), replace=False)
    query_images = spin_images(query, query_normals, query_keys, radius_m)
    model_images = spin_images(model, model_normals, model_keys, radius_m)
    _, to_model = cKDTree(model_images).query(query_images)
    _, to_query = cKDTree(query_images).query(model_images)
    mutual = to_query[to_model] == np.arange(len(query_keys))
    return ransac_rigid_fit(
        model[model_keys[to_model[mutual]]],
        query[query_keys[mutual]],
        inlier_distance_m=0.5 * radius_m,
        iterations=200,
        rng=rng,
    )
