"""4x4 homogeneous transforms named `a_from_b`, and the URDF xyz + rpy convention."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

# The toolkit (like URDF and ROS) is z-up, glTF y-up: a turn of -90 deg about x takes z-up to y-up.
Y_UP_FROM_Z_UP = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


def as_transform(matrix: np.ndarray | Sequence[Sequence[float]]) -> np.ndarray:
    """Check and convert a 4x4 rigid transform."""
    m = np.asarray(matrix, dtype=np.float64)
    if m.shape != (4, 4):
        raise ValueError(f"{m.shape=} but expected (4, 4)")
    return m


# How far from orthonormal a hand-written rotation may be (one rounded to 4 decimals, say).
RIGID_TOLERANCE = 1e-3


def rigid_transform(matrix: object, what: str = "transform") -> np.ndarray:
    """`matrix` as a 4x4 float64 rigid transform, its rotation made exactly orthonormal; a
    ValueError naming `what` and the problem otherwise."""
    try:
        m = np.array(matrix, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be a 4x4 nested list of numbers") from None
    if m.shape != (4, 4):
        raise ValueError(f"{what} must be a 4x4 nested list of numbers, got shape {m.shape}")
    if not np.isfinite(m).all():
        raise ValueError(f"{what} holds a value that is not a finite number")
    rotation = m[:3, :3]
    if (
        not np.allclose(m[3], (0, 0, 0, 1), atol=1e-9)
        or np.abs(rotation.T @ rotation - np.eye(3)).max() > RIGID_TOLERANCE
        or np.linalg.det(rotation) <= 0
    ):
        raise ValueError(
            f"{what} is not a rigid transform (its 3x3 rotation must be orthonormal with determinant +1,"
            " its last row 0 0 0 1)"
        )
    u, _, vt = np.linalg.svd(rotation)
    m[:3, :3] = u @ vt
    return m


def rotation_from_rpy(rpy: Sequence[float]) -> np.ndarray:
    """Rotation matrix of fixed-axis roll, pitch, yaw (URDF/ROS: R = Rz(yaw) Ry(pitch) Rx(roll))."""
    r, p, y = (float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def rpy_from_rotation(rotation: np.ndarray) -> np.ndarray:
    """Inverse of `rotation_from_rpy`, with pitch in [-pi/2, pi/2]."""
    r = np.asarray(rotation, dtype=np.float64)
    pitch = np.arcsin(np.clip(-r[2, 0], -1.0, 1.0))
    if abs(np.cos(pitch)) > 1e-9:
        roll = np.arctan2(r[2, 1], r[2, 2])
        yaw = np.arctan2(r[1, 0], r[0, 0])
    else:  # gimbal lock: fold all rotation about z into yaw
        roll = 0.0
        yaw = np.arctan2(-r[0, 1], r[1, 1])
    return np.array([roll, pitch, yaw])


def transform_from_xyz_rpy(xyz: Sequence[float] = (0, 0, 0), rpy: Sequence[float] = (0, 0, 0)) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = rotation_from_rpy(rpy)
    m[:3, 3] = np.asarray(xyz, dtype=np.float64)
    return m


def xyz_rpy_from_transform(a_from_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    m = as_transform(a_from_b)
    return m[:3, 3].copy(), rpy_from_rotation(m[:3, :3])


def rotation_angle_rad(rotation: np.ndarray) -> float:
    """The angle of a 3x3 rotation about its axis, in [0, pi] (trace = 1 + 2 cos angle; clipped:
    rounding takes the trace of a near-identity rotation a little past 3)."""
    return float(np.arccos(np.clip((np.trace(rotation) - 1) / 2, -1.0, 1.0)))


def axis_angle_transform(axis: Sequence[float], angle_rad: float) -> np.ndarray:
    """Rotation by `angle_rad` about the unit `axis` through the origin (Rodrigues)."""
    k = np.asarray(axis, dtype=np.float64)
    k = k / np.linalg.norm(k)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    m = np.eye(4)
    m[:3, :3] = np.eye(3) + np.sin(angle_rad) * kx + (1 - np.cos(angle_rad)) * kx @ kx
    return m


def translation_transform(offset: Sequence[float]) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = np.asarray(offset, dtype=np.float64)
    return m


def transform_points(a_from_b: np.ndarray, points_b: np.ndarray) -> np.ndarray:
    pts = np.asarray(points_b, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"{pts.shape=} but expected (N, 3)")
    return pts @ a_from_b[:3, :3].T + a_from_b[:3, 3]


def world_from_camera_looking_at(
    eye: Sequence[float], target: Sequence[float], up: Sequence[float] = (0.0, 0.0, 1.0)
) -> np.ndarray:
    """`world_from_camera` of an OpenCV camera (x right, y down, z forward) at `eye` looking
    at `target`, with the image's up along `up` (see `world_from_camera_looking_along`)."""
    eye = np.asarray(eye, dtype=np.float64)
    return world_from_camera_looking_along(eye, np.asarray(target, dtype=np.float64) - eye, up)


def world_from_camera_looking_along(
    eye: Sequence[float], forward: Sequence[float], up: Sequence[float] = (0.0, 0.0, 1.0)
) -> np.ndarray:
    """`world_from_camera` of an OpenCV camera at `eye` whose optical axis runs along `forward`,
    with the image's up along `up`; a camera looking within 8 deg of `up` (or its opposite)
    takes +y as up instead."""
    forward = np.asarray(forward, dtype=np.float64)
    forward = forward / np.linalg.norm(forward)
    up = np.asarray(up, dtype=np.float64)
    if abs(forward @ up) >= 0.99 * np.linalg.norm(up):
        up = np.array([0.0, 1.0, 0.0])
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    world_from_camera = np.eye(4)
    world_from_camera[:3, :3] = np.column_stack([right, np.cross(forward, right), forward])
    world_from_camera[:3, 3] = np.asarray(eye, dtype=np.float64)
    return world_from_camera
