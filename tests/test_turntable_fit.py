"""The turntable fit (turntable.turntable_model) on synthetic corners of known poses: no
rendering, so it runs in a second. Its normal equations are summed per frame; this checks
that they find the true poses from noisy per-frame ones, as the dense Jacobian did."""

from __future__ import annotations

import numpy as np
import trimesh

from homemodel.core.transforms import world_from_camera_looking_at
from homemodel.evaluation import camera_pose_errors
from homemodel.geometry.camera import Camera
from turntable.board import grid_board
from turntable.orbit import table_axis
from turntable.pose import FramePose
from turntable.turntable_model import fit_turntable

CAMERA = Camera(width=640, height=480, fx=530.0, fy=530.0, cx=319.5, cy=239.5)


def _true_poses(frames: int) -> dict[str, np.ndarray]:
    """A tripod 0.4 m from the axis, 0.5 m up; the board's origin 1.1 cm off the axis."""
    camera_from_world = np.linalg.inv(world_from_camera_looking_at([0.0, -0.4, 0.5], [0.0, 0.0, 0.03]))
    axis_table = np.array([0.011, -0.007, 0.0])
    poses = {}
    for k in range(frames):
        world_from_table = trimesh.transformations.rotation_matrix(2 * np.pi * k / frames, [0, 0, 1])
        world_from_table[:3, 3] = -world_from_table[:3, :3] @ axis_table
        poses[f"{k:06d}"] = camera_from_world @ world_from_table
    return poses


def _perturbed(pose: np.ndarray, rng: np.random.Generator, shift_m: float, turn_rad: float) -> np.ndarray:
    axis = rng.normal(size=3)
    noisy = trimesh.transformations.rotation_matrix(turn_rad, axis / np.linalg.norm(axis)) @ pose
    noisy[:3, 3] += rng.normal(scale=shift_m, size=3)
    return noisy


def test_turntable_fit_recovers_the_true_poses_from_noisy_frames() -> None:
    rng = np.random.default_rng(4)
    board = grid_board(table_diameter_m=0.4, tag_size_m=0.03)
    corners = np.concatenate(list(board.corners_table().values()))
    truth = _true_poses(60)
    frames = {}
    for stem, camera_from_table in truth.items():
        in_camera = corners @ camera_from_table[:3, :3].T + camera_from_table[:3, 3]
        seen = in_camera[:, 2] > 0
        pixels = CAMERA.project(in_camera[seen]) + rng.normal(scale=0.3, size=(int(seen.sum()), 2))
        frames[stem] = FramePose(
            camera_from_table=_perturbed(camera_from_table, rng, 0.0005, np.radians(0.05)),  # PnP-sized errors
            tags=int(seen.sum()) // 4,
            inlier_corners=int(seen.sum()),
            reprojection_error_px=0.3,
            table_points=corners[seen],
            image_points=pixels,
        )
    before, before_deg = camera_pose_errors({s: f.camera_from_table for s, f in frames.items()}, truth)
    orbit = table_axis([f.camera_from_table for f in frames.values()]).orbit
    fit = fit_turntable(frames, orbit, CAMERA)
    assert fit.accepted and fit.rms_px < 0.45, f"rms {fit.rms_px:.3f} px"  # the noise: 0.3 x sqrt(2) per corner
    centre_m, rotation_deg = camera_pose_errors(fit.camera_from_tables, truth)
    # The fit pools every frame's corners: its poses are several times closer than the frames' own.
    assert np.median(centre_m) < np.median(before) / 3, f"{np.median(centre_m) * 1000:.3f} mm"
    assert np.median(rotation_deg) < np.median(before_deg)
    assert np.max(centre_m) < 0.0004 and np.max(rotation_deg) < 0.04
