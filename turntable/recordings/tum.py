"""TUM RGB-D folders, and the datasets that copy their layout: `rgb.txt` and `depth.txt`
("timestamp path" a line, # comments), as the TUM benchmark and ETH3D ship them; or only an
associations file of "time path time path" lines, as TUM's `associate.py` writes it (colour
first) and ICL-NUIM ships it (depth first, frame numbers for times). Depth PNGs at 5000 units a
metre, registered to colour by the driver. The intrinsics come from `--camera`, or from
ETH3D's `calibration.txt` ("fx fy cx cy") and the colour images' size."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np

from homemodel.core.errors import InputError
from homemodel.core.images import read_image_size
from homemodel.core.input_files import read_bounded
from homemodel.geometry.camera import Camera
from turntable.recordings.images import read_depth_units, read_rgb
from turntable.recordings.source import StreamSetup
from turntable.recordings.timed import TimedStreamsSource

DEPTH_SCALE_M = 1 / 5000
LISTS = ("rgb.txt", "depth.txt")
ASSOCIATIONS = ("associations.txt", "associated.txt", "associate.txt", "association.txt")
CALIBRATION = "calibration.txt"  # ETH3D's
_MAX_LIST_BYTES = 64 << 20


def _rows(path: Path, columns: int) -> list[tuple[int, list[str]]]:
    """(line number, fields) of the data lines: # comments and blank lines skipped."""
    rows = []
    for number, line in enumerate(read_bounded(path, _MAX_LIST_BYTES).decode("utf-8", "replace").splitlines(), 1):
        fields = line.split()
        if not fields or fields[0].startswith("#"):
            continue
        if len(fields) < columns:
            raise InputError(f"{path}:{number}: expected {columns} fields, got {line.strip()!r}")
        rows.append((number, fields))
    return rows


def _number(path: Path, number: int, field: str, what: str = "a time stamp") -> float:
    try:
        return float(field)
    except ValueError:
        raise InputError(f"{path}:{number}: {field!r} is not {what}") from None


def _list(path: Path) -> tuple[np.ndarray, list[Path]]:
    rows = _rows(path, 2)
    times = [_number(path, number, fields[0]) for number, fields in rows]
    return np.array(times, dtype=np.float64), [path.parent / fields[1] for _, fields in rows]


def _associations(path: Path) -> tuple[np.ndarray, list[Path], np.ndarray, list[Path]]:
    """Colour times and files, depth times and files of an associations file, either order:
    the pair whose files lie under a folder named depth is the depth."""
    rows = _rows(path, 4)
    if not rows:
        return np.zeros(0), [], np.zeros(0), []
    depth_first = "depth" in Path(rows[0][1][1]).parent.name.lower()
    if depth_first == ("depth" in Path(rows[0][1][3]).parent.name.lower()):
        raise InputError(f"{path}:{rows[0][0]}: cannot tell the colour image from the depth image (neither or both under depth/)")
    color_at, depth_at = (2, 0) if depth_first else (0, 2)
    times = {at: [_number(path, number, fields[at]) for number, fields in rows] for at in (color_at, depth_at)}
    return (
        np.array(times[color_at]),
        [path.parent / fields[color_at + 1] for _, fields in rows],
        np.array(times[depth_at]),
        [path.parent / fields[depth_at + 1] for _, fields in rows],
    )


def _calibration_camera(path: Path, first_color: Path) -> Camera:
    rows = _rows(path, 4)
    if not rows:
        raise InputError(f"{path}: no 'fx fy cx cy' line")
    number, fields = rows[0]
    fx, fy, cx, cy = (_number(path, number, f, "a number (fx fy cx cy)") for f in fields[:4])
    height, width = read_image_size(first_color)
    try:
        return Camera(width=width, height=height, fx=fx, fy=fy, cx=cx, cy=cy)
    except ValueError as exc:
        raise InputError(f"{path}: not a camera: {exc}") from None


def associations_file(folder: Path) -> Path | None:
    return next((folder / name for name in ASSOCIATIONS if (folder / name).is_file()), None)


class TumSource(TimedStreamsSource):
    def __init__(self, path: Path, *, camera: Camera | None, **kwargs: object) -> None:
        super().__init__(path, **kwargs)
        self.camera = camera

    def open(self) -> StreamSetup:
        lists = [self.path / name for name in LISTS]
        associations = associations_file(self.path)
        if all(p.is_file() for p in lists) or associations is None:
            for listed in lists:
                if not listed.is_file():
                    raise InputError(f"{listed}: missing (a TUM folder has rgb.txt and depth.txt, or {ASSOCIATIONS[0]})")
            (self._color_t, self._color_files), (self._depth_t, self._depth_files) = _list(lists[0]), _list(lists[1])
            depth_list = lists[1]
        else:
            self._color_t, self._color_files, self._depth_t, self._depth_files = _associations(associations)
            depth_list = associations
        if len(self._depth_t) == 0:
            raise InputError(f"{depth_list}: no depth frames")
        notes = []
        if (self.path / CALIBRATION).is_file() and self._color_files:  # the recording's own win over --camera's
            camera, intrinsics_from = _calibration_camera(self.path / CALIBRATION, self._color_files[0]), "recording"
        elif self.camera is not None:
            camera, intrinsics_from = self.camera, "--camera"
            if self.camera.depth_scale_m != DEPTH_SCALE_M:
                notes.append(f"depth units 1/5000 m (TUM's), not --camera's {self.camera.depth_scale_m:g} m")
        else:
            raise InputError(f"{self.path}: a TUM recording carries no intrinsics; give them with --camera camera.yaml")
        camera = Camera(**{**camera.model_dump(), "depth_scale_m": DEPTH_SCALE_M})
        return StreamSetup(format="tum", color_camera=camera, intrinsics_from=intrinsics_from, notes=notes)

    def stream_times(self) -> tuple[np.ndarray, np.ndarray]:
        return self._color_t, self._depth_t

    def stream_images(self, chosen: list[tuple[int, int]]) -> Iterator[tuple[str, int, np.ndarray]]:
        camera = self.setup.color_camera
        for i, j in chosen:
            yield "color", i, read_rgb(self._color_files[i])
            yield "depth", j, read_depth_units(self._depth_files[j], (camera.width, camera.height))
