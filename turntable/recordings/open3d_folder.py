"""Open3D / Redwood RGB-D folders: `color/` (or `image/`, `rgb/`), `depth/` (16-bit PNG,
1 mm unless the intrinsics file says `depth_scale` units a metre), and `intrinsic.json` or
`camera_intrinsic.json` (Open3D's PinholeCameraIntrinsic: width, height, a column-major
`intrinsic_matrix`), as Open3D's RealSense recorder and its reconstruction system write them.
Depth is registered to colour. The frames carry no times: they pair by order, 1/30 s apart
(the recorder's rate)."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from homemodel.core.errors import InputError
from homemodel.core.input_files import read_bounded
from homemodel.geometry.camera import Camera
from turntable.recordings.images import read_depth_units, read_rgb
from turntable.recordings.source import StreamSetup
from turntable.recordings.timed import TimedStreamsSource

COLOR_FOLDERS = ("color", "image", "rgb")
INTRINSICS_FILES = ("intrinsic.json", "camera_intrinsic.json")
FRAME_PERIOD_S = 1 / 30


def _frames(folder: Path, suffixes: tuple[str, ...]) -> list[Path]:
    return sorted(p for p in folder.iterdir() if p.suffix.lower() in suffixes and not p.name.startswith("."))


def read_intrinsics(path: Path) -> tuple[Camera, str | None]:
    """The colour camera (depth_scale_m set) and a note when the depth scale was assumed."""
    try:
        data = json.loads(read_bounded(path, 1 << 20))
        matrix = np.asarray(data["intrinsic_matrix"], dtype=np.float64).reshape(3, 3).T  # column-major
        camera = Camera.from_matrix(matrix, width=int(data["width"]), height=int(data["height"]))
        per_metre = data.get("depth_scale")
        scale = 0.001 if per_metre is None else 1.0 / float(per_metre)
        camera = Camera(**{**camera.model_dump(), "depth_scale_m": scale})
    except (ValueError, KeyError, TypeError, RecursionError) as exc:
        raise InputError(f"{path}: not an Open3D camera intrinsic file: {exc}") from None
    return camera, None if per_metre is not None else "depth units 1 mm (Open3D's default; no depth_scale in the file)"


class Open3dSource(TimedStreamsSource):
    def open(self) -> StreamSetup:
        color_dir = next((self.path / n for n in COLOR_FOLDERS if (self.path / n).is_dir()), None)
        if color_dir is None:
            raise InputError(f"{self.path}: no colour folder (one of {', '.join(COLOR_FOLDERS)})")
        if not (self.path / "depth").is_dir():
            raise InputError(f"{self.path}: no depth folder (depth/)")
        intrinsics = next((self.path / n for n in INTRINSICS_FILES if (self.path / n).is_file()), None)
        if intrinsics is None:
            raise InputError(f"{self.path}: no intrinsics ({' or '.join(INTRINSICS_FILES)})")
        camera, note = read_intrinsics(intrinsics)
        self._colors = _frames(color_dir, (".png", ".jpg", ".jpeg"))
        self._depths = _frames(self.path / "depth", (".png",))
        if not self._depths:
            raise InputError(f"{self.path / 'depth'}: no depth images")
        if len(self._colors) != len(self._depths):  # then only frames with a common stem pair
            stems = {p.stem for p in self._colors} & {p.stem for p in self._depths}
            self._colors = [p for p in self._colors if p.stem in stems]
            self._depths = [p for p in self._depths if p.stem in stems]
        return StreamSetup(format="open3d", color_camera=camera, notes=[note] if note else [])

    def stream_times(self) -> tuple[np.ndarray, np.ndarray]:
        return np.arange(len(self._colors)) * FRAME_PERIOD_S, np.arange(len(self._depths)) * FRAME_PERIOD_S

    def stream_images(self, chosen: list[tuple[int, int]]) -> Iterator[tuple[str, int, np.ndarray]]:
        for i, j in chosen:
            yield "color", i, read_rgb(self._colors[i])
            yield "depth", j, read_depth_units(self._depths[j])
