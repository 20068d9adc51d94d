"""The turntable's axis from the orbit of the board's origin (D3.1 section 3.3.3).

Seen from the fixed camera, the board's origin runs round a circle as the table turns. A
least-squares circle through those points gives the plane of the table top and, through its
centre and normal, the axis of rotation: together they bound the cylinder the object stands in.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from homemodel.core.errors import ModelError


@dataclass(kw_only=True)
class Circle3D:
    center: np.ndarray  # (3,)
    normal: np.ndarray  # (3,), unit
    radius_m: float
    rms_m: float  # RMS distance of the points from the circle


def fit_circle_3d(points: np.ndarray) -> Circle3D:
    """Least-squares circle through 3D points: plane by SVD, then a geometric (not only
    algebraic) circle fit in that plane."""
    from scipy.optimize import least_squares

    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"{pts.shape=} but expected (N, 3)")
    if len(pts) < 3:
        raise ModelError(f"a circle needs at least 3 points, got {len(pts)}")
    centroid = pts.mean(axis=0)
    _, singular, vt = np.linalg.svd(pts - centroid)
    if singular[1] < 1e-9 * max(singular[0], 1e-12):
        raise ModelError("the orbit points lie on a line: the table did not turn")
    u, v, normal = vt
    xy = np.column_stack([(pts - centroid) @ u, (pts - centroid) @ v])
    # Kasa's algebraic fit as the start: x^2 + y^2 = 2 a x + 2 b y + c.
    a_matrix = np.column_stack([2 * xy, np.ones(len(xy))])
    (a, b, c), *_ = np.linalg.lstsq(a_matrix, np.sum(xy**2, axis=1), rcond=None)
    start = np.array([a, b, np.sqrt(max(c + a * a + b * b, 1e-12))])

    def residuals(p: np.ndarray) -> np.ndarray:
        return np.hypot(xy[:, 0] - p[0], xy[:, 1] - p[1]) - p[2]

    fit = least_squares(residuals, start, method="lm")
    cx, cy, radius = fit.x
    in_plane = residuals(fit.x)
    off_plane = (pts - centroid) @ normal
    return Circle3D(
        center=centroid + cx * u + cy * v,
        normal=normal / np.linalg.norm(normal),
        radius_m=float(abs(radius)),
        rms_m=float(np.sqrt(np.mean(in_plane**2 + off_plane**2))),
    )


@dataclass(kw_only=True)
class TableAxis:
    """The turntable's axis in the table frame, and how well the orbit fits it."""

    axis_xy_m: np.ndarray  # where the axis crosses the table top
    tilt_deg: float  # between the fitted axis and the table's z
    orbit: Circle3D  # in the camera frame
    axis_spread_m: float  # RMS spread of the axis point over frames (0 for a perfect turntable)


def table_axis(camera_from_tables: list[np.ndarray]) -> TableAxis:
    """Fit the orbit of the board's origin and express the axis in the table frame."""
    origins = np.array([p[:3, 3] for p in camera_from_tables])
    orbit = fit_circle_3d(origins)
    table_from_cameras = [np.linalg.inv(p) for p in camera_from_tables]
    centers = np.array([t[:3, :3] @ orbit.center + t[:3, 3] for t in table_from_cameras])
    normals = np.array([t[:3, :3] @ orbit.normal for t in table_from_cameras])
    mean_normal = normals.mean(axis=0)
    tilt = float(np.degrees(np.arccos(np.clip(abs(mean_normal[2]) / np.linalg.norm(mean_normal), -1.0, 1.0))))
    axis_xy = centers[:, :2].mean(axis=0)
    spread = float(np.sqrt(np.mean(np.sum((centers[:, :2] - axis_xy) ** 2, axis=1))))
    return TableAxis(axis_xy_m=axis_xy, tilt_deg=tilt, orbit=orbit, axis_spread_m=spread)
