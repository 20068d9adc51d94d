"""TUM RGB-D folders, and the datasets that copy their layout: `rgb.txt` and `depth.txt`
("timestamp path" a line, # comments), as the TUM benchmark and ETH3D ship them; or only an
associations file of "time path time path" lines, as TUM's `associate.py` writes it (colour
first) and ICL-NUIM ships it (depth first, frame numbers for times). Depth PNGs at 5000 units a
metre, registered to colour by the driver. The intrinsics come from `--camera`, or from
ETH3D's `calibration.txt` ("fx fy cx cy") and the colour images' size.

Lists written by hand or on Windows are read as TUM's own tools read them, and a little more:
fields split by spaces, tabs or commas (TUM's `associate.py` takes a comma for a space), a
decimal comma in a time (`1305031102,175304`, when spaces split the fields), CRLF lines, a
UTF-8 or UTF-16 byte-order mark (PowerShell's `>` writes UTF-16), `\\` in paths."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path, PureWindowsPath

import numpy as np

from homemodel.core.errors import InputError
from homemodel.core.images import read_image, read_image_size
from homemodel.core.input_files import read_bounded
from homemodel.geometry.camera import Camera
from turntable.recordings.images import read_depth_units, read_rgb_of_size
from turntable.recordings.source import StreamSetup
from turntable.recordings.timed import TimedStreamsSource

DEPTH_SCALE_M = 1 / 5000
LISTS = ("rgb.txt", "depth.txt")
ASSOCIATIONS = ("associations.txt", "associated.txt", "associate.txt", "association.txt")
CALIBRATION = "calibration.txt"  # ETH3D's
_MAX_LIST_BYTES = 64 << 20
_DECIMAL_COMMA = re.compile(r"^[+-]?\d+,\d+$")


def _text(path: Path) -> str:
    data = read_bounded(path, _MAX_LIST_BYTES)
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        return data.decode("utf-16", "replace")
    return data.decode("utf-8-sig", "replace")


def _rows(path: Path, columns: int) -> list[tuple[int, list[str]]]:
    """(line number, fields) of the data lines: # comments and blank lines skipped. Fields split
    by white space, else (too few) by commas too, as TUM's associate.py splits them."""
    rows = []
    for number, line in enumerate(_text(path).splitlines(), 1):
        fields = line.split()
        if not fields or fields[0].startswith("#"):
            continue
        if len(fields) < columns or any(f.endswith(",") for f in fields):
            fields = line.replace(",", " ").split()
        if len(fields) < columns:
            raise InputError(f"{path}:{number}: expected {columns} fields, got {line.strip()!r}")
        rows.append((number, fields))
    return rows


def _number(path: Path, number: int, field: str, what: str = "a time stamp") -> float:
    try:
        return float(field.replace(",", ".") if _DECIMAL_COMMA.match(field) else field)
    except ValueError:
        raise InputError(f"{path}:{number}: {field!r} is not {what}") from None


def _file(folder: Path, name: str) -> Path:
    """A listed image, its path written with `/` or Windows' `\\`."""
    return folder / (PureWindowsPath(name).as_posix() if "\\" in name else name)


def _list(path: Path) -> tuple[np.ndarray, list[Path]]:
    rows = _rows(path, 2)
    times = [_number(path, number, fields[0]) for number, fields in rows]
    return np.array(times, dtype=np.float64), [_file(path.parent, fields[1]) for _, fields in rows]


def _is_depth_image(path: Path) -> bool:
    import cv2

    image = read_image(path, cv2.IMREAD_UNCHANGED)
    return image.ndim == 2 and image.dtype == np.uint16


def _associations(path: Path) -> tuple[np.ndarray, list[Path], np.ndarray, list[Path]]:
    """Colour times and files, depth times and files of an associations file, either order:
    the pair whose files lie under a folder named depth is the depth; where the folders do not
    tell (a user's `frames/0001_depth.png`, `aligned/`), the first row's 16-bit image is."""
    rows = _rows(path, 4)
    if not rows:
        return np.zeros(0), [], np.zeros(0), []
    number, first = rows[0]
    files = [_file(path.parent, first[1]), _file(path.parent, first[3])]
    is_depth = ["depth" in f.parent.name.lower() for f in files]
    if is_depth[0] == is_depth[1]:
        is_depth = [_is_depth_image(f) for f in files]
    if is_depth[0] == is_depth[1]:
        raise InputError(
            f"{path}:{number}: cannot tell the colour image from the depth image (neither or both under depth/ "
            "or 16-bit)"
        )
    color_at, depth_at = (2, 0) if is_depth[0] else (0, 2)
    times = {at: [_number(path, n, fields[at]) for n, fields in rows] for at in (color_at, depth_at)}
    return (
        np.array(times[color_at]),
        [_file(path.parent, fields[color_at + 1]) for _, fields in rows],
        np.array(times[depth_at]),
        [_file(path.parent, fields[depth_at + 1]) for _, fields in rows],
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
            self._camera_file = str(self.path / CALIBRATION)
        elif self.camera is not None:
            camera, intrinsics_from = self.camera, "--camera"
            self._camera_file = "--camera's camera file"
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
            yield "color", i, read_rgb_of_size(self._color_files[i], (camera.width, camera.height), self._camera_file)
            yield "depth", j, read_depth_units(self._depth_files[j], (camera.width, camera.height))
