"""Free-space filtering: a point that a view sees through cannot be on a surface.

Semi-global matching smears depth across an object's silhouette, leaving a skirt of points
between the object and the table. Such a point is consistent with the views that made it, but
other views look past it at the table behind: their depth maps hold a larger depth at the
point's pixel. A point that more views see through than see it is dropped.
"""

from __future__ import annotations

import numpy as np

from photogrammetry.sfm import View
from photogrammetry.stereo import DepthMap


def free_space_votes(
    points: np.ndarray, maps: list[DepthMap], views: list[View], *, tolerance: float
) -> tuple[np.ndarray, np.ndarray]:
    """Per point: how many depth maps see it (depth within `tolerance` of the point's) and how
    many see through it (a depth beyond it by more than that); points and views share a frame."""
    seen = np.zeros(len(points), np.int32)
    through = np.zeros(len(points), np.int32)
    for depth_map in maps:
        view = views[depth_map.view_index]
        camera = points @ view.camera_from_world[:3, :3].T + view.camera_from_world[:3, 3]
        z = camera[:, 2]
        front = z > 0
        col, row = np.round(depth_map.camera.project(camera[front])).astype(np.int64).T
        height, width = depth_map.depth.shape
        inside = (col >= 0) & (col < width) & (row >= 0) & (row < height)
        index = np.nonzero(front)[0][inside]
        observed = depth_map.depth[row[inside], col[inside]]
        known = observed > 0
        index, observed = index[known], observed[known]
        relative = (observed - z[index]) / z[index]
        seen[index[np.abs(relative) <= tolerance]] += 1
        through[index[relative > tolerance]] += 1
    return seen, through


def keep_surface_points(
    points: np.ndarray, maps: list[DepthMap], views: list[View], *, tolerance: float = 0.01
) -> np.ndarray:
    """A mask of the points that are not in free space."""
    seen, through = free_space_votes(points, maps, views, tolerance=tolerance)
    return through <= seen
