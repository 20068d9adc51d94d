"""Rigid alignment: Kabsch on correspondences, normals of a partial cloud, a trimmed ICP."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree


def kabsch(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """The 4x4 rigid `target_from_source` minimising the squared distances of paired points."""
    src_mean, dst_mean = source.mean(axis=0), target.mean(axis=0)
    u, _, vt = np.linalg.svd((source - src_mean).T @ (target - dst_mean))
    d = np.sign(np.linalg.det(vt.T @ u.T))
    rotation = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    transform = np.eye(4)
    transform[:3, :3] = rotation
    transform[:3, 3] = dst_mean - rotation @ src_mean
    return transform


def kabsch_batch(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """`kabsch` of each of B point sets at once: (B, N, 3) pairs to (B, 4, 4) transforms."""
    src_mean, dst_mean = source.mean(axis=1), target.mean(axis=1)
    u, _, vt = np.linalg.svd(np.einsum("bni,bnj->bij", source - src_mean[:, None], target - dst_mean[:, None]))
    v, ut = np.transpose(vt, (0, 2, 1)), np.transpose(u, (0, 2, 1))
    d = np.sign(np.linalg.det(v @ ut))
    rotation = v @ (np.stack([np.ones_like(d), np.ones_like(d), d], axis=1)[:, :, None] * ut)
    transforms = np.tile(np.eye(4), (len(source), 1, 1))
    transforms[:, :3, :3] = rotation
    transforms[:, :3, 3] = dst_mean - np.einsum("bij,bj->bi", rotation, src_mean)
    return transforms


def apply(transform: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ transform[:3, :3].T + transform[:3, 3]


def camera_facing_normals(points: np.ndarray, neighbours: int = 12) -> np.ndarray:
    """Unit normals of a cloud seen from the origin (a camera frame), by local PCA, facing the camera."""
    k = min(neighbours, len(points))
    _, index = cKDTree(points).query(points, k=k)
    local = points[index] - points[index].mean(axis=1, keepdims=True)
    _, vectors = np.linalg.eigh(np.einsum("nki,nkj->nij", local, local))
    normals = vectors[:, :, 0]
    flip = np.einsum("ni,ni->n", normals, points) > 0
    normals[flip] *= -1
    return normals


def trimmed_icp(
    query: np.ndarray,
    model_points: np.ndarray,
    model_normals: np.ndarray,
    camera_from_model: np.ndarray,
    *,
    iterations: int = 30,
    max_distance_m: float,
) -> tuple[np.ndarray, float]:
    """Refine `camera_from_model` so the model's camera-facing surface meets the query cloud
    (both in the camera frame). Returns the pose and the mean query-to-model distance.

    Only model samples whose normal faces the camera take part (the query sees one side);
    pairs farther than 2.5x the median distance or `max_distance_m` are dropped.
    """
    pose = camera_from_model.copy()
    for _ in range(iterations):
        points = apply(pose, model_points)
        normals = model_normals @ pose[:3, :3].T
        facing = np.einsum("ni,ni->n", normals, -points) > 0
        candidates = np.nonzero(facing)[0] if facing.sum() >= 10 else np.arange(len(points))
        distances, nearest = cKDTree(points[candidates]).query(query)
        keep = distances <= min(2.5 * np.median(distances) + 1e-9, max_distance_m)
        if keep.sum() < 6:
            break
        update = kabsch(model_points[candidates[nearest[keep]]], query[keep])
        if np.allclose(update, pose, atol=1e-7):
            pose = update
            break
        pose = update
    points = apply(pose, model_points)
    return pose, float(cKDTree(points).query(query)[0].mean())


def subsample(points: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """At most `count` of `points`, drawn without replacement."""
    if len(points) <= count:
        return points
    return points[rng.choice(len(points), size=count, replace=False)]
