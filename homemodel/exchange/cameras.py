"""`cameras.json`: the one per-view camera file. Every pipeline that knows its views' cameras
writes it (turntable: `cameras.json` and a simulation's `true_cameras.json`, photogrammetry:
`cameras.json`), and every reader reads it here.

```json
{"format": "homemodel-cameras", "version": 1,
 "frame": "table",
 "convention": "camera_from_table maps ...",
 "cameras": {"camera0": {"width": 640, "height": 480, "fx": ..., "fy": ..., "cx": ..., "cy": ...}},
 "views": [{"name": "000000", "camera": "camera0", "camera_from_table": [[4 x 4]], ...the view's figures}],
 "skipped": [{"name": "000007", "reason": "pose: 2 tags seen, 3 needed"}]}
```

- `frame` names the frame the poses map from: `table` (a turntable's board frame, z up out of the
  table top) or `model` (the model folder's frame, that of model.urdf); each view's pose is the
  key `camera_from_<frame>`, a row-major 4x4, OpenCV camera axes, in metres (or the SfM units of
  an unscaled photogrammetry model);
- `cameras` holds each distinct camera once, in the fields of a `camera.yaml` (`Camera`), and a
  view names its camera. A `camera.yaml` stays the one-camera input of a capture, a completion
  query or an observation; this file is the many views of a reconstruction.

`read_cameras` also reads the two shapes written before this one, which may still lie in old
folders: turntable's `poses.json`/`true_poses.json` (`frames`, `camera_from_table`, no
intrinsics) and photogrammetry's list of `{name, intrinsics (K), camera_from_model, width_px,
height_px}`.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pydantic

from homemodel.core.atomic import write_json
from homemodel.core.errors import InputError
from homemodel.core.input_files import read_bounded
from homemodel.geometry.camera import Camera, camera_mapping

FORMAT = "homemodel-cameras"
VERSION = 1
CAMERAS_FILE = "cameras.json"
TRUE_CAMERAS_FILE = "true_cameras.json"  # a simulation's true views, beside its capture
OLD_TRUE_POSES_FILE = "true_poses.json"  # what captures simulated before true_cameras.json hold
MAX_BYTES = 64 * 1024 * 1024
FRAMES = {
    "table": "table-frame points (board frame, z up out of the table top, metres)",
    "model": "model-frame points (the frame of model.urdf; metres, or SfM units when unscaled)",
}


@dataclass(frozen=True, kw_only=True)
class CameraView:
    """One view: its camera and `camera_from_frame` (the file's frame), with figures of its own."""

    name: str
    camera: Camera | None  # None only from an old poses.json, which held no intrinsics
    camera_from_frame: np.ndarray  # 4x4
    figures: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, kw_only=True)
class CameraViews:
    frame: str  # a key of FRAMES
    views: list[CameraView]
    skipped: dict[str, str] = field(default_factory=dict)  # view name -> why it has no pose

    @property
    def poses(self) -> dict[str, np.ndarray]:
        """`camera_from_<frame>` by view name."""
        return {v.name: v.camera_from_frame for v in self.views}


def true_cameras_file(capture_dir: Path) -> Path:
    """The file of a simulated capture's true views: its true_cameras.json, or the true_poses.json
    of a capture simulated before that."""
    path = Path(capture_dir) / TRUE_CAMERAS_FILE
    old = Path(capture_dir) / OLD_TRUE_POSES_FILE
    return old if not path.exists() and old.exists() else path


def _convention(frame: str) -> str:
    return (
        f"camera_from_{frame} maps {FRAMES[frame]} to the camera frame (OpenCV: x right, y down, z forward); "
        "each view's camera is one of `cameras`, in the fields of a camera.yaml"
    )


def write_cameras(
    path: Path, views: Iterable[CameraView], *, frame: str, skipped: Mapping[str, str] | None = None
) -> None:
    """Write the views (atomically), in name order, each distinct camera once."""
    if frame not in FRAMES:
        raise ValueError(f"{frame=} but expected one of {sorted(FRAMES)}")
    ids: dict[Camera, str] = {}
    entries = []
    for view in sorted(views, key=lambda v: v.name):
        if view.camera is None:
            raise ValueError(f"view {view.name}: no camera")
        camera_id = ids.setdefault(view.camera, f"camera{len(ids)}")
        pose = np.asarray(view.camera_from_frame, dtype=np.float64)
        if pose.shape != (4, 4):
            raise ValueError(f"view {view.name}: {pose.shape=} but expected (4, 4)")
        entries.append({"name": view.name, "camera": camera_id, f"camera_from_{frame}": np.round(pose, 9).tolist(),
                        **view.figures})  # fmt: skip
    document = {
        "format": FORMAT,
        "version": VERSION,
        "frame": frame,
        "convention": _convention(frame),
        "cameras": {camera_id: camera_mapping(camera) for camera, camera_id in ids.items()},
        "views": entries,
        "skipped": [{"name": name, "reason": reason} for name, reason in sorted((skipped or {}).items())],
    }
    write_json(Path(path), document)


def read_cameras(path: Path) -> CameraViews:
    """The views of a cameras.json (or of an older poses.json or photogrammetry cameras.json);
    InputError naming the file and the problem."""
    path = Path(path)
    data = read_bounded(path, MAX_BYTES)  # its errors name the file
    try:
        document = json.loads(data)
        if isinstance(document, list):
            views = _from_photogrammetry_list(document)
        elif "format" not in document and "frames" in document:
            views = _from_poses(document)
        else:
            views = _from_document(document)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
    except (ValueError, KeyError, TypeError, AttributeError, RecursionError) as exc:  # RecursionError: [[[[... nested deep
        raise InputError(f"{path}: not a cameras file: {type(exc).__name__}: {exc}") from None
    names = [v.name for v in views.views]
    if len(set(names)) != len(names):
        raise InputError(f"{path}: a view name appears twice")
    for view in views.views:
        if view.camera_from_frame.shape != (4, 4) or not np.all(np.isfinite(view.camera_from_frame)):
            raise InputError(f"{path}: view {view.name}: camera_from_{views.frame} is not a finite 4x4 matrix")
    return views


def _camera(data: Any, where: str) -> Camera:
    try:
        return Camera.model_validate(data)
    except pydantic.ValidationError as exc:
        first = exc.errors()[0]
        raise InputError(f"{where}: {'.'.join(str(p) for p in first['loc']) or 'camera'}: {first['msg']}") from None


def _from_document(document: dict) -> CameraViews:
    if document.get("format") != FORMAT or document.get("version") != VERSION:
        raise InputError(f"not a {FORMAT} file of version {VERSION} (format {document.get('format')!r}, "
                         f"version {document.get('version')!r})")  # fmt: skip
    frame = document["frame"]
    if frame not in FRAMES:
        raise InputError(f"frame: {frame!r} but expected one of {sorted(FRAMES)}")
    cameras = {str(k): _camera(v, f"cameras.{k}") for k, v in document["cameras"].items()}
    key = f"camera_from_{frame}"
    views = []
    for entry in document["views"]:
        if entry["camera"] not in cameras:
            raise InputError(f"view {entry['name']}: camera {entry['camera']!r} is not one of cameras")
        figures = {k: v for k, v in entry.items() if k not in ("name", "camera", key)}
        views.append(CameraView(name=str(entry["name"]), camera=cameras[entry["camera"]],
                                camera_from_frame=np.asarray(entry[key], dtype=np.float64), figures=figures))  # fmt: skip
    skipped = {str(s["name"]): str(s["reason"]) for s in document.get("skipped", [])}
    return CameraViews(frame=frame, views=views, skipped=skipped)


def _from_poses(document: dict) -> CameraViews:
    """Turntable's poses.json before this format: `camera_from_table` per frame, no intrinsics."""
    views = []
    for entry in document["frames"]:
        figures = {k: v for k, v in entry.items() if k not in ("frame", "camera_from_table")}
        views.append(CameraView(name=str(entry["frame"]), camera=None,
                                camera_from_frame=np.asarray(entry["camera_from_table"], dtype=np.float64),
                                figures=figures))  # fmt: skip
    skipped = {str(s["frame"]): str(s["reason"]) for s in document.get("skipped", [])}
    return CameraViews(frame="table", views=views, skipped=skipped)


def _from_photogrammetry_list(document: list) -> CameraViews:
    """Photogrammetry's cameras.json before this format: a K matrix and the image size per view."""
    views = []
    for entry in document:
        camera = Camera.from_matrix(entry["intrinsics"], width=entry["width_px"], height=entry["height_px"])
        views.append(CameraView(name=str(entry["name"]), camera=camera,
                                camera_from_frame=np.asarray(entry["camera_from_model"], dtype=np.float64)))  # fmt: skip
    return CameraViews(frame="model", views=views)
