"""The surface the object stands on, found in the dense points by RANSAC."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# A support plane must hold at least this share of the scene's points to count as one.
MIN_PLANE_SHARE = 0.08
# RANSAC runs on a random sample this large: 100,000 took 8.5 s a try on Kermit, 20,000 took 1.2 s
# and found the same plane (holding 11.0 % of the points against 10.8 %).
MAX_RANSAC_POINTS = 20_000
MIN_UP_COSINE = 0.5  # a support plane's normal is within 60 degrees of the cameras' up


@dataclass(kw_only=True)
class Plane:
    """Points x with normal . x + offset = 0; the normal points to the side the cameras are on."""

    normal: np.ndarray
    offset: float
    inlier_share: float

    def height(self, points: np.ndarray) -> np.ndarray:
        return points @ self.normal + self.offset


def focus_point(centres: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """The point closest (least squares) to every camera's optical axis: what the photos look at."""
    a, b = np.zeros((3, 3)), np.zeros(3)
    for c, d in zip(centres, axes):
        d = d / np.linalg.norm(d)
        projector = np.eye(3) - np.outer(d, d)
        a += projector
        b += projector @ c
    return np.linalg.lstsq(a, b, rcond=None)[0]


def find_support_plane(
    points: np.ndarray, camera_centres: np.ndarray, camera_up: np.ndarray, *, threshold: float, seed: int = 0
) -> Plane | None:
    """The largest plane below the cameras and facing up (RANSAC, then a least-squares refit of
    its inliers), or None when no such plane holds MIN_PLANE_SHARE of the points.

    `camera_up` is the mean of the cameras' up directions (minus their image y axes): photos
    are taken upright, so a table faces it and a wall behind the object does not."""
    import open3d as o3d

    o3d.utility.random.seed(seed)
    rng = np.random.default_rng(seed)
    if len(points) > MAX_RANSAC_POINTS:  # a random subset finds the same plane, much faster
        points = points[rng.choice(len(points), MAX_RANSAC_POINTS, replace=False)]
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    remaining = np.arange(len(points))
    up = camera_up / np.linalg.norm(camera_up)
    for _ in range(4):  # a wall may be larger than the table: take the first plane facing up, cameras above
        if len(remaining) < 3:
            return None
        sub = cloud.select_by_index(remaining)
        _, inliers = sub.segment_plane(distance_threshold=threshold, ransac_n=3, num_iterations=2000)
        share = len(inliers) / len(points)
        if share < MIN_PLANE_SHARE:
            return None
        inlier_points = points[remaining[inliers]]
        centroid = inlier_points.mean(axis=0)
        normal = np.linalg.svd(inlier_points - centroid, full_matrices=False)[2][-1]
        heights = (camera_centres - centroid) @ normal
        if np.mean(heights > 0) < 0.5:
            normal = -normal
            heights = -heights
        if np.mean(heights > threshold) >= 0.8 and normal @ up >= MIN_UP_COSINE:
            return Plane(normal=normal, offset=float(-normal @ centroid), inlier_share=share)
        remaining = np.delete(remaining, inliers)
    return None
