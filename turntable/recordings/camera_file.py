"""`turntable import --camera camera.yaml`: the colour camera's intrinsics, for a recording that
carries none (TUM, Redwood), and/or `color_from_depth`, the depth camera's pose in colour's
frame, for an unregistered depth whose recording does not give it (a ROS bag without
/tf_static, a RealSense .bag without extrinsics). A file of `color_from_depth` alone serves a
recording with intrinsics of its own."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pydantic

from homemodel.core.transforms import rigid_transform, rotation_angle_rad
from homemodel.core.yaml_specs import read_yaml_mapping, validate_mapping
from homemodel.geometry.camera import Camera
from turntable.recordings.source import StreamSetup

FIELD = "color_from_depth"
# The recording's pose and the file's differ past these: said (the recording's kept).
_DISAGREE_M, _DISAGREE_DEG = 0.001, 0.1


class _DepthPose(pydantic.BaseModel):
    model_config = pydantic.ConfigDict(extra="forbid")

    # 4x4 nested list, row-major, metres, OpenCV camera axes: a depth point p lands at
    # color_from_depth @ p in colour's frame (ROS's /tf_static from the depth optical frame to
    # colour's; a RealSense's depth-to-colour extrinsics).
    color_from_depth: list[list[float]]

    @pydantic.field_validator(FIELD)
    @classmethod
    def _rigid(cls, value: list[list[float]]) -> list[list[float]]:
        return rigid_transform(value, "the matrix").tolist()


@dataclass
class CameraFile:
    camera: Camera | None  # None: the file gives only the depth camera's pose
    color_from_depth: np.ndarray | None


def load_camera_file(path: Path) -> CameraFile:
    """The intrinsics and the depth camera's pose --camera's file gives; refuses, naming the
    file and the field, a file of neither or a pose that is not a rigid transform."""
    data = read_yaml_mapping(Path(path))
    pose = None
    if FIELD in data:
        pose = validate_mapping(Path(path), {FIELD: data.pop(FIELD)}, _DepthPose).color_from_depth
    camera = validate_mapping(Path(path), data, Camera) if data or pose is None else None
    return CameraFile(camera=camera, color_from_depth=None if pose is None else np.asarray(pose, dtype=np.float64))


def take_depth_pose(setup: StreamSetup, color_from_depth: np.ndarray) -> None:
    """--camera's `color_from_depth` for the recording's depth, said in a note: taken where the
    recording gives no pose; the recording's kept where it does (a difference said)."""
    if setup.depth_camera is None:
        setup.notes.append(f"--camera's {FIELD} not used: the recording's depth is registered to colour")
        return
    if setup.color_from_depth is None:
        setup.color_from_depth, setup.depth_pose_given = color_from_depth, True
        setup.notes.append(f"the depth camera's pose from --camera's {FIELD}")
        return
    shift_m = float(np.linalg.norm(setup.color_from_depth[:3, 3] - color_from_depth[:3, 3]))
    turn_deg = float(np.degrees(rotation_angle_rad(setup.color_from_depth[:3, :3].T @ color_from_depth[:3, :3])))
    if shift_m > _DISAGREE_M or turn_deg > _DISAGREE_DEG:
        setup.notes.append(
            f"--camera's {FIELD} is {1000 * shift_m:.1f} mm and {turn_deg:.2f} deg from the recording's (the recording's kept)"
        )
