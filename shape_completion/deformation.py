"""Symmetry-aware approximating thin-plate-spline deformation of the retrieved mesh.

Control points are model surface points paired with the query cloud, displaced toward their
query point. For every symmetry plane, each control point's mirror image is added with the
mirrored displacement, so the smooth field that approximates them (scipy's
RBFInterpolator, thin-plate kernel with smoothing) moves symmetric pairs symmetrically.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import RBFInterpolator

from shape_completion.symmetry import Plane

MAX_DEFORMATION_STRETCH = 1.5


def symmetric_controls(
    points: np.ndarray, displacements: np.ndarray, planes: list[Plane]
) -> tuple[np.ndarray, np.ndarray]:
    """The control points and displacements with their mirror images under each plane added."""
    all_points, all_displacements = [points], [displacements]
    for plane in planes:
        all_points.append(plane.reflect(points))
        all_displacements.append(plane.reflect_vectors(displacements))
    return np.concatenate(all_points), np.concatenate(all_displacements)


def tps_deform(
    vertices: np.ndarray,
    control_points: np.ndarray,
    displacements: np.ndarray,
    *,
    scale_m: float,
    smoothing: float,
) -> np.ndarray:
    """`vertices` moved by the approximating thin-plate spline through the controls.

    Coordinates are divided by `scale_m` first so that `smoothing` means the same for a
    spoon and a bottle.
    """
    if len(control_points) < 5:
        return vertices.copy()
    field = RBFInterpolator(
        control_points / scale_m, displacements / scale_m, kernel="thin_plate_spline", smoothing=smoothing, degree=1
    )
    return vertices + field(vertices / scale_m) * scale_m


def deformation_is_trusted(placed: np.ndarray, moved: np.ndarray, camera_from_object_rotation: np.ndarray) -> bool:
    """Whether a deformation of the `placed` vertices to `moved` keeps the mesh's box, along the
    object's own axes, within MAX_DEFORMATION_STRETCH of its size. Few or one-sided controls can
    make the spline run away (seen: a spoon blown up to 40 times its volume); the rigid fit
    then stands."""
    stretch = np.ptp(moved @ camera_from_object_rotation, axis=0) / np.maximum(
        np.ptp(placed @ camera_from_object_rotation, axis=0), 1e-9
    )
    return bool(np.all(stretch <= MAX_DEFORMATION_STRETCH) and np.all(stretch >= 1 / MAX_DEFORMATION_STRETCH))
