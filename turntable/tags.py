"""tag36h11 detection: the AprilTag library (pupil-apriltags) or OpenCV's ArUco module.

Corners come back in ArUco order (top-left, top-right, bottom-right, bottom-left of the tag
image, clockwise in the picture), in OpenCV pixel coordinates (pixel centres at integers),
which is what `turntable.board` pairs them with.
"""

from __future__ import annotations

import atexit
import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Literal

import numpy as np

from homemodel.core.checks import require_at_least, require_choice, require_positive
from homemodel.core.srgb import srgb_decode

TagDetector = Literal["apriltag", "opencv"]


@dataclass(kw_only=True)
class DetectionOptions:
    detector: TagDetector = "apriltag"
    # AprilTag's quad_decimate: finer than 1 misses small tags, larger speeds up big images.
    # None: 1 on a lone image; a turntable capture picks it from its first frame's tags.
    decimate: float | None = None
    # Move each tag side to where the intensity crosses halfway between the black border
    # and the white margin, then intersect the sides (see `refine_edges`).
    edge_refinement: bool = True
    # Intensities of the images: "linear" (raw sensor or a linear render) or "srgb" (most
    # cameras' 8-bit output), which is linearised before edge refinement.
    intensity: Literal["linear", "srgb"] = "linear"
    max_hamming: int = 1  # bit errors accepted when decoding a tag

    def check(self) -> None:
        require_choice("detector", self.detector, ("apriltag", "opencv"))
        if self.decimate is not None:
            require_positive("decimate", self.decimate)
        require_choice("intensity", self.intensity, ("linear", "srgb"))
        require_at_least("max_hamming", self.max_hamming, 0)


@dataclass(frozen=True, kw_only=True)
class PixelWindow:
    """Rows top to bottom and columns left to right of an image (ends excluded)."""

    top: int
    bottom: int
    left: int
    right: int

    def holds(self, pixels: np.ndarray, margin_px: float | np.ndarray = 0.0) -> np.ndarray:
        """Which of (..., 2) pixel coordinates lie `margin_px` (broadcast to (...)) or more inside the window."""
        x, y = pixels[..., 0], pixels[..., 1]
        return (
            (x >= self.left + margin_px)
            & (x <= self.right - 1 - margin_px)
            & (y >= self.top + margin_px)
            & (y <= self.bottom - 1 - margin_px)
        )


# pupil-apriltags builds tag36h11's decoding table for up to 2 bit errors: 18-21 ms of CPU a
# detector, where the table for the 1 a detection keeps by default (`max_hamming`) takes 0.7.
_LIBRARY_BITS = 2
_idle_detectors: dict[int, list] = {}  # per table's bit errors, the detectors no thread is using
_detectors_built: dict[int, int] = {}  # per table's bit errors, built or being built
_idle_lock = threading.Lock()


def _table_bits(options: DetectionOptions) -> int:
    """The bit errors the detector's decoding table needs: a tag36h11 code is 11 bits or more
    from every other code turned any way, so a table for fewer errors only leaves out the
    detections with more, which `max_hamming` drops anyway (the library's own table holds 2)."""
    return min(options.max_hamming, _LIBRARY_BITS)


@contextmanager
def _apriltag_detector(options: DetectionOptions) -> Iterator:
    """A detector for `options` (its decimation, the table for their bit errors) for this
    thread's use (one is not safe to share between threads): an idle one if any, else a new
    one. A capture needs only as many as its threads search at once, whatever their
    decimations (a detector's is a field set before each search)."""
    bits = _table_bits(options)
    with _idle_lock:
        idle = _idle_detectors.setdefault(bits, [])
        detector = idle.pop() if idle else None
        if detector is None:
            _detectors_built[bits] = _detectors_built.get(bits, 0) + 1
    if detector is None:
        detector = _new_detector(bits)
    detector.tag_detector_ptr.contents.quad_decimate = float(options.decimate or 1.0)
    try:
        yield detector
    finally:
        with _idle_lock:
            _idle_detectors[bits].append(detector)


def _new_detector(bits: int):  # noqa: ANN202
    """A tag36h11 detector whose decoding table corrects `bits` bit errors. The library's
    constructor takes a family name and builds its 2-bit table: it is made for tag16h5 (30
    codes: 0.1 ms), whose family goes again before tag36h11's is added. Kept for the process's
    life and freed at exit by `_release` (the library's own teardown reads a freed family)."""
    import ctypes

    from pupil_apriltags import Detector
    from pupil_apriltags.bindings import _ApriltagFamily

    detector = Detector(families="tag16h5", nthreads=1, quad_sigma=0.0, refine_edges=1)
    atexit.register(_release, detector)
    libc = detector.libc
    libc.apriltag_detector_clear_families.restype = None
    libc.apriltag_detector_clear_families(detector.tag_detector_ptr)  # frees tag16h5's table
    libc.tag16h5_destroy.restype = None
    libc.tag16h5_destroy(detector.tag_families.pop("tag16h5"))
    libc.tag36h11_create.restype = ctypes.POINTER(_ApriltagFamily)
    family = detector.tag_families["tag36h11"] = libc.tag36h11_create()  # a family per detector: it holds the table
    libc.apriltag_detector_add_family_bits(detector.tag_detector_ptr, family, bits)
    return detector


def prepare_detectors(options: DetectionOptions, count: int) -> None:
    """Build detectors for `options` until `count` exist: a capture's runs each search their
    first frames at once, and building theirs while the first frame is searched, on the core
    that search leaves idle, takes that off the runs' start."""
    if options.detector != "apriltag":
        return
    bits = _table_bits(options)
    with _idle_lock:
        missing = max(count - _detectors_built.get(bits, 0), 0)
        _detectors_built[bits] = _detectors_built.get(bits, 0) + missing
    for _ in range(missing):
        detector = _new_detector(bits)
        with _idle_lock:
            _idle_detectors.setdefault(bits, []).append(detector)


def _release(detector) -> None:  # noqa: ANN001
    """Free a pupil-apriltags detector (ours or the library's own) safely.

    The library's own `__del__` frees the tag family before the detector, whose destructor then
    reads the freed family: an intermittent segfault at exit. Destroy the detector first instead.
    """
    if detector.tag_detector_ptr is None:
        return
    detector.libc.apriltag_detector_destroy.restype = None
    detector.libc.apriltag_detector_destroy(detector.tag_detector_ptr)
    for name, family in detector.tag_families.items():
        destroy = getattr(detector.libc, f"{name}_destroy")
        destroy.restype = None
        destroy(family)
    detector.tag_detector_ptr = None


def _detect_apriltag(gray: np.ndarray, options: DetectionOptions) -> dict[int, np.ndarray]:
    found: dict[int, np.ndarray] = {}
    with _apriltag_detector(options) as detector:
        detections = detector.detect(np.ascontiguousarray(gray))
    for detection in detections:
        if detection.hamming > options.max_hamming:
            continue
        # The library starts at the tag image's top-right and runs counter-clockwise in the
        # picture, and puts pixel centres at half-integers; both measured against renders
        # of known poses (mean corner offset below 0.02 px after this conversion).
        corners = np.asarray(detection.corners, dtype=np.float64)[[1, 0, 3, 2]] - 0.5
        _keep_unique(found, int(detection.tag_id), corners)
    return found


def _detect_opencv(gray: np.ndarray, options: DetectionOptions) -> dict[int, np.ndarray]:
    import cv2

    parameters = cv2.aruco.DetectorParameters()
    parameters.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_NONE
    parameters.maxErroneousBitsInBorderRate = 0.2
    parameters.errorCorrectionRate = options.max_hamming / 5.0
    detector = cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11), parameters)
    corners, ids, _rejected = detector.detectMarkers(gray)
    found: dict[int, np.ndarray] = {}
    for tag_id, tag_corners in zip(np.ravel(ids) if ids is not None else [], corners):
        _keep_unique(found, int(tag_id), np.asarray(tag_corners, dtype=np.float64).reshape(4, 2))
    return found


def _keep_unique(found: dict[int, np.ndarray], tag_id: int, corners: np.ndarray) -> None:
    """A tag id seen twice in one image is ambiguous: drop both (NaN corners mark the id)."""
    if tag_id in found:
        found[tag_id] = np.full((4, 2), np.nan)
    else:
        found[tag_id] = corners


def detect_tags(
    gray: np.ndarray, options: DetectionOptions | None = None, window: PixelWindow | None = None
) -> dict[int, np.ndarray]:
    """Tag id -> (4, 2) corners in pixels, for each tag36h11 tag found once in the image, or
    once in its `window` (the search's time goes with the pixels searched; the corners are
    refined on the whole image and given in its pixels)."""
    options = options or DetectionOptions()
    gray = np.asarray(gray)
    if gray.ndim != 2 or gray.dtype != np.uint8:
        raise ValueError(f"{gray.shape=}, {gray.dtype=} but expected an (H, W) uint8 image")
    searched = gray if window is None else np.ascontiguousarray(gray[window.top : window.bottom, window.left : window.right])
    if options.detector == "apriltag":
        found = _detect_apriltag(searched, options)
    elif options.detector == "opencv":
        found = _detect_opencv(searched, options)
    else:
        raise ValueError(f"unknown tag detector {options.detector!r}")
    shift = np.zeros(2) if window is None else np.array([window.left, window.top], dtype=np.float64)
    found = {tag_id: c + shift for tag_id, c in found.items() if np.all(np.isfinite(c))}
    if options.edge_refinement and found:
        ids = sorted(found)
        refined = refine_edges(gray, np.stack([found[i] for i in ids]), LINEAR_LEVELS[options.intensity])
        found = dict(zip(ids, refined))
    return found


_LEVELS = np.arange(256) / 255.0
# Each 8-bit level's linear intensity: the sides are found on the linear image (see `refine_edges`).
LINEAR_LEVELS = {
    "linear": _LEVELS,
    "srgb": srgb_decode(_LEVELS),
}


_ALONG = np.linspace(0.15, 0.85, 12)  # where along each side the profiles are taken (clear of corners)
_MIN_ROWS = 4  # profiles with one clear crossing a side needs for its line
_REMAP_GRID = 32  # OpenCV's remap rounds coordinates to 1/32 px (INTER_TAB_SIZE)
_REMAP_ROWS = 32766  # the most rows remap's maps may have (SHRT_MAX - 1)


def refine_edges(gray: np.ndarray, corners: np.ndarray, linear: np.ndarray = LINEAR_LEVELS["linear"]) -> np.ndarray:
    """Corners (T, 4, 2) as intersections of the tags' refined sides in an (H, W) uint8 image
    whose levels have the linear intensities `linear` (256,); a corner stays as detected where
    one of its sides is unclear (see `refined_edges`)."""
    return refined_edges(gray, corners, linear)[0]


def refined_edges(gray: np.ndarray, corners: np.ndarray, linear: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The corners (T, 4, 2) refined as `refine_edges` says, and (T, 4) which were: both sides
    clear.

    Each side is moved to where a linear image's intensity crosses halfway between the black
    border (inside) and the white margin (outside): the edge itself for any symmetric blur.
    The detectors' own corners sat 0.4 px (AprilTag) to 0.9 px (OpenCV) inside the tag on
    renders of known poses; these within 0.01 px on average. All sides of all tags at once.
    """
    import cv2

    corners = np.asarray(corners, dtype=np.float64)
    start, side = corners, corners[:, [1, 2, 3, 0]] - corners  # side i runs from corner i to i + 1
    length = np.linalg.norm(side, axis=-1)  # (T, 4)
    direction = side / np.maximum(length, 1e-9)[..., None]
    outward = np.stack([direction[..., 1], -direction[..., 0]], axis=-1)
    middle = start + side / 2 - corners.mean(axis=1, keepdims=True)
    outward *= np.where(np.sum(outward * middle, axis=-1) < 0, -1.0, 1.0)[..., None]
    half_width = 0.8 * length / 8  # within the one-cell black border and white margin
    # Samples no farther apart than half a pixel across the widest edge band.
    steps = int(np.clip(np.ceil(4 * half_width.max()) + 1, 17, 161))
    across = np.linspace(-1.0, 1.0, steps)
    offsets = half_width[..., None] * across  # (T, 4, M)
    base = start[:, :, None, :] + _ALONG[None, None, :, None] * side[:, :, None, :]  # (T, 4, N, 2)
    # The samples on the grid where OpenCV's remap interpolates exactly (it rounds to it), each
    # crossing placed between its samples where they lie: on the bench mug's frames the corners
    # moved 0.003 px (median) and lie as close to the truth, for a third of NumPy's sampling time.
    # In 1/32 px units (scaling by 32 is exact), rounded, then as remap's float32 maps in the
    # frame of the pixels they reach (exact there too); x and y each (T, 4, N, M) through one
    # scratch array (each fresh array of these had cost more than its arithmetic).
    reach = half_width.max() + 1.0  # no sample lies farther than this beyond the corners' box
    levels, left, top = _window_levels(gray, linear, corners.min(axis=(0, 1)) - reach, corners.max(axis=(0, 1)) + reach)
    grid = np.empty((*half_width.shape, len(_ALONG), steps))
    maps = np.empty((2, *grid.shape), np.float32)
    for axis, origin in ((0, left), (1, top)):
        across_px = offsets * (outward[..., axis, None] * _REMAP_GRID)  # (T, 4, M)
        np.add((base[..., axis] * _REMAP_GRID)[..., None], across_px[:, :, None, :], out=grid)
        np.rint(grid, out=grid)
        grid -= origin * _REMAP_GRID
        np.multiply(grid, 1.0 / _REMAP_GRID, out=maps[axis], casting="unsafe")
    # A tag's profiles in one row of the maps: remap runs faster on long rows (and a board has
    # far fewer tags than the rows remap allows).
    rows = (len(corners), -1)
    profiles = cv2.remap(levels, maps[0].reshape(rows), maps[1].reshape(rows), cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    at, fraction, usable = profile_crossings(profiles.reshape(grid.shape), max(2, steps // 5), 0.05)  # (T, 4, N)

    def sample(values: np.ndarray, after: int = 0) -> np.ndarray:  # (T, 4, N)
        return values.reshape(-1)[at + after].reshape(usable.shape)

    points = np.stack(
        [
            (1 - fraction) * (sample(axis_map).astype(np.float64) + origin)
            + fraction * (sample(axis_map, 1).astype(np.float64) + origin)
            for axis_map, origin in ((maps[0], left), (maps[1], top))
        ],
        axis=-1,
    )  # (T, 4, N, 2)
    # Each side's line through its usable crossing points (total least squares).
    weight = usable.astype(np.float64)
    count = weight.sum(axis=-1)
    valid = (count >= _MIN_ROWS) & (half_width >= 1.0)
    centre = np.sum(points * weight[..., None], axis=2) / np.maximum(count, 1)[..., None]
    dx, dy = np.moveaxis(points - centre[:, :, None, :], -1, 0)
    xx, xy, yy = np.sum(weight * dx * dx, axis=-1), np.sum(weight * dx * dy, axis=-1), np.sum(weight * dy * dy, axis=-1)
    # The 2 x 2 scatter's larger eigenvalue's vector, in closed form (NumPy's batched eigh cost more).
    angle = 0.5 * np.arctan2(2 * xy, xx - yy)
    line_direction = np.stack([np.cos(angle), np.sin(angle)], axis=-1)
    # Corner i joins side i - 1 (ending there) and side i (starting there).
    previous = [3, 0, 1, 2]  # np.roll's order, without its cost
    p1, d1, ok1 = centre[:, previous], line_direction[:, previous], valid[:, previous]
    p2, d2 = centre, line_direction
    determinant = d1[..., 0] * (-d2[..., 1]) - (-d2[..., 0]) * d1[..., 1]
    good = ok1 & valid & (np.abs(determinant) > 1e-6)
    rhs = p2 - p1
    t = (rhs[..., 0] * (-d2[..., 1]) - (-d2[..., 0]) * rhs[..., 1]) / np.where(good, determinant, 1.0)
    refined = p1 + t[..., None] * d1
    return np.where(good[..., None], refined, corners), good


def profile_crossings(profiles: np.ndarray, level_samples: int, min_contrast: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where each profile (..., M) of linear intensities, dark end first, crosses halfway between
    its dark and bright levels (the means of its first and last `level_samples` samples): the
    sample before the crossing as a flat index into `profiles`, the crossing's fraction of the
    step beyond it, and (...) whether the profile is usable (one crossing, its levels
    `min_contrast` or more apart; elsewhere the fraction is 0)."""
    steps, k = profiles.shape[-1], level_samples
    if k < 8:  # `refined_edges` on tag sides up to 95 px, the cell edges' 4: np.mean on rows this
        # short costs more than the rest of the profile's arithmetic; the k samples summed in
        # order give its values bit for bit (from 8 on, it sums in pairs).
        dark, bright = (sum(profiles[..., i] for i in range(start, start + k)) / profiles.dtype.type(k) for start in (0, steps - k))
    else:
        dark, bright = profiles[..., :k].mean(axis=-1), profiles[..., -k:].mean(axis=-1)
    midway = (dark + bright) / 2
    above = profiles >= midway[..., None]
    rising = above[..., 1:] > above[..., :-1]
    usable = (rising.view(np.uint8).sum(axis=-1, dtype=np.uint8) == 1) & (bright - dark >= min_contrast)
    # One flat index for the gathers (take_along_axis built its own index arrays for each).
    at = np.argmax(rising, axis=-1).ravel() + np.arange(0, profiles.size, steps)
    flat = profiles.reshape(-1)
    before, after = flat[at].reshape(usable.shape) - midway, flat[at + 1].reshape(usable.shape) - midway
    fraction = np.where(usable, -before / np.where(after - before > 1e-9, after - before, 1.0), 0.0)
    return at, fraction, usable


def _window_levels(
    gray: np.ndarray, linear: np.ndarray, low: Sequence[float] | np.ndarray, high: Sequence[float] | np.ndarray
) -> tuple[np.ndarray, int, int]:
    """The linear intensities (float32) of the pixels that points from `low` to `high` (x, y)
    interpolate between, 2 x 2 at least, and the window's left and top pixel: only those
    pixels are converted."""
    import cv2

    height, width = gray.shape
    left, top = min(max(int(low[0]) - 1, 0), width - 2), min(max(int(low[1]) - 1, 0), height - 2)
    right, bottom = max(min(int(high[0]) + 3, width), left + 2), max(min(int(high[1]) + 3, height), top + 2)
    return cv2.LUT(gray[top:bottom, left:right], linear.astype(np.float32)), left, top


def bilinear_levels(gray: np.ndarray, linear: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The linear intensity (float32) at (x, y), interpolated between the four pixels around
    each point, points beyond the border taking the border's (as SciPy's map_coordinates with
    order 1 and mode "nearest"). By OpenCV's remap, which rounds the points to 1/32 px
    (`_REMAP_GRID`): exact on that grid, within 1/64 px of the point elsewhere. Images of 2 x 2
    pixels or more."""
    import cv2

    levels, left, top = _window_levels(gray, linear, (x.min(), y.min()), (x.max(), y.max()))
    rows = (-1, x.shape[-1])
    map_x, map_y = (x - left).astype(np.float32).reshape(rows), (y - top).astype(np.float32).reshape(rows)
    # remap takes maps of fewer than 32767 rows (a board of ~700 tags would fill them).
    return np.concatenate(
        [
            cv2.remap(levels, map_x[i : i + _REMAP_ROWS], map_y[i : i + _REMAP_ROWS], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
            for i in range(0, len(map_x), _REMAP_ROWS)
        ]
    ).reshape(x.shape)
