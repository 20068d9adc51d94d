"""A recording to a turntable capture folder (`camera.yaml`, `board.yaml`, `color/`, `depth/`),
plus `recording.json`: what was read, associated, dropped, registered and assumed."""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from homemodel.core.atomic import atomic_dir, write_json
from homemodel.core.checks import require_at_least, require_choice, require_positive
from homemodel.core.errors import InputError
from homemodel.core.progress import Progress, no_progress
from homemodel.geometry.camera import Camera, save_camera
from homemodel.geometry.depth_io import write_depth
from turntable.board import load_board, save_board
from turntable.recordings.camera_file import load_camera_file, take_depth_pose
from turntable.recordings.depth_units import FLAG as DEPTH_UNITS_FLAG
from turntable.recordings.depth_units import DepthUnitsCheck, take_depth_units
from turntable.recordings.detect import FORMATS, RecordingFormat, detect_format
from turntable.recordings.register import expected_edge_offset_px, register_depth
from turntable.recordings.source import FrameSource, RgbdPair, StreamSetup, frame_size_problem

RECORDING_JSON = "recording.json"
_INTRINSICS_TOLERANCE_PX = 1.0


@dataclass(kw_only=True)
class ImportOptions:
    format: RecordingFormat | None = None  # None: detected from the path
    # camera.yaml for recordings without intrinsics (TUM, Redwood scans), and/or the depth
    # camera's pose (`color_from_depth`) for those without it (`camera_file`)
    camera_path: Path | None = None
    every: int = 1  # keep every N-th associated pair
    start_s: float = 0.0  # from the recording's first frame
    end_s: float | None = None
    tolerance_s: float | None = None  # colour-depth association; None: half a frame interval, at most 50 ms
    # Metres per unit of the 16-bit depth images, for a recording not in its format's units (a
    # TUM-layout folder in mm); None: the recording's own (TUM's 1/5000 m, a bag's, Open3D's).
    depth_units_m: float | None = None

    def check(self) -> None:
        if self.format is not None:
            require_choice("format", self.format, FORMATS)
        require_at_least("every", self.every, 1)
        require_at_least("start_s", self.start_s, 0.0)
        if self.end_s is not None and self.end_s < self.start_s:
            raise InputError(f"end_s: {self.end_s} is before start_s ({self.start_s})")
        if self.tolerance_s is not None:
            require_positive("tolerance_s", self.tolerance_s)
        if self.depth_units_m is not None:
            require_positive("depth_units_m", self.depth_units_m)


@dataclass(kw_only=True)
class ImportReport:
    format: str
    frames_written: int
    color_frames: int
    depth_frames: int
    pairs_associated: int
    frames_dropped: dict[str, int]  # colour and depth frames without a partner (or missing from the camera's count)
    max_time_offset_ms: float
    mean_time_offset_ms: float  # of the written pairs, depth minus colour
    registration: str  # "recording" (already registered) or "reprojected"
    # What the misregistration estimate reads on this registration with an exact extrinsic
    # (`register.expected_edge_offset_px`): reconstruct measures the offset from it.
    registration_edge_offset_px: tuple[float, float] = (0.0, 0.0)
    intrinsics_from: str
    intrinsics_disagreement: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    depth_scale_m: float = 0.001
    color_size: tuple[int, int] = (0, 0)
    time_s: float = 0.0

    def as_json(self) -> dict:
        return dataclasses.asdict(self)


def open_recording(path: Path, options: ImportOptions) -> FrameSource:
    """The frame source for the recording at `path` (not yet entered)."""
    kind = options.format or detect_format(path)
    camera = None if options.camera_path is None else load_camera_file(options.camera_path).camera
    timed = {"tolerance_s": options.tolerance_s, "every": options.every}
    if kind == "realsense-bag":
        from turntable.recordings.realsense import RealSenseSource

        return RealSenseSource(bag=path, every=options.every, tolerance_s=options.tolerance_s)
    if kind in ("ros1", "ros2"):
        from turntable.recordings.rosbag import RosBagSource

        return RosBagSource(path, ros_version=int(kind[-1]), **timed)
    if kind == "tum":
        from turntable.recordings.tum import TumSource

        return TumSource(path, camera=camera, **timed)
    from turntable.recordings.open3d_folder import Open3dSource

    return Open3dSource(path, camera=camera, **timed)


def intrinsics_disagreement(given: Camera, found: Camera) -> list[str]:
    """What --camera's camera.yaml says differently from the recording's intrinsics."""
    lines = []
    if (given.width, given.height) != (found.width, found.height):
        lines.append(f"size {given.width}x{given.height} vs the recording's {found.width}x{found.height}")
    for name in ("fx", "fy", "cx", "cy"):
        a, b = getattr(given, name), getattr(found, name)
        if abs(a - b) > _INTRINSICS_TOLERANCE_PX:
            lines.append(f"{name} {a:.2f} vs the recording's {b:.2f}")
    if not np.allclose(given.distortion_coefficients[:4], found.distortion_coefficients[:4], atol=1e-3) or (
        given.distortion_model != found.distortion_model
    ):
        lines.append("distortion differs")
    return [f"--camera: {line} (the recording's kept)" for line in lines]


def registered_depth_m(pair: RgbdPair, setup: StreamSetup) -> np.ndarray:
    """The pair's depth in colour's pixels, in metres (NaN: none); refuses images of other sizes
    than their cameras'."""
    if (problem := frame_size_problem(pair, setup)) is not None:
        raise InputError(problem)
    depth = pair.depth.astype(np.float64)
    if pair.depth.dtype == np.uint16:
        depth = np.where(pair.depth > 0, depth * setup.color_camera.depth_scale_m, np.nan)
    else:
        depth[~(np.isfinite(depth) & (depth > 0))] = np.nan
    if setup.depth_camera is None:
        return depth
    extrinsic = np.eye(4) if setup.color_from_depth is None else setup.color_from_depth
    return register_depth(depth, setup.depth_camera, setup.color_camera, extrinsic, setup.depth_pixel_rays())


def registration_edge_offset_px(setup: StreamSetup) -> tuple[float, float]:
    """`ImportReport.registration_edge_offset_px` of the recording's registration, to 0.01 px."""
    if setup.depth_camera is None:
        return (0.0, 0.0)
    extrinsic = np.eye(4) if setup.color_from_depth is None else setup.color_from_depth
    dx, dy = expected_edge_offset_px(setup.depth_camera, setup.color_camera, extrinsic)
    return (round(float(dx), 2), round(float(dy), 2))


def import_recording(
    recording: Path,
    board_path: Path,
    out_dir: Path,
    options: ImportOptions | None = None,
    *,
    progress: Progress | None = None,
    force: bool = False,
) -> ImportReport:
    """Write the capture folder of `recording` at `out_dir` (whole or not at all). Refuses,
    naming the recording, one without depth, intrinsics, or overlapping streams."""
    import cv2

    options = options or ImportOptions()
    options.check()
    report = progress or no_progress
    recording = Path(recording)
    board = load_board(board_path)
    start = time.perf_counter()
    source = open_recording(recording, options)
    source.board = board
    with source, atomic_dir(Path(out_dir), force=force, inputs=[recording, Path(board_path)]) as tmp:
        setup = source.setup
        if options.depth_units_m is not None:
            take_depth_units(setup, options.depth_units_m)
        camera = setup.color_camera
        disagreement = []
        if options.camera_path is not None:
            given = load_camera_file(options.camera_path)
            if given.camera is not None and setup.intrinsics_from == "recording":
                disagreement = intrinsics_disagreement(given.camera, camera)
            if given.color_from_depth is not None:
                take_depth_pose(setup, given.color_from_depth)
        (tmp / "color").mkdir()
        (tmp / "depth").mkdir()
        written = 0
        units = DepthUnitsCheck(board, camera, str(recording))
        offsets = []
        frames = []
        depth_seen = False
        for pair in source.pairs(start_s=options.start_s, end_s=options.end_s):
            if options.depth_units_m is not None and pair.depth.dtype != np.uint16:
                raise InputError(f"{recording}: {DEPTH_UNITS_FLAG}: its depth is in float metres, not in units")
            stem = f"{written:06d}"
            if not cv2.imwrite(str(tmp / "color" / f"{stem}.png"), cv2.cvtColor(pair.color, cv2.COLOR_RGB2BGR)):
                raise InputError(f"{tmp}: cannot write a colour frame")
            try:
                depth = registered_depth_m(pair, setup)
            except InputError as exc:
                raise InputError(f"{recording}: {exc}") from None
            units.add(written, pair.color, depth)
            depth_seen = depth_seen or bool(np.isfinite(depth).any())
            write_depth(tmp / "depth" / f"{stem}.png", depth, depth_scale_m=camera.depth_scale_m)
            offsets.append(pair.depth_offset_s)
            times = (pair.time_s, pair.depth_offset_s) if setup.timed else (None, None)
            frames.append({"stem": stem, "time_s": times[0], "depth_offset_s": times[1]})
            written += 1
            report("import", written, None)
        if written == 0:
            span = f" between {options.start_s} s and {options.end_s} s" if options.end_s is not None else ""
            span = span or (f" after {options.start_s} s" if options.start_s else "")
            raise InputError(f"{recording}: no colour frame paired with a depth frame{span}")
        if not depth_seen:  # a driver that wrote no depth: reconstruct would blame the object
            raise InputError(f"{recording}: no depth: its {written} depth frames read none (every pixel 0)")
        units.finish()
        save_camera(camera, tmp / "camera.yaml")
        save_board(board, tmp / "board.yaml")
        counts = source.counts
        result = ImportReport(
            format=setup.format,
            frames_written=written,
            color_frames=counts.color_frames,
            depth_frames=counts.depth_frames,
            pairs_associated=counts.pairs,
            frames_dropped={"color": counts.dropped_color, "depth": counts.dropped_depth},
            max_time_offset_ms=1000 * counts.max_offset_s,
            mean_time_offset_ms=1000 * float(np.mean(offsets)),
            registration="reprojected" if setup.depth_camera is not None else "recording",
            registration_edge_offset_px=registration_edge_offset_px(setup),
            intrinsics_from=setup.intrinsics_from,
            intrinsics_disagreement=disagreement,
            notes=setup.notes,
            depth_scale_m=camera.depth_scale_m,
            color_size=(camera.width, camera.height),
            time_s=time.perf_counter() - start,
        )
        write_json(tmp / RECORDING_JSON, {**result.as_json(), "frames": frames})
    return result
