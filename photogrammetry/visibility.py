"""Free-space filtering: a point that a view sees through cannot be on a surface.

Semi-global matching smears depth across an object's silhouette, leaving a skirt of points
between the object and the table. Such a point is consistent with the views that made it, but
other views look past it at the table behind: their depth maps hold a larger depth at the
point's pixel. A point that more views see through than see it is dropped.
"""

from __future__ import annotations

import numpy as np

from photogrammetry.sfm import View
from photogrammetry.stereo import DepthMap, in_frame_pixels


def free_space_votes(
    points: np.ndarray, maps: list[DepthMap], views: list[View], *, tolerance: float
) -> tuple[np.ndarray, np.ndarray]:
    """Per point: how many depth maps see it (depth within `tolerance` of the point's) and how
    many see through it (a depth beyond it by more than that); points and views share a frame."""
    seen = np.zeros(len(points), np.int32)
    through = np.zeros(len(points), np.int32)
    for depth_map in maps:
        view = views[depth_map.view_index]
        index, pixels, z = in_frame_pixels(points, view.camera_from_world, depth_map.camera, depth_map.depth.shape)
        observed = depth_map.depth[pixels[:, 1], pixels[:, 0]]
        known = observed > 0
        index, observed, z = index[known], observed[known], z[known]
        relative = (observed - z) / z
        seen[index[np.abs(relative) <= tolerance]] += 1
        through[index[relative > tolerance]] += 1
    return seen, through


def keep_surface_points(
    points: np.ndarray, maps: list[DepthMap], views: list[View], *, tolerance: float = 0.01
) -> np.ndarray:
    """A mask of the points that are not in free space."""
    seen, through = free_space_votes(points, maps, views, tolerance=tolerance)
    return through <= seen
