"""Live turntable capture from a frame source (a connected RealSense, or a recording played
back through the same interface): per frame, the tags seen and the board's pose; the angle
the table has turned and which parts of its circle have been seen; warnings for blur and too
few tags; frames kept every `step_deg` of turn; stops by itself once the circle is covered.
Writes the capture folder `turntable reconstruct` reads."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from homemodel.core.atomic import atomic_dir, write_json
from homemodel.core.checks import require_at_least, require_between, require_positive
from homemodel.core.errors import InputError
from homemodel.geometry.camera import save_camera
from homemodel.geometry.depth_io import write_depth
from turntable.board import Board, save_board
from turntable.pose import PoseOptions, PoseSkip, estimate_camera_from_table
from turntable.real_frames import sharpness, table_turn_rad
from turntable.recordings.importer import RECORDING_JSON, registered_depth_m, registration_edge_offset_px
from turntable.recordings.source import FrameSource
from turntable.tags import DetectionOptions, detect_tags


@dataclass(kw_only=True)
class LiveCaptureOptions:
    detection: DetectionOptions = field(default_factory=DetectionOptions)
    pose: PoseOptions = field(default_factory=PoseOptions)
    sectors: int = 36  # the circle's parts that must each be seen once
    step_deg: float = 5.0  # a frame is kept each time the table turned this much since the last
    blur_ratio: float = 0.35  # sharpness below this fraction of the running median: blurred
    max_duration_s: float = 600.0

    def check(self) -> None:
        require_between("sectors", self.sectors, 4, 3600)
        require_positive("step_deg", self.step_deg)
        require_between("blur_ratio", self.blur_ratio, 0.0, 1.0)
        require_positive("max_duration_s", self.max_duration_s)
        require_at_least("pose.min_tags", self.pose.min_tags, 1)


@dataclass(kw_only=True)
class LiveStatus:
    """What the live view shows after each frame."""

    frames_seen: int
    frames_kept: int
    tag_ids: list[int]  # the board tags seen in this frame
    turned_deg: float  # since the first frame with a pose
    covered: np.ndarray  # (sectors,) bool
    warning: str | None  # "blur: ..." or "tags: ..."


@dataclass(kw_only=True)
class LiveCaptureResult:
    frames_seen: int
    frames_kept: int
    turned_deg: float
    coverage: float  # fraction of sectors seen
    complete: bool  # stopped by itself after a full turn
    warnings: dict[str, int]  # "blur", "tags": frames warned about


def capture_turn(
    source: FrameSource,
    board: Board,
    out_dir: Path,
    options: LiveCaptureOptions | None = None,
    *,
    on_status: Callable[[LiveStatus], None] | None = None,
    force: bool = False,
) -> LiveCaptureResult:
    """Read `source` (entered here) until the table's circle is covered, keeping frames into the
    capture folder `out_dir` (whole or not at all)."""
    import cv2

    options = options or LiveCaptureOptions()
    options.check()
    covered = np.zeros(options.sectors, dtype=bool)
    warnings = {"blur": 0, "tags": 0}
    sharpness_seen: list[float] = []
    first = None
    turned = last_angle = 0.0
    kept_at = -math.inf
    seen = kept = 0
    frames = []  # stem, time, depth offset: for the pipeline's depth-time compensation
    start = time.monotonic()
    with source, atomic_dir(Path(out_dir), force=force) as tmp:
        camera = source.setup.color_camera
        (tmp / "color").mkdir()
        (tmp / "depth").mkdir()
        for pair in source.pairs():
            seen += 1
            gray = cv2.cvtColor(pair.color, cv2.COLOR_RGB2GRAY)
            detections = detect_tags(gray, options.detection)
            ids = sorted(i for i in detections if i in board.corners_table())
            sharp = sharpness(gray)
            sharpness_seen.append(sharp)
            warning = None
            if sharp < options.blur_ratio * float(np.median(sharpness_seen[-50:])):
                warning = f"blur: sharpness {sharp:.0f}, the recent median {np.median(sharpness_seen[-50:]):.0f}"
                warnings["blur"] += 1
            else:
                try:
                    pose = estimate_camera_from_table(detections, board, camera, options.pose)
                except PoseSkip as exc:
                    warning = f"tags: {exc}"
                    warnings["tags"] += 1
                else:
                    if first is None:
                        first = pose.camera_from_table
                    angle = table_turn_rad(first, pose.camera_from_table)
                    turned += math.remainder(angle - last_angle, 2 * math.pi)  # frames are far less than half a turn apart
                    last_angle = angle
                    covered[int((angle % (2 * math.pi)) / (2 * math.pi) * options.sectors) % options.sectors] = True
                    if abs(math.degrees(turned) - kept_at) >= options.step_deg:
                        kept_at = math.degrees(turned)
                        stem = f"{kept:06d}"
                        cv2.imwrite(str(tmp / "color" / f"{stem}.png"), cv2.cvtColor(pair.color, cv2.COLOR_RGB2BGR))
                        depth = registered_depth_m(pair, source.setup)
                        write_depth(tmp / "depth" / f"{stem}.png", depth, depth_scale_m=camera.depth_scale_m)
                        frames.append({"stem": stem, "time_s": pair.time_s, "depth_offset_s": pair.depth_offset_s})
                        kept += 1
            if on_status is not None:
                on_status(
                    LiveStatus(
                        frames_seen=seen,
                        frames_kept=kept,
                        tag_ids=ids,
                        turned_deg=math.degrees(turned),
                        covered=covered.copy(),
                        warning=warning,
                    )
                )
            if covered.all() or time.monotonic() - start > options.max_duration_s:
                break
        if kept < 3:
            raise InputError(f"{source.setup.format}: only {kept} frames had a pose; is the board in view?")
        save_camera(camera, tmp / "camera.yaml")
        save_board(board, tmp / "board.yaml")
        result = LiveCaptureResult(
            frames_seen=seen,
            frames_kept=kept,
            turned_deg=math.degrees(turned),
            coverage=float(covered.mean()),
            complete=bool(covered.all()),
            warnings=warnings,
        )
        # What the source assumed (units, lens refits, two clocks...), as an import's recording.json says it.
        record = {
            "format": source.setup.format,
            "notes": source.setup.notes,
            "registration_edge_offset_px": registration_edge_offset_px(source.setup),
            "live_capture": result.__dict__,
            "frames": frames,
        }
        write_json(tmp / RECORDING_JSON, record)
    return result
