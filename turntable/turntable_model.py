"""All frames' poses refined together under the turntable's own motion.

A camera on a tripod and a table turning about a fixed axis leave one unknown per frame,
the table's angle: `camera_from_table_k = camera_from_world @ Rz(angle_k) @ world_from_board`,
with the tripod (`camera_from_world`) and the board's seat on the table (`world_from_board`)
shared by every frame. Fitting that to every tag corner of every frame at once averages the
corner noise of thousands of corners into each pose, where PnP sees one frame's corners only.
The circle through the board origin's orbit gives the starting point. When the motion is not
a turntable's (a hand-held camera, a table that wobbles), the fit's reprojection error is
clearly worse than per-frame PnP's, and the PnP poses are kept.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from homemodel.geometry.camera import Camera
from turntable.orbit import Circle3D
from turntable.pose import FramePose

# The fit is accepted unless its RMS error exceeds PnP's by this factor plus this margin.
_ACCEPT_RATIO = 1.5
_ACCEPT_MARGIN_PX = 0.3
# Converged once a step lowers the cost by less than this fraction of it: the bench mug's fourth
# step (1e-15 of the cost, 40 frames) moved the poses by 2e-10 rad, and cost a quarter of the fit.
_CONVERGED_COST_FRACTION = 1e-8
# Shared parameters: the tripod (rotation vector, translation), the board's tilt on the
# table (rotation vector about x and y) and its offset from the axis (x, y).
_SHARED = 10


@dataclass(kw_only=True)
class TurntableFit:
    camera_from_tables: dict[str, np.ndarray]
    rms_px: float  # over all corners, under the turntable model
    pnp_rms_px: float  # over the same corners, per-frame PnP poses
    accepted: bool


def _rigid(rvec: np.ndarray, t: np.ndarray) -> np.ndarray:
    import cv2

    m = np.eye(4)
    m[:3, :3] = cv2.Rodrigues(np.asarray(rvec, dtype=np.float64))[0]
    m[:3, 3] = t
    return m


def _unpack(params: np.ndarray, n_frames: int) -> np.ndarray:
    """(n_frames, 4, 4) `camera_from_table` of every frame, all at once."""
    camera_from_world = _rigid(params[0:3], params[3:6])
    world_from_board = _rigid([params[6], params[7], 0.0], [params[8], params[9], 0.0])
    angles = np.concatenate([[0.0], params[_SHARED : _SHARED + n_frames - 1]])
    turns = np.zeros((n_frames, 4, 4))
    turns[:, 0, 0] = turns[:, 1, 1] = np.cos(angles)
    turns[:, 1, 0] = np.sin(angles)
    turns[:, 0, 1] = -turns[:, 1, 0]
    turns[:, 2, 2] = turns[:, 3, 3] = 1.0
    return camera_from_world @ turns @ world_from_board


def _initial_params(poses: list[np.ndarray], orbit: Circle3D) -> np.ndarray:
    import cv2

    normal = orbit.normal if orbit.normal @ poses[0][:3, 2] > 0 else -orbit.normal  # along the table's z
    # World x along the board's x at frame 0, so world_from_board turns about z by nothing
    # (its z-rotation would trade off with the tripod's: a gauge freedom).
    x = poses[0][:3, 0] - (poses[0][:3, 0] @ normal) * normal
    x /= np.linalg.norm(x)
    camera_from_world = np.eye(4)
    camera_from_world[:3, :3] = np.column_stack([x, np.cross(normal, x), normal])
    camera_from_world[:3, 3] = orbit.center
    world_from_camera = np.linalg.inv(camera_from_world)
    world_from_board = world_from_camera @ poses[0]
    angles = []
    for pose in poses[1:]:
        turn = world_from_camera @ pose @ np.linalg.inv(world_from_board)
        angles.append(np.arctan2(turn[1, 0], turn[0, 0]))
    # Unwrap so consecutive angles do not jump by 2 pi.
    angles = np.unwrap(np.concatenate([[0.0], angles]))[1:]
    return np.concatenate(
        [
            cv2.Rodrigues(camera_from_world[:3, :3])[0].ravel(),
            camera_from_world[:3, 3],
            cv2.Rodrigues(world_from_board[:3, :3])[0].ravel()[:2],
            world_from_board[:2, 3],
            angles,
        ]
    )


def _levenberg_marquardt(
    residuals: Callable[[np.ndarray], np.ndarray],
    normal_equations: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]],
    params: np.ndarray,
    max_iterations: int = 50,
) -> tuple[np.ndarray, bool]:
    """Levenberg-Marquardt on the normal equations (JᵀJ, Jᵀr at `params`, given the residuals
    there). The Jacobian is tall and thin (every corner of every frame by a few hundred
    parameters): JᵀJ is small and quick to solve, where MINPACK's QR of J took seconds per
    iteration for 200 frames."""
    r = residuals(params)
    cost = float(r @ r)
    damping = 1e-3
    for _ in range(max_iterations):
        normal, gradient = normal_equations(params, r)
        while True:
            step = np.linalg.solve(normal + damping * np.diag(np.diag(normal) + 1e-12), -gradient)
            trial = params + step
            r_trial = residuals(trial)
            cost_trial = float(r_trial @ r_trial)
            if cost_trial < cost:
                break
            damping *= 10
            if damping > 1e10:
                return params, True  # no step lowers the cost: a minimum
        converged = cost - cost_trial < _CONVERGED_COST_FRACTION * cost or np.linalg.norm(step) < 1e-12 * (1 + np.linalg.norm(params))
        params, r, cost = trial, r_trial, cost_trial
        damping = max(damping / 10, 1e-12)
        if converged:
            return params, True
    return params, False


def _distinct_rows(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(the distinct rows, each row's index among them): np.unique(axis=0)'s, from each
    column's ranks (a sixth of the time of its sort of whole rows)."""
    ranks = [np.unique(column, return_inverse=True)[1].ravel() for column in points.T]
    key = ranks[0]
    for rank in ranks[1:]:
        key = key * (int(rank.max()) + 1) + rank
    _, first, inverse = np.unique(key, return_index=True, return_inverse=True)
    return points[first], inverse.ravel()


def fit_turntable(frames: dict[str, FramePose], orbit: Circle3D, camera: Camera) -> TurntableFit:
    """Refine every frame's pose under the turntable model (see the module docstring)."""

    stems = sorted(frames)
    poses = [frames[s].camera_from_table for s in stems]
    counts = np.array([len(frames[s].table_points) for s in stems])
    frame_of_corner = np.repeat(np.arange(len(stems)), counts)
    # The board has a few hundred corners, seen again in every frame: each frame's pose moves
    # them all at once, then the corners seen are picked (not a 4 x 4 matrix gathered for
    # each of the ~40,000 corners of 200 frames).
    board_points, board_point_of_corner = _distinct_rows(np.concatenate([frames[s].table_points for s in stems]))
    image_points = np.concatenate([frames[s].image_points for s in stems])

    def residuals(params: np.ndarray) -> np.ndarray:
        poses = _unpack(params, len(stems))
        in_camera = board_points @ poses[:, :3, :3].transpose(0, 2, 1) + poses[:, None, :3, 3]  # (frames, points, 3)
        points_camera = in_camera[frame_of_corner, board_point_of_corner]
        return (camera.project(points_camera) - image_points).ravel()

    # Each frame's residual rows are contiguous (frame after frame), frame 0's first: its angle is
    # fixed, so the angles' rows are the rest, in runs starting at `angle_starts`.
    row_starts = 2 * np.concatenate([[0], np.cumsum(counts)[:-1]])
    first_moving = 2 * counts[0]
    angle_starts, has_rows = row_starts[1:] - first_moving, counts[1:] > 0
    n_angles = len(stems) - 1

    def per_angle(values: np.ndarray) -> np.ndarray:
        """Sums over each angle's rows of (..., moving rows) values: (..., angles)."""
        sums = np.zeros((*values.shape[:-1], n_angles))
        if np.any(has_rows):
            sums[..., has_rows] = np.add.reduceat(values, angle_starts[has_rows], axis=-1)
        return sums

    def normal_equations(params: np.ndarray, base: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """JᵀJ and Jᵀr from forward differences in 11 evaluations: one per shared parameter,
        and one for all the angles at once (each frame's angle moves only that frame's
        corners). The angles' block of J has one entry per row, so its products are sums per
        frame: never the dense (rows x frames) matrix."""
        step = 1e-7
        shared = np.empty((_SHARED, len(base)))  # a row per parameter: contiguous, unlike J's columns
        for j in range(_SHARED):
            moved = params.copy()
            moved[j] += step
            shared[j] = (residuals(moved) - base) / step
        moved = params.copy()
        moved[_SHARED:] += step
        angle = ((residuals(moved) - base) / step)[first_moving:]  # row i's derivative by its frame's angle
        normal = np.zeros((len(params), len(params)))
        normal[:_SHARED, :_SHARED] = shared @ shared.T
        cross = per_angle(shared[:, first_moving:] * angle)
        normal[:_SHARED, _SHARED:] = cross
        normal[_SHARED:, :_SHARED] = cross.T
        normal[_SHARED:, _SHARED:] = np.diag(per_angle(angle**2))
        gradient = np.concatenate([shared @ base, per_angle(angle * base[first_moving:])])
        return normal, gradient

    params, converged = _levenberg_marquardt(residuals, normal_equations, _initial_params(poses, orbit))
    rms = float(np.sqrt(2 * np.mean(residuals(params) ** 2)))  # per corner, as PnP's
    pnp_rms = float(
        np.sqrt(np.sum(counts * np.array([frames[s].reprojection_error_px ** 2 for s in stems])) / counts.sum())
    )
    accepted = converged and rms <= _ACCEPT_RATIO * pnp_rms + _ACCEPT_MARGIN_PX
    refined = list(_unpack(params, len(stems))) if accepted else poses
    return TurntableFit(camera_from_tables=dict(zip(stems, refined)), rms_px=rms, pnp_rms_px=pnp_rms, accepted=accepted)
