"""Open3D / Redwood RGB-D folders: `color/` (or `image/`, `rgb/`), `depth/` (16-bit PNG), and
the intrinsics as Open3D's PinholeCameraIntrinsic JSON (width, height, a column-major
`intrinsic_matrix`; or PinholeCameraParameters, holding one under `intrinsic`):
`intrinsic.json` (Open3D's RSBagReader.save_frames, with `depth_scale` units a metre),
`camera_intrinsic.json` (its RealSense recorder), `camera_primesense.json` (its Redwood
sample), or any JSON in the folder holding an `intrinsic_matrix`. Without one,
the camera comes from `--camera` (Redwood's object scans ship none). Depth is registered to
colour, 1 mm unless `depth_scale` says otherwise. The recording may also be given as the
reconstruction system's config JSON: its `path_dataset`, `path_intrinsic` and `depth_scale`.

Frames are numbered files (`00000.jpg`, or `0.png`, `1.png`, ... in number order) paired by
order, placed 1/30 s apart (the recorders' rate) for --start/--end but not timed: a recorder
numbers the frames it kept, so a number is no time (`StreamSetup.timed`); Redwood's scans name
each frame `NNNNNNN-TTTTTTTTTTTT` (its number, its time in microseconds), and those pair by time."""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pydantic

from homemodel.core.errors import InputError
from homemodel.core.input_files import read_bounded
from homemodel.core.yaml_specs import describe_validation_error
from homemodel.geometry.camera import Camera
from turntable.recordings.images import read_depth_units, read_rgb_of_size
from turntable.recordings.source import StreamSetup
from turntable.recordings.timed import TimedStreamsSource

COLOR_FOLDERS = ("color", "image", "rgb")
INTRINSICS_FILES = ("intrinsic.json", "camera_intrinsic.json")
FRAME_PERIOD_S = 1 / 30
_REDWOOD_NAME = re.compile(r"^\d+-(\d+)$")  # frame number - microseconds
_MAX_JSON_BYTES = 1 << 20


def _number_order(path: Path) -> tuple:
    """`10.png` after `9.png`: runs of digits compared as numbers."""
    return tuple(int(part) if part.isdigit() else part for part in re.split(r"(\d+)", path.stem))


def _frames(folder: Path, suffixes: tuple[str, ...]) -> list[Path]:
    found = (p for p in folder.iterdir() if p.suffix.lower() in suffixes and not p.name.startswith("."))
    return sorted(found, key=_number_order)


def read_intrinsics(path: Path) -> tuple[Camera, list[str]]:
    """The colour camera (depth_scale_m set) and notes on what was assumed."""
    try:
        data = json.loads(read_bounded(path, _MAX_JSON_BYTES))
        if not isinstance(data, dict):
            raise TypeError(f"a JSON {type(data).__name__}, not an object")
        if "intrinsic_matrix" not in data and isinstance(data.get("intrinsic"), dict):
            data = data["intrinsic"]  # PinholeCameraParameters (write_pinhole_camera_parameters)
        matrix = np.asarray(data["intrinsic_matrix"], dtype=np.float64).reshape(3, 3).T  # column-major
        row_major = not np.allclose(matrix[2], [0, 0, 1]) and np.allclose(matrix[:, 2], [0, 0, 1])
        if row_major:  # written by hand in reading order: its last row would carry cx, cy
            matrix = matrix.T
        camera = Camera.from_matrix(matrix, width=int(data["width"]), height=int(data["height"]))
        per_metre = data.get("depth_scale")
        scale = 0.001 if per_metre is None else 1.0 / float(per_metre)
        camera = Camera(**{**camera.model_dump(), "depth_scale_m": scale})
    except pydantic.ValidationError as exc:  # numbers a camera cannot have (a zero focal length)
        raise InputError(f"{path}: not an Open3D camera intrinsic file: {describe_validation_error(exc)}") from None
    except KeyError as exc:  # a JSON of another shape (a user's {"fx": ...}, OpenCV's camera_matrix)
        keys = ", ".join(str(key) for key in list(data)[:8]) if isinstance(data, dict) else ""
        raise InputError(f"{path}: not an Open3D camera intrinsic file: no {exc.args[0]} (its keys: {keys})") from None
    except (ValueError, TypeError, RecursionError, ZeroDivisionError) as exc:
        raise InputError(f"{path}: not an Open3D camera intrinsic file: {exc}") from None
    notes = ["intrinsic_matrix read row-major (Open3D writes it column-major: its last row held cx, cy)"] if row_major else []
    if per_metre is None:
        notes.append("depth units 1 mm (Open3D's default; no depth_scale in the file)")
    return camera, notes


def intrinsics_file(folder: Path) -> Path | None:
    """The folder's PinholeCameraIntrinsic JSON: a known name first, else any JSON with an
    intrinsic_matrix (Open3D reads whatever name its caller gives)."""
    named = next((folder / n for n in INTRINSICS_FILES if (folder / n).is_file()), None)
    if named is not None:
        return named
    for path in sorted(folder.glob("*.json")):
        if path.is_file() and _json_naming(path, "intrinsic_matrix"):
            return path
    return None


def _json_naming(path: Path, key: str) -> bool:
    """A JSON file small enough to read that holds `key` (a sniff: a larger one is not ours)."""
    return path.stat().st_size < _MAX_JSON_BYTES and f'"{key}"'.encode() in read_bounded(path, _MAX_JSON_BYTES)


def is_config(path: Path) -> bool:
    """An Open3D reconstruction system config (a JSON naming its `path_dataset`)."""
    return path.suffix.lower() == ".json" and _json_naming(path, "path_dataset")


def read_config(path: Path) -> tuple[Path, Path | None, float | None]:
    """An Open3D reconstruction system config's dataset folder, its intrinsics file (None: not
    named) and its depth units a metre (None: not said). Relative paths are tried from the
    config's folder, then from the working folder (where Open3D's scripts run)."""
    try:
        data = json.loads(read_bounded(path, _MAX_JSON_BYTES))
        dataset, named, per_metre = str(data["path_dataset"]), data.get("path_intrinsic") or None, data.get("depth_scale")
        per_metre = None if per_metre is None else float(per_metre)
    except (ValueError, KeyError, TypeError, RecursionError) as exc:
        raise InputError(f"{path}: not an Open3D reconstruction config: {exc}") from None
    if per_metre is not None and not per_metre > 0:
        raise InputError(f"{path}: depth_scale {per_metre} is not positive")

    def resolve(value: str) -> Path:
        given = Path(value).expanduser()
        tried = [given] if given.is_absolute() else [path.parent / given, Path.cwd() / given]
        return next((p for p in tried if p.exists()), tried[0])

    return resolve(dataset), None if named is None else resolve(str(named)), per_metre


def _redwood_times_s(files: list[Path]) -> np.ndarray | None:
    matches = [_REDWOOD_NAME.match(p.stem) for p in files]
    if not files or not all(matches):
        return None
    return np.array([1e-6 * int(m.group(1)) for m in matches])


class Open3dSource(TimedStreamsSource):
    def __init__(self, path: Path, *, camera: Camera | None = None, **kwargs: object) -> None:
        super().__init__(path, **kwargs)
        self.camera = camera

    def open(self) -> StreamSetup:
        folder, intrinsics, per_metre = self.path, None, None
        if self.path.is_file():
            folder, intrinsics, per_metre = read_config(self.path)
        color_dir = next((folder / n for n in COLOR_FOLDERS if (folder / n).is_dir()), None)
        if color_dir is None:
            raise InputError(f"{folder}: no colour folder (one of {', '.join(COLOR_FOLDERS)})")
        if not (folder / "depth").is_dir():
            raise InputError(f"{folder}: no depth folder (depth/)")
        intrinsics = intrinsics or intrinsics_file(folder)
        notes = []
        unread = None
        if intrinsics is not None:
            try:
                camera, intrinsics_notes = read_intrinsics(intrinsics)
            except InputError as exc:
                if self.camera is None:
                    raise
                unread = f"{exc}: --camera's camera file taken"
        if intrinsics is not None and unread is None:
            notes += [n for n in intrinsics_notes if per_metre is None or not n.startswith("depth units")]
            intrinsics_from, self._camera_file = "recording", str(intrinsics)
        elif self.camera is not None:
            camera, intrinsics_from = self.camera, "--camera"
            self._camera_file = "--camera's camera file"
            notes += [unread] if unread else []
        else:
            raise InputError(
                f"{folder}: no intrinsics ({' or '.join(INTRINSICS_FILES)}, or a JSON with an intrinsic_matrix); "
                "give them with --camera camera.yaml"
            )
        if per_metre is not None:
            camera = Camera(**{**camera.model_dump(), "depth_scale_m": 1.0 / per_metre})
        self._colors = _frames(color_dir, (".png", ".jpg", ".jpeg"))
        self._depths = _frames(folder / "depth", (".png",))
        if not self._depths:
            others = _frames(folder / "depth", (".jpg", ".jpeg", ".tif", ".tiff"))
            found = f" ({len(others)} {others[0].suffix} files: depth must be 16-bit PNG)" if others else ""
            raise InputError(f"{folder / 'depth'}: no depth images{found}")
        self._times = (_redwood_times_s(self._colors), _redwood_times_s(self._depths))
        if self._times[0] is None or self._times[1] is None:
            self._times = None
            if len(self._colors) != len(self._depths):  # then only frames with a common stem pair
                stems = {p.stem for p in self._colors} & {p.stem for p in self._depths}
                notes.append(
                    f"{len(self._colors)} colour and {len(self._depths)} depth images: the {len(stems)} of one number "
                    f"paired, {len(self._colors) - len(stems)} colour and {len(self._depths) - len(stems)} depth left out"
                )
                self._colors = [p for p in self._colors if p.stem in stems]
                self._depths = [p for p in self._depths if p.stem in stems]
        timed = self._times is not None
        return StreamSetup(format="open3d", color_camera=camera, intrinsics_from=intrinsics_from, notes=notes, timed=timed)

    def stream_times(self) -> tuple[np.ndarray, np.ndarray]:
        if self._times is not None:
            return self._times
        return np.arange(len(self._colors)) * FRAME_PERIOD_S, np.arange(len(self._depths)) * FRAME_PERIOD_S

    def stream_images(self, chosen: list[tuple[int, int]]) -> Iterator[tuple[str, int, np.ndarray]]:
        camera = self.setup.color_camera
        for i, j in chosen:
            yield "color", i, read_rgb_of_size(self._colors[i], (camera.width, camera.height), self._camera_file)
            yield "depth", j, read_depth_units(self._depths[j], (camera.width, camera.height))
