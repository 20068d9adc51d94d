"""TUM RGB-D folders: `rgb.txt` and `depth.txt` ("timestamp path" a line, # comments), depth
PNGs at 5000 units a metre, registered to colour by the Kinect's driver. They carry no
intrinsics: the camera comes from `--camera`."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np

from homemodel.core.errors import InputError
from homemodel.core.input_files import read_bounded
from homemodel.geometry.camera import Camera
from turntable.recordings.images import read_depth_units, read_rgb
from turntable.recordings.source import StreamSetup
from turntable.recordings.timed import TimedStreamsSource

DEPTH_SCALE_M = 1 / 5000
_MAX_LIST_BYTES = 64 << 20


def _list(path: Path) -> tuple[np.ndarray, list[Path]]:
    if not path.is_file():
        raise InputError(f"{path}: missing (a TUM folder has rgb.txt and depth.txt)")
    times, files = [], []
    for number, line in enumerate(read_bounded(path, _MAX_LIST_BYTES).decode("utf-8", "replace").splitlines(), 1):
        fields = line.split()
        if not fields or fields[0].startswith("#"):
            continue
        try:
            times.append(float(fields[0]))
            files.append(path.parent / fields[1])
        except (ValueError, IndexError):
            raise InputError(f"{path}:{number}: expected 'timestamp filename', got {line.strip()!r}") from None
    return np.array(times, dtype=np.float64), files


class TumSource(TimedStreamsSource):
    def __init__(self, path: Path, *, camera: Camera | None, **kwargs: object) -> None:
        super().__init__(path, **kwargs)
        self.camera = camera

    def open(self) -> StreamSetup:
        if self.camera is None:
            raise InputError(f"{self.path}: a TUM recording carries no intrinsics; give them with --camera camera.yaml")
        self._color_t, self._color_files = _list(self.path / "rgb.txt")
        self._depth_t, self._depth_files = _list(self.path / "depth.txt")
        if len(self._depth_t) == 0:
            raise InputError(f"{self.path / 'depth.txt'}: no depth frames")
        camera = Camera(**{**self.camera.model_dump(), "depth_scale_m": DEPTH_SCALE_M})
        notes = []
        if self.camera.depth_scale_m != DEPTH_SCALE_M:
            notes.append(f"depth units 1/5000 m (TUM's), not --camera's {self.camera.depth_scale_m:g} m")
        return StreamSetup(format="tum", color_camera=camera, intrinsics_from="--camera", notes=notes)

    def stream_times(self) -> tuple[np.ndarray, np.ndarray]:
        return self._color_t, self._depth_t

    def stream_images(self, chosen: list[tuple[int, int]]) -> Iterator[tuple[str, int, np.ndarray]]:
        for i, j in chosen:
            yield "color", i, read_rgb(self._color_files[i])
            yield "depth", j, read_depth_units(self._depth_files[j])
