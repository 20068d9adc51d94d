"""The observation folder: what `homemodel map observe` reads and `map simulate-view` writes.

    OBS_DIR/
      depth.png     16-bit; metres = value * depth_scale_m; 0 = no reading
      color.png     optional, 8-bit RGB registered to depth (same size)
      camera.yaml   width, height, fx, fy, cx, cy, depth_scale_m (optional distortion) and
                    map_from_camera: the camera's pose in the map, 4x4 nested list, row-major,
                    metres, OpenCV axes (x right, y down, z forward)
      truth.json    simulated views only: the true joint positions, poses and visibility
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from homemodel.core.atomic import write_bytes_atomic, write_json
from homemodel.core.errors import InputError
from homemodel.core.images import read_image
from homemodel.core.input_files import read_bounded
from homemodel.core.transforms import rigid_transform
from homemodel.core.yaml_specs import write_yaml
from homemodel.geometry.camera import Camera, camera_mapping, load_camera_and_pose
from homemodel.geometry.depth_io import read_depth_m, write_depth

DEPTH_FILE = "depth.png"
COLOR_FILE = "color.png"
CAMERA_FILE = "camera.yaml"
TRUTH_FILE = "truth.json"
MAX_TRUTH_BYTES = 64 * 1024 * 1024


def load_observation_camera(path: Path, *, need_pose: bool = True) -> tuple[Camera, np.ndarray | None]:
    """The camera and `map_from_camera` of a camera.yaml; `need_pose` makes the pose required."""
    camera, map_from_camera = load_camera_and_pose(Path(path))
    if map_from_camera is None and need_pose:
        raise InputError(f"{path}: map_from_camera: missing (the camera's pose in the map, a 4x4 nested list)")
    return camera, map_from_camera


def save_observation_camera(path: Path, camera: Camera, map_from_camera: np.ndarray) -> None:
    data = camera_mapping(camera)
    data["map_from_camera"] = [[float(v) for v in row] for row in rigid_transform(map_from_camera, "map_from_camera")]
    write_yaml(Path(path), data, flow_style=None)


@dataclass(kw_only=True)
class Observation:
    """One depth image from a camera at a known pose in the map.

    `depth_m` is metres, 0 where the sensor gave no reading (the file's convention);
    `color_rgb` is 8-bit RGB of the same size, or None; `truth` is a simulated view's truth.json.
    """

    camera: Camera
    map_from_camera: np.ndarray
    depth_m: np.ndarray
    color_rgb: np.ndarray | None = None
    truth: dict | None = None

    def __post_init__(self) -> None:
        self.map_from_camera = rigid_transform(self.map_from_camera, "map_from_camera")
        expected = (self.camera.height, self.camera.width)
        if np.shape(self.depth_m) != expected:
            raise ValueError(f"{np.shape(self.depth_m)=} but expected {expected}")
        if self.color_rgb is not None and np.shape(self.color_rgb) != (*expected, 3):
            raise ValueError(f"{np.shape(self.color_rgb)=} but expected {(*expected, 3)}")


def read_observation(folder: Path) -> Observation:
    """Read an observation folder, checking what `map observe` relies on: one-line errors for a
    missing file, a depth or colour image whose size differs from camera.yaml, a
    `map_from_camera` that is not a rigid transform."""
    import cv2

    folder = Path(folder)
    if not folder.is_dir():  # a file given as OBS_DIR (the map, a depth.png) exists: say so
        raise InputError(f"{folder}: not an observation folder ({'a file' if folder.exists() else 'no such folder'})")
    for name in (CAMERA_FILE, DEPTH_FILE):
        if not (folder / name).is_file():
            raise InputError(f"{folder}: the observation has no {name}")
    camera, map_from_camera = load_observation_camera(folder / CAMERA_FILE)
    depth_path = folder / DEPTH_FILE
    depth = np.nan_to_num(read_depth_m(depth_path, depth_scale_m=camera.depth_scale_m).astype(np.float64), nan=0.0)
    _check_size(depth_path, depth.shape, camera)
    color = None
    if (folder / COLOR_FILE).is_file():
        bgr = read_image(folder / COLOR_FILE, cv2.IMREAD_COLOR)
        _check_size(folder / COLOR_FILE, bgr.shape[:2], camera)
        color = np.ascontiguousarray(bgr[:, :, ::-1])
    truth = None
    if (folder / TRUTH_FILE).is_file():
        try:
            truth = json.loads(read_bounded(folder / TRUTH_FILE, MAX_TRUTH_BYTES))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise InputError(f"{folder / TRUTH_FILE}: not valid JSON: {exc}") from None
    return Observation(camera=camera, map_from_camera=map_from_camera, depth_m=depth, color_rgb=color, truth=truth)


def _check_size(path: Path, shape: tuple[int, ...], camera: Camera) -> None:
    height, width = shape[:2]
    if (width, height) != (camera.width, camera.height):
        raise InputError(
            f"{path}: the image is {width}x{height} but {CAMERA_FILE} says {camera.width}x{camera.height}"
        )


def write_observation(folder: Path, observation: Observation) -> None:
    """Write the observation's files into `folder` (each atomically); the caller makes the
    folder itself appear at once (`homemodel.core.atomic.atomic_dir`)."""
    import cv2

    folder = Path(folder)
    depth = np.where(observation.depth_m > 0, observation.depth_m, np.nan)
    write_depth(folder / DEPTH_FILE, depth, depth_scale_m=observation.camera.depth_scale_m)
    if observation.color_rgb is not None:
        ok, encoded = cv2.imencode(".png", np.ascontiguousarray(observation.color_rgb[:, :, ::-1]))
        if not ok:
            raise InputError(f"{folder / COLOR_FILE}: could not encode the colour PNG")
        write_bytes_atomic(folder / COLOR_FILE, encoded.tobytes())
    save_observation_camera(folder / CAMERA_FILE, observation.camera, observation.map_from_camera)
    if observation.truth is not None:
        write_json(folder / TRUTH_FILE, observation.truth)
