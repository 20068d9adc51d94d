"""`reconstruct`: a turntable capture folder to a model folder of a metric, coloured mesh
(D3.1 section 3.3.3); `reconstruct_capture` runs the stages on a loaded capture, in memory.

Stages: tag detection and PnP per frame; the turntable's axis from a circle through the
board origin's orbit; merging of the frames in the table frame inside the cylinder over the
axis, on a voxel grid averaging coordinates and colours; outlier removal, outward normals,
Poisson with density trimming; colour baked into a texture on a chart atlas's UVs; then the export
(`turntable.outputs`) and, on request, the registration into a semantic map.
"""

from __future__ import annotations

import math
import queue
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TypeVar

import numpy as np

from homemodel.core.atomic import prepare_out_dir
from homemodel.core.errors import ModelError, errors_naming
from homemodel.core.progress import Progress, StageClock
from turntable.capture import Capture, FrameError, FramePaths, load_capture, read_color, read_depth
from turntable.color_encoding import capture_encoding
from turntable.fusion import Cylinder, MergedCloud, ObjectPixels, VoxelAccumulator, object_pixels, pixel_points
from turntable.meshing import object_surface, vertex_colors
from turntable.outputs import write_reconstruction
from turntable.orbit import TableAxis, table_axis
from turntable.real_frames import (
    depth_color_offset_px,
    sharpness,
    turn_rate_rad_s,
    turned_table,
)
from turntable.pose import FramePose, PoseSkip
from turntable.reconstruction import Reconstruction, ReconstructOptions
from turntable.tag_search import TagSearch, capture_search, frame_pose, predicted_pose
from turntable.tags import PixelWindow, prepare_detectors
from turntable.turn_coverage import TurnCoverage, turn_angles_rad, turn_coverage
from turntable.turntable_model import fit_turntable

A, B = TypeVar("A"), TypeVar("B")
STAGES = ("poses", "axis", "merge", "mesh", "texture", "export")
_MISREGISTRATION_FRAMES = 8
_SETTLED_PX = 0.5  # half the probes this close together, and their median this clear of the warning, settle it
_REGION_MARGIN_M = 0.03  # kept pixels reach this far beyond the object's cylinder, wherever the axis is
_FIRST_DECIMATION = 2.0  # the first frame's search, before one at full resolution
_SEARCH_TRIES = 5  # frames searched over the whole image before a window and a coarser search are given up
_TABLE_SAMPLE_STEP = 16  # every 16th pixel's height is read for the table's depth noise
_TABLE_BAND_M = 0.015  # heights this close to the board's plane are the table top's, with its noise


@contextmanager
def _mapper(workers: int) -> Iterator[Callable]:
    """`map` over threads (OpenCV, the AprilTag library and PNG decoding release the GIL)."""
    if workers <= 1:
        yield map
        return
    with ThreadPoolExecutor(max_workers=workers) as pool:
        yield pool.map


def _beside(letting_go: Callable[[], A], holding: Callable[[], B]) -> tuple[A, B]:
    """(`letting_go()`, `holding()`): the first, a call that soon lets go of the GIL for most of
    its time (a k-d tree's query), on a thread of its own; the second, one that holds it most of
    its time (fast-simplification, the chart atlas), here once the first has started. Started
    the other way round, the first could not even begin before the second ended."""
    started = threading.Event()

    def first() -> A:
        started.set()
        return letting_go()

    with ThreadPoolExecutor(max_workers=1) as pool:
        result = pool.submit(first)
        started.wait()
        held = holding()
        return result.result(), held


def _read_runs(runs: list[list[FramePaths]], read_run: Callable, keep: Callable) -> None:
    """`read_run(k, run, hand_over)` on each run, a thread each when there are several (no run
    waits for another's frame: stepping the runs together had left a core idle whenever one
    frame of a step took longer); what they hand over is kept here, on this thread, as it comes."""
    if len(runs) <= 1:
        for k, run in enumerate(runs):
            read_run(k, run, keep)
        return
    handed: queue.SimpleQueue = queue.SimpleQueue()
    ended, stopping = object(), threading.Event()

    def hand_over(item: object) -> None:
        if stopping.is_set():  # a run or this thread failed (an interrupt, say): the runs end at their next frame
            raise _Stopped
        handed.put(item)

    def whole_run(k: int) -> None:
        try:
            read_run(k, runs[k], hand_over)
        except _Stopped:
            pass
        except BaseException:
            stopping.set()
            raise
        finally:
            handed.put(ended)

    with ThreadPoolExecutor(max_workers=len(runs)) as pool:
        futures = [pool.submit(whole_run, k) for k in range(len(runs))]
        try:
            running = len(runs)
            while running:
                item = handed.get()
                if item is ended:
                    running -= 1
                else:
                    keep(item)
        finally:
            stopping.set()
        for future in futures:
            future.result()  # a run's exception, raised here


class _Stopped(Exception):
    """A run's thread told to end early."""


@dataclass(kw_only=True)
class FrameReading:
    """What one reading of a frame's colour and depth gives; the images themselves are not kept."""

    stem: str
    pose: FramePose | str  # or why there is none: "image: ..." or "pose: ..."
    sharpness: float  # NaN when the colour image is unreadable
    pixels: ObjectPixels | None = None  # where the object may be (see `object_region`)
    flying: int = 0
    valid: int = 0  # pixels with a depth
    # A few frames' depth and grey images, for the depth-to-colour misregistration
    # (`misregistration_offsets`, measured after the poses, beside the axis fit).
    probe_images: tuple[np.ndarray, np.ndarray] | None = None
    table_heights: np.ndarray | None = None  # a sample of the board's points' heights (`table_heights`)


@dataclass(kw_only=True)
class FrameReadings:
    poses: dict[str, FramePose]
    skipped: dict[str, str]  # frame stem -> "image: ...", "pose: ...", "blur: ..." or "unpaired: ..."
    readings: dict[str, FrameReading]
    rays: np.ndarray  # the camera's pixel rays


def object_region(capture: Capture, options: ReconstructOptions) -> Cylinder:
    """A cylinder about the board's origin holding the object's cylinder whatever the axis
    (which lies on the board) and the refinement find: frames are read before either."""
    radius = capture.board.radius_m + (options.cylinder_radius_m or 0.0) + _REGION_MARGIN_M
    return Cylinder(
        axis_xy_m=np.zeros(2),
        radius_m=radius,
        z_min_m=options.plane_margin_m - _REGION_MARGIN_M / 10,
        z_max_m=options.max_height_m + _REGION_MARGIN_M,
    )


def table_heights(
    depth_m: np.ndarray, rays: np.ndarray, table_from_camera: np.ndarray, board_radius_m: float
) -> np.ndarray:
    """Heights above the board's plane of a sample of the pixels over the board, near that
    plane: the table top's depth noise (and the object's foot, above the plane only)."""
    depth, rays = depth_m.reshape(-1)[::_TABLE_SAMPLE_STEP], rays[::_TABLE_SAMPLE_STEP]
    rotation, eye = table_from_camera[:3, :3].astype(rays.dtype), table_from_camera[:3, 3]
    z = depth * (rays @ rotation[2]) + eye[2]  # the height first: the room goes before any other arithmetic
    near = np.flatnonzero(np.abs(z) < _TABLE_BAND_M)  # NaN compares False
    xy = (rays[near] * depth[near, None]) @ rotation[:2].T + eye[:2]
    return z[near[np.hypot(*xy.T) < board_radius_m]].astype(np.float32)


def table_noise_m(heights: np.ndarray) -> float:
    """How far above the board's plane the table top's depth noise reaches: its median plus
    5 sigma, sigma robustly from the heights below the median (the object's foot lies only
    above the plane, so the lower side is the table's alone). 5, not 3: of a capture's ~10^7
    table pixels ~10^4 lie above 3 sigma, ~3 above 5. 0 without heights."""
    if len(heights) < 100:
        return 0.0
    median = float(np.median(heights))
    return median + 5 * (median - float(np.percentile(heights, 15.87)))


def read_frames(capture: Capture, options: ReconstructOptions, report: Progress) -> FrameReadings:
    """Each frame read once: its pose from the tags and the depth pixels where the object may
    be, kept for the merge. Frames with unreadable images, too few tags or blur are skipped
    with a reason."""
    camera = capture.camera
    # While the first frame is searched alone, on the other core: the pixel rays (float32 halves
    # the per-pixel arithmetic; 0.1 um at 1 m), which the frames' pixels need (15 ms of NumPy at
    # 640 x 480; 0.23 s undistorting a 1280 x 720 lens's), then the tag detectors the runs'
    # first searches need beside the one the first frame's search builds.
    with ThreadPoolExecutor(max_workers=1) as pool:
        rays = pool.submit(lambda: camera.pixel_rays().astype(np.float32))
        pool.submit(prepare_detectors, options.detection, options.workers)
        return _read_frames(capture, options, report, rays)


def _read_frames(capture: Capture, options: ReconstructOptions, report: Progress, rays: Future) -> FrameReadings:
    import cv2

    camera = capture.camera
    region = object_region(capture, options)
    # The misregistration is measured on a few frames spread over the turn; not the first, read
    # alone while the other core has nothing to do.
    step = max(1, len(capture.frames) // _MISREGISTRATION_FRAMES)
    probes = {f.stem for f in capture.frames[step // 2 :: step]}

    def posed(
        frame: FramePaths, search: TagSearch, predicted: np.ndarray | None = None
    ) -> tuple[FrameReading, tuple[np.ndarray, np.ndarray] | None]:
        """The frame's reading as far as its pose, and its colour and grey images if they are readable."""
        try:
            rgb = read_color(frame.color, camera)
        except FrameError as exc:
            return FrameReading(stem=frame.stem, pose=f"image: {exc}", sharpness=np.nan), None
        gray = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
        sharp = sharpness(_window_of(gray, search.window))
        try:
            pose: FramePose | str = frame_pose(gray, search, capture.board, camera, options.pose, predicted)
        except PoseSkip as exc:
            pose = f"pose: {exc}"
        return FrameReading(stem=frame.stem, pose=pose, sharpness=sharp), (rgb, gray)

    def measured(frame: FramePaths, reading: FrameReading, rgb: np.ndarray, gray: np.ndarray) -> FrameReading:
        """A posed frame's reading with its depth: the object's pixels and the figures."""
        assert isinstance(reading.pose, FramePose)
        try:
            depth = read_depth(frame.depth, camera)
        except FrameError as exc:
            return replace(reading, pose=f"image: {exc}")
        table_from_camera = np.linalg.inv(reading.pose.camera_from_table)
        pixels, flying = object_pixels(
            depth, rgb, rays.result(), table_from_camera, region, drop_flying=options.drop_flying_pixels
        )
        return replace(
            reading,
            pixels=pixels,
            flying=flying,
            valid=int(np.count_nonzero(np.isfinite(depth))),
            probe_images=(depth, gray) if frame.stem in probes else None,
            table_heights=table_heights(depth, rays.result(), table_from_camera, capture.board.radius_m),
        )

    def one(frame: FramePaths, search: TagSearch, predicted: np.ndarray | None = None) -> FrameReading:
        reading, images = posed(frame, search, predicted)
        return measured(frame, reading, *images) if images is not None and isinstance(reading.pose, FramePose) else reading

    readings: dict[str, FrameReading] = {}

    def keep(reading: FrameReading) -> None:
        readings[reading.stem] = reading
        report("poses", len(readings), len(capture.frames))

    # The tag search's window and (unless the options fix it) decimation come from the first
    # frame with a pose, searched over the whole image: at half resolution first (the bench
    # mug's first frame: 6 CPU-ms, 44 tags, against 14 ms and 48 at full), then at full
    # resolution if that gives no pose (`frame_pose`).
    whole = TagSearch(detection=replace(options.detection, decimate=options.detection.decimate or _FIRST_DECIMATION))
    # The runs start as soon as that frame has its pose: the first run reads its depth.
    search, frames, first, grays = None, list(capture.frames), None, {}
    while frames and search is None and len(readings) < _SEARCH_TRIES:
        frame = frames.pop(0)
        reading, images = posed(frame, whole)
        keep(reading)
        if images is not None:
            grays[frame.stem] = images[1]
        if isinstance(reading.pose, FramePose):
            first = (frame, reading, *images)
            search = capture_search(
                capture.board, camera, reading.pose.camera_from_table, options.detection, predict=options.predict_tags
            )
    search = search or whole
    if search.window is not None:  # the frames above were read before it: their sharpness on it too
        for stem, gray in grays.items():
            readings[stem] = replace(readings[stem], sharpness=sharpness(_window_of(gray, search.window)))
        if first is not None:
            first = (first[0], readings[first[0].stem], *first[2:])
    # The rest in `workers` runs of consecutive frames, each run read by a thread of its own,
    # frame after frame: a run's last two poses predict its next frame's tags (see
    # `tag_search.tracked_pose`). The first run goes on from the frames read above. (Runs that
    # met wherever they got to, one from each end, ended closer together, but a frame's pose
    # then depended on the direction it was tracked in, and that on the threads' timing.)
    n = options.workers
    runs = [run for i in range(n) if (run := frames[len(frames) * i // n : len(frames) * (i + 1) // n])] or [[]]
    befores = [list(readings.values())[-2:]] + [[] for _ in runs[1:]]

    def read_run(k: int, run: list[FramePaths], hand_over: Callable[[FrameReading], None]) -> None:
        before = befores[k]
        if k == 0 and first is not None:
            hand_over(measured(*first))
        for frame in run:
            tracking = len(before) == 2 and all(isinstance(r.pose, FramePose) for r in before)
            reading = one(frame, search, predicted_pose(*(r.pose.camera_from_table for r in before)) if tracking else None)
            before = [*before[-1:], reading]
            hand_over(reading)

    _read_runs(runs, read_run, keep)
    readings = {f.stem: readings[f.stem] for f in capture.frames if f.stem in readings}  # in the capture's order

    poses = {stem: r.pose for stem, r in readings.items() if isinstance(r.pose, FramePose)}
    skipped = {stem: "unpaired: a colour or a depth image without its partner" for stem in capture.unpaired}
    skipped.update({stem: r.pose for stem, r in readings.items() if isinstance(r.pose, str)})
    # Blur: a turntable's frames see the same scene, so a frame far less sharp than the
    # median is blurred (auto exposure, motion); its tag corners and colours would smear.
    readable = [r.sharpness for r in readings.values() if np.isfinite(r.sharpness)]  # unreadable images have none
    median = float(np.median(readable)) if readable else 0.0
    for stem, reading in readings.items():
        if reading.sharpness < options.blur_ratio * median:
            blur = f"sharpness {reading.sharpness:.0f} below {options.blur_ratio} x the median {median:.0f}"
            if stem in poses:
                del poses[stem]
                skipped[stem] = f"blur: {blur}"
            elif stem in skipped:  # no pose anyway: say it was blurred too
                skipped[stem] += f" (blurred: {blur})"
    if len(poses) < options.min_frames:
        examples = "; ".join(f"{s}: {r}" for s, r in list(skipped.items())[:3])
        raise ModelError(
            f"{capture.folder}: only {len(poses)} of {len(capture.frames)} frames have a pose, "
            f"{options.min_frames} needed ({examples})"
        )
    return FrameReadings(poses=poses, skipped=skipped, readings=readings, rays=rays.result())


def _window_of(image: np.ndarray, window: PixelWindow | None) -> np.ndarray:
    """The part of the image in the tag search's window, where the board and the object are (a
    frame's sharpness is measured there: half the bench mug's image), or all of it."""
    return image if window is None else image[window.top : window.bottom, window.left : window.right]


def misregistration_offsets(
    readings: dict[str, FrameReading], expected_px: np.ndarray, warning_px: float
) -> dict[str, np.ndarray | None]:
    """The probed frames' depth-to-colour offsets (`depth_color_offset_px`), by frame: every
    other probe first, the rest only when those leave the warning in doubt (see `_settled`).
    The bench mug's first four read within 0.12 px of their median, 0.33 px from the expected
    offset against the warning's 1.5: its four others are not probed (40 frames: 23 -> 14 CPU-ms)."""
    probed = [(stem, r.probe_images) for stem, r in readings.items() if r.probe_images is not None]
    offsets = {stem: depth_color_offset_px(*images) for stem, images in probed[::2]}
    if not _settled([offset for offset in offsets.values() if offset is not None], expected_px, warning_px):
        offsets.update({stem: depth_color_offset_px(*images) for stem, images in probed[1::2]})
    return offsets


def _settled(found: list[np.ndarray], expected_px: np.ndarray, warning_px: float) -> bool:
    """Whether these offsets settle the misregistration warning: three or more, each within
    `_SETTLED_PX` of their median, and that median's distance from `expected_px` more than
    `_SETTLED_PX` short of `warning_px` or beyond it."""
    if len(found) < 3:
        return False
    median = np.median(found, axis=0)
    spread = float(np.max(np.hypot(*(np.array(found) - median).T)))
    return spread <= _SETTLED_PX and abs(float(np.hypot(*(median - expected_px))) - warning_px) > _SETTLED_PX


def object_cylinder(capture: Capture, axis: TableAxis, options: ReconstructOptions) -> Cylinder:
    if options.cylinder_radius_m is not None:
        radius = options.cylinder_radius_m
    else:
        radius = capture.board.radius_m - float(np.linalg.norm(axis.axis_xy_m)) - 0.01
    if radius <= 0:
        raise ModelError(f"cylinder radius {radius:.3f} m: the turntable axis lies off the board")
    return Cylinder(
        axis_xy_m=axis.axis_xy_m, radius_m=radius, z_min_m=options.plane_margin_m, z_max_m=options.max_height_m
    )


def merge_frames(
    capture: Capture,
    frames: FrameReadings,
    poses: dict[str, FramePose],
    cylinder: Cylinder,
    options: ReconstructOptions,
    report: Progress,
    figures: dict,
    offsets: Future[dict[str, np.ndarray | None]],
) -> tuple[MergedCloud, TurnCoverage]:
    """The frames' kept pixels in the table frame, voxel-averaged, and how much of the turn the
    merged frames saw; fills `figures` with the real-frame figures (flying pixels, holes,
    misregistration from the merged frames' `offsets`)."""
    skipped, readings = frames.skipped, frames.readings
    accumulator = VoxelAccumulator(voxel_size_m=options.voxel_size_m)
    # A depth frame taken `depth_offset_s` after its colour frame sees the table turned on by
    # the turn rate times that: its points go back by as much (recordings with frame times).
    timing = {
        f["stem"]: f
        for f in (capture.recording or {}).get("frames", [])
        if isinstance(f, dict) and isinstance(f.get("stem"), str)
        and all(isinstance(f.get(k), (int, float)) for k in ("time_s", "depth_offset_s"))
    }
    ordered = sorted((s for s in timing if s in poses), key=lambda stem: timing[stem]["time_s"])
    rate = turn_rate_rad_s([poses[s].camera_from_table for s in ordered], [timing[s]["time_s"] for s in ordered])
    camera_from_tables = {s: p.camera_from_table for s, p in poses.items()}
    if rate is not None:
        # A frame whose colour gave no pose (blurred, too few tags) keeps its depth: the table's
        # pose at its time follows from the nearest posed frame and the turn rate.
        for frame in capture.frames:
            if frame.stem not in poses and frame.stem in timing and skipped.get(frame.stem, "").startswith(("blur:", "pose:")):
                t = float(timing[frame.stem]["time_s"])
                nearest = min(ordered, key=lambda s: abs(timing[s]["time_s"] - t))
                turn = turned_table(cylinder.axis_xy_m, rate * (t - timing[nearest]["time_s"]))
                camera_from_tables[frame.stem] = poses[nearest].camera_from_table @ turn
    merged = [f for f in capture.frames if f.stem in camera_from_tables]

    def one(frame: FramePaths) -> FrameReading:
        """The frame's reading; read now if its colour gave no pose (so no pixels were kept)."""
        reading = readings.get(frame.stem)
        if reading is not None and reading.pixels is not None:
            return reading
        try:
            depth = read_depth(frame.depth, capture.camera)
            rgb = read_color(frame.color, capture.camera)
        except FrameError as exc:
            return FrameReading(stem=frame.stem, pose=f"image: {exc}", sharpness=np.nan)
        pixels, flying = object_pixels(
            depth,
            rgb,
            frames.rays,
            np.linalg.inv(camera_from_tables[frame.stem]),
            cylinder,
            drop_flying=options.drop_flying_pixels,
        )
        return FrameReading(
            stem=frame.stem, pose="posed by the turn rate", sharpness=np.nan, pixels=pixels, flying=flying,
            valid=int(np.count_nonzero(np.isfinite(depth))),
        )

    def points_of(frame: FramePaths) -> tuple[FrameReading, tuple[np.ndarray, np.ndarray, np.ndarray] | None]:
        reading = one(frame)
        if reading.pixels is None:
            return reading, None
        table_from_camera = np.linalg.inv(camera_from_tables[frame.stem])
        if rate is not None and frame.stem in timing:
            angle = rate * float(timing[frame.stem]["depth_offset_s"])
            table_from_camera = np.linalg.inv(turned_table(cylinder.axis_xy_m, angle)) @ table_from_camera
        return reading, pixel_points(reading.pixels, frames.rays, table_from_camera, cylinder)

    flying_total = valid_total = merged_total = 0
    probed, merged_views = [], []
    # The frames' points on the workers' threads (NumPy lets go of the GIL), summed in order here.
    with _mapper(options.workers) as mapper:
        done_frames = enumerate(zip(merged, mapper(points_of, merged)), start=1)
        for done, (frame, (reading, points)) in done_frames:
            if points is None:
                skipped[frame.stem] = str(reading.pose)
                poses.pop(frame.stem, None)
            else:
                accumulator.add(*points)
                merged_views.append(camera_from_tables[frame.stem])
                flying_total += reading.flying
                valid_total += reading.valid
                merged_total += 1
                if reading.probe_images is not None:
                    probed.append(frame.stem)
            report("merge", done, len(merged))
    found = [offset for stem in probed if (offset := offsets.result().get(stem)) is not None]  # probed and measured
    offset_px = np.median(found, axis=0) if found else None
    # What the estimate reads on the import's own registration with an exact extrinsic (a depth
    # camera of its own reprojected: `recordings.register.expected_edge_offset_px`).
    expected_px = capture.registration_edge_offset_px()
    figures.update(
        {
            "flying_pixels_dropped": flying_total,  # around the object's pixels
            "flying_pixel_fraction": flying_total / max(valid_total, 1),
            "holes_filled": 0,  # never: a hole is no measurement
            "depth_valid_fraction": valid_total / max(merged_total * capture.camera.width * capture.camera.height, 1),
            "depth_to_color_offset_px": None if offset_px is None else [round(float(v), 2) for v in offset_px],
            "misregistration_frames": len(found),
            "turn_rate_deg_s": None if rate is None else math.degrees(rate),
            "depth_time_compensated_frames": len(timing) if rate is not None else 0,
            "frames_posed_by_turn_rate": len(camera_from_tables) - len(poses),
            "registration_edge_offset_px": expected_px.tolist(),
            "misregistration_warning": bool(
                offset_px is not None and np.hypot(*(offset_px - expected_px)) > options.misregistration_warning_px
            ),
        }
    )
    if len(poses) < options.min_frames:
        raise ModelError(f"{capture.folder}: only {len(poses)} frames have readable depth, {options.min_frames} needed")
    # The frames posed by the turn rate count: their depth is merged.
    return accumulator.cloud(), turn_coverage(turn_angles_rad(merged_views))


def reconstruct_capture(
    capture: Capture, options: ReconstructOptions | None = None, progress: Progress | None = None
) -> Reconstruction:
    """Run the pipeline on a loaded capture (see `turntable.capture.load_capture`), in memory."""
    from threadpoolctl import threadpool_limits

    # The stages' BLAS calls are small (points by 3 x 3 rotations, 4 x 4 inverses) and the
    # frames already run on `workers` threads: OpenBLAS's own threads only wait on each other
    # (a 4 x 4 inverse took 4 ms instead of 4 us on a busy 2-core machine).
    with threadpool_limits(1, user_api="blas"), _small_pages():
        return _run_stages(capture, options or ReconstructOptions(), progress)


@contextmanager
def _small_pages() -> Iterator[None]:
    """NumPy's arrays of 4 MB and more without its madvise(MADV_HUGEPAGE): the merge's sums, say,
    are fresh arrays of 10-20 MB, filled once. Where a transparent huge page's first touch is
    dear (a virtual machine's: 4-27 ms of kernel time each on the bench's host, against 1.6 us
    a 4 kB page), the 40-frame merge had paid 0.01-0.24 CPU-s of it, at random; the TLB misses
    the huge pages save do not show in these stages. NumPy's setting (one for the process) is
    restored when the last of the reconstructions running at once ends."""
    from numpy._core.multiarray import _set_madvise_hugepage

    global _small_pages_runs, _huge_pages_before
    with _small_pages_lock:
        if _small_pages_runs == 0:
            _huge_pages_before = _set_madvise_hugepage(False)
        _small_pages_runs += 1
    try:
        yield
    finally:
        with _small_pages_lock:
            _small_pages_runs -= 1
            if _small_pages_runs == 0:
                _set_madvise_hugepage(_huge_pages_before)


_small_pages_lock = threading.Lock()
_small_pages_runs = 0  # reconstructions inside `_small_pages` now
_huge_pages_before = True  # NumPy's setting when the first of them began


def _run_stages(capture: Capture, options: ReconstructOptions, progress: Progress | None) -> Reconstruction:
    from turntable.texture import TextureLayout, bake_vertex_colors, carrier, texture_layout

    clock = StageClock(progress)
    clock.start("poses")
    encoding = capture_encoding(capture, options.color_encoding, options.detection)
    options = replace(options, detection=replace(options.detection, intensity=encoding.encoding))
    frames = read_frames(capture, options, clock.progress)
    poses, skipped = frames.poses, frames.skipped
    # The object starts above the table top's depth noise: at least `plane_margin_m`, more on
    # a noisier camera, whose table would otherwise come into the mesh as a skirt around the
    # object (s17 check29b's plate: 30-42 % of its mesh outside the rim at 4 mm).
    heights = [frames.readings[s].table_heights for s in poses]
    table_noise = table_noise_m(np.concatenate([h for h in heights if h is not None] or [np.zeros(0, np.float32)]))
    options = replace(options, plane_margin_m=max(options.plane_margin_m, table_noise))
    real_frames = {
        "blurred_frames_skipped": sum(r.startswith("blur:") for r in skipped.values()),
        "blurred_frames": sum(r.startswith("blur:") or "(blurred:" in r for r in skipped.values()),
    }

    # The misregistration probes on the other core, beside the axis fit, which holds the GIL
    # most of its time (their OpenCV and whole-image NumPy steps let go of it): at 40 frames,
    # 8 probes of 4 CPU-ms that the poses stage's two runs had waited for.
    with ThreadPoolExecutor(max_workers=1) as pool:
        offsets = pool.submit(
            misregistration_offsets, frames.readings, capture.registration_edge_offset_px(), options.misregistration_warning_px
        )
        clock.start("axis", 1)
        axis = table_axis([p.camera_from_table for p in poses.values()])
        fit = None
        if options.turntable_refinement and len(poses) >= options.min_frames:
            fit = fit_turntable(poses, axis.orbit, capture.camera)
            if fit.accepted:
                poses = {s: replace(p, camera_from_table=fit.camera_from_tables[s]) for s, p in poses.items()}
                axis = table_axis([p.camera_from_table for p in poses.values()])
        cylinder = object_cylinder(capture, axis, options)

        clock.start("merge")
        cloud, coverage = merge_frames(capture, frames, poses, cylinder, options, clock.progress, real_frames, offsets)

    clock.start("mesh", 1)
    mesh, kept, figures = object_surface(cloud, cylinder, options.voxel_size_m, options.meshing)

    textured = uv = texture = None
    if options.texture_size_px > 0:
        clock.start("texture", 1)
        # The vertex colours' k-d tree and neighbour query on the other core (both let go of the
        # GIL), beside the carrier's quadric collapse and its texture's layout, which need no
        # colour and hold it most of their time: the tree's 4 CPU-ms no longer before the collapse.

        def laid_out_carrier() -> tuple[np.ndarray, TextureLayout]:
            small, nearest = carrier(mesh, options.texture_max_triangles)
            return nearest, texture_layout(small, size_px=options.texture_size_px)

        colors, (nearest, layout) = _beside(lambda: vertex_colors(mesh, kept, workers=1), laid_out_carrier)
        textured, uv, texture = bake_vertex_colors(layout, colors[nearest])
    else:
        colors = vertex_colors(mesh, kept)
    clock.stop()
    return Reconstruction(
        mesh=mesh,
        vertex_colors=colors,
        textured_mesh=textured,
        uv=uv,
        texture=texture,
        camera=capture.camera,
        poses=poses,
        skipped=skipped,
        axis=axis,
        turntable_fit=fit,
        turn=coverage,
        cylinder=cylinder,
        table_noise_m=table_noise,
        cloud=cloud,
        meshing=figures,
        times_s=clock.times_s,
        frames_total=len(capture.frames) + len(capture.unpaired),
        color_encoding=encoding,
        real_frames=real_frames,
        recording=capture.recording,
    )


def reconstruct(
    capture_dir: Path,
    out_dir: Path,
    options: ReconstructOptions | None = None,
    *,
    progress: Progress | None = None,
    force: bool = False,
) -> Reconstruction:
    """The turntable's entry: the capture in `capture_dir` (camera.yaml, board.yaml, color/,
    depth/) to a model folder at `out_dir` (model.urdf, model.glb, meshes/, mesh.ply,
    poses.json, summary.json; picture.png on request), registered into `options.map_entry`
    when given. Refuses a non-empty `out_dir` unless `force`; the folder appears whole or
    not at all. Progress stages: poses, axis, merge, mesh, texture, export."""
    options = options or ReconstructOptions()
    options.check()
    prepare_out_dir(Path(out_dir), force=force, inputs=[Path(capture_dir)])  # a full --out fails now too
    if options.map_entry is not None:
        options.map_entry.check()  # an unknown parent or a taken id fails now, not after the work
    with errors_naming(capture_dir):
        result = reconstruct_capture(load_capture(capture_dir), options, progress)
    result.summary = write_reconstruction(
        result, out_dir, options, inputs=[Path(capture_dir)], force=force, progress=progress
    ).summary
    result.register(out_dir, options.map_entry)
    return result
