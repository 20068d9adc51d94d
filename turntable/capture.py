"""A turntable capture folder (its format: docs/turntable.md): camera.yaml, board.yaml, and colour
and depth frames paired by file stem."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from homemodel.core.errors import InputError
from homemodel.core.images import read_image
from homemodel.core.input_files import read_bounded
from homemodel.geometry.camera import Camera, load_camera
from homemodel.geometry.depth_io import read_depth_m
from turntable.board import Board, load_board

COLOR_SUFFIXES = (".png", ".jpg", ".jpeg")
DEPTH_SUFFIXES = (".png", ".exr")
SIMULATION_JSON = "simulation.json"  # `turntable simulate`'s options, beside the frames it rendered


@dataclass(kw_only=True)
class FramePaths:
    stem: str
    color: Path
    depth: Path


@dataclass(kw_only=True)
class Capture:
    folder: Path
    camera: Camera
    board: Board
    frames: list[FramePaths]
    unpaired: list[str]  # stems with only a colour or only a depth image
    recording: dict | None = None  # recording.json: what `turntable import` read, associated and dropped
    simulated: bool = False  # written by `turntable simulate` (its simulation.json): linear renders

    def registration_edge_offset_px(self) -> np.ndarray:
        """(dx, dy): what the misregistration estimate reads on the import's own registration with
        an exact extrinsic (recording.json's `registration_edge_offset_px`, see
        `recordings.register.expected_edge_offset_px`); (0, 0) without two finite numbers there."""
        value = (self.recording or {}).get("registration_edge_offset_px")
        if isinstance(value, list) and len(value) == 2 and all(isinstance(v, (int, float)) and math.isfinite(v) for v in value):
            return np.array(value, dtype=float)
        return np.zeros(2)


class FrameError(InputError):
    """One frame's image is unreadable or of the wrong size; the pipeline skips and counts it."""


def _images(folder: Path, suffixes: tuple[str, ...]) -> dict[str, Path]:
    if not folder.is_dir():
        return {}
    found: dict[str, Path] = {}
    for path in sorted(folder.iterdir()):
        if path.suffix.lower() in suffixes and not path.name.startswith("."):
            if path.stem in found:
                raise InputError(f"{folder}: frame {path.stem} exists as both {found[path.stem].name} and {path.name}")
            found[path.stem] = path
    return found


def load_capture(folder: Path) -> Capture:
    """Read the capture's YAML files and pair its frames; refuses a folder without frames."""
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{folder}: no such capture folder")
    camera = load_camera(folder / "camera.yaml")
    board = load_board(folder / "board.yaml")
    colors = _images(folder / "color", COLOR_SUFFIXES)
    depths = _images(folder / "depth", DEPTH_SUFFIXES)
    stems = sorted(set(colors) & set(depths))
    recording = None
    if (folder / "recording.json").is_file():
        try:
            recording = json.loads(read_bounded(folder / "recording.json", 1 << 20))
        except (ValueError, RecursionError) as exc:
            raise InputError(f"{folder / 'recording.json'}: not JSON: {exc}") from None
    if not stems:
        raise InputError(
            f"{folder}: no frames (expected color/NNNNNN.png and depth/NNNNNN.png pairs; "
            f"found {len(colors)} colour and {len(depths)} depth images)"
        )
    return Capture(
        folder=folder,
        camera=camera,
        board=board,
        frames=[FramePaths(stem=s, color=colors[s], depth=depths[s]) for s in stems],
        unpaired=sorted(set(colors) ^ set(depths)),
        recording=recording,
        simulated=(folder / SIMULATION_JSON).is_file(),
    )


def read_color(path: Path, camera: Camera) -> np.ndarray:
    """(H, W, 3) uint8 RGB; raises FrameError if unreadable or not camera-sized."""
    import cv2

    try:
        image = read_image(path)
    except InputError as exc:
        raise FrameError(str(exc)) from None
    _check_size(path, image.shape[:2], camera)
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)


def read_depth(path: Path, camera: Camera) -> np.ndarray:
    """(H, W) metres, NaN where missing; raises FrameError if unreadable or not camera-sized."""
    try:
        depth = read_depth_m(path, depth_scale_m=camera.depth_scale_m)
    except InputError as exc:
        raise FrameError(str(exc)) from None
    _check_size(path, depth.shape, camera)
    return depth


def _check_size(path: Path, shape: tuple[int, ...], camera: Camera) -> None:
    if tuple(shape) != (camera.height, camera.width):
        raise FrameError(f"{path}: {shape[1]}x{shape[0]} pixels but camera.yaml says {camera.width}x{camera.height}")
