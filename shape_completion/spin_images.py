"""Spin images (Johnson and Hebert, 1999) and a RANSAC rigid fit on their correspondences.

A spin image of an oriented point (p, n) is the 2-D histogram of its neighbours' distance
from the normal line (alpha) and height along the normal (beta): invariant to rotation about
the normal, so it matches a point of the query cloud to a point of the retrieved mesh.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from shape_completion.registration import kabsch, kabsch_batch

ALPHA_BINS, BETA_BINS = 6, 12


def spin_images(points: np.ndarray, normals: np.ndarray, keypoints: np.ndarray, radius_m: float) -> np.ndarray:
    """(K, ALPHA_BINS * BETA_BINS) unit-norm spin images of `points[keypoints]` (all keypoints'
    neighbours binned in one pass, as `np.histogram2d` bins them)."""
    neighbours = cKDTree(points).query_ball_point(points[keypoints], radius_m)
    counts = np.fromiter((len(n) for n in neighbours), dtype=np.int64, count=len(keypoints))
    rows = np.repeat(np.arange(len(keypoints)), counts)
    found = np.concatenate([np.asarray(n, dtype=np.int64) for n in neighbours]) if len(rows) else rows
    offsets = points[found] - points[keypoints][rows]
    beta = np.einsum("ni,ni->n", offsets, normals[keypoints][rows])
    alpha = np.sqrt(np.maximum(np.einsum("ni,ni->n", offsets, offsets) - beta**2, 0.0))
    alpha_bin = _bins(alpha, 0.0, radius_m, ALPHA_BINS)
    beta_bin = _bins(beta, -radius_m, radius_m, BETA_BINS)
    counted = (alpha_bin >= 0) & (beta_bin >= 0)
    cells = (rows * ALPHA_BINS + alpha_bin) * BETA_BINS + beta_bin
    images = np.bincount(cells[counted], minlength=len(keypoints) * ALPHA_BINS * BETA_BINS).astype(np.float64)
    images = images.reshape(len(keypoints), ALPHA_BINS * BETA_BINS)
    norms = np.linalg.norm(images, axis=1, keepdims=True)
    return images / np.maximum(norms, 1e-12)


def _bins(values: np.ndarray, low: float, high: float, count: int) -> np.ndarray:
    """Each value's bin among `count` equal ones over [low, high] (the last one closed), -1 outside."""
    edges = np.linspace(low, high, count + 1)
    index = np.searchsorted(edges, values, side="right") - 1
    index[values == high] = count - 1
    return np.where((values >= low) & (values <= high), index, -1)


def ransac_rigid_fit(
    source: np.ndarray,
    target: np.ndarray,
    *,
    inlier_distance_m: float,
    iterations: int,
    rng: np.random.Generator,
) -> tuple[np.ndarray, int]:
    """The `target_from_source` with most paired points within `inlier_distance_m`, refit on its
    inliers. Every iteration's three pairs are drawn first, then all fits are scored at once."""
    if len(source) < 3:
        return np.eye(4), 0
    samples = np.array([rng.choice(len(source), size=3, replace=False) for _ in range(iterations)])
    transforms = kabsch_batch(source[samples], target[samples])
    moved = np.einsum("bij,nj->bni", transforms[:, :3, :3], source) + transforms[:, None, :3, 3]
    inliers = np.linalg.norm(moved - target, axis=2) < inlier_distance_m
    counts = inliers.sum(axis=1)
    best = int(np.argmax(counts))  # the first of the best, as a loop keeping strict improvements would
    if counts[best] == 0:
        return np.eye(4), 0
    if counts[best] >= 3:
        return kabsch(source[inliers[best]], target[inliers[best]]), int(counts[best])
    return transforms[best], int(counts[best])


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
