"""What real sensors' frames need before merging, each measured for summary.json: flying
pixels at depth edges dropped (holes are left as they are: no filling), blurred colour frames
found, the depth-to-colour misregistration estimated from where depth edges and colour edges
fall, and each depth frame moved to its own time (the table turns on between a colour frame
and the depth frame associated with it)."""

from __future__ import annotations

import math

import numpy as np

# Flying pixels' thresholds in the pixel's footprint z / f: a surface seen at an angle a from
# the view changes its depth by z tan(a) / f from one pixel to the next, so one rule holds for a
# 256x192 depth camera (f ~150 px, 4 mm a pixel at 0.6 m) and a 640x480 one (f ~530-580 px).
FLYING_JUMP_FOOTPRINTS = 3.0  # from both neighbours: more than a surface 72 deg from the view ...
FLYING_OFF_SURFACE_FOOTPRINTS = 4.6  # ... and off both sides' surfaces carried one pixel on
FLYING_MIN_JUMP_M = 0.003  # the floor of both: a structured-light sensor's noise at 0.6 m is 1.3 mm
# The table turned less than this from the first (or last) frame has not started (or has
# stopped): above the poses' noise (~0.05 deg). A slow turn's step at 30 fps (0.4 deg) is under
# it: its first (and last) two frames are left out of the fit too, which keeps the slope.
STILL_TURN_RAD = math.radians(0.5)
_NEAR_FACTOR = 1.5  # misregistration: depth jumps kept whose near side is within this times the nearest depths


def drop_flying_pixels(depth_m: np.ndarray, focal_px: float) -> tuple[np.ndarray, int]:
    """The depth with its flying pixels set to NaN, and how many went; `focal_px` the depth
    camera's. A flying pixel reads between a foreground and a background surface: along a row
    or a column it lies between its two neighbours, differs from each by more than a jump, and
    lies off each side's surface carried one pixel on (the neighbour plus that side's own step).
    A surface point, even one seen at a grazing angle or curving away at a silhouette, carries
    on one side's surface; a pixel mixed across a step of a few footprints, which the jump alone
    cannot tell from a grazing surface, carries on neither. A neighbour that reads nothing is
    looked past, to the next pixel: a dark or shiny object's holes beside its mixed pixels hid
    them (check29b's glazed mug, 25 % holes: its opening closed by a dome, 1.24 -> 0.84 mm)."""
    import cv2

    depth = np.asarray(depth_m, dtype=np.float32)
    footprint = depth / np.float32(focal_px)
    jump = np.maximum(FLYING_JUMP_FOOTPRINTS * footprint, FLYING_MIN_JUMP_M)
    padded = np.pad(depth, 3, constant_values=np.nan)
    flying = np.zeros(depth.shape, dtype=bool)
    for axis in (0, 1):
        sides = [_beside(padded, depth.shape, axis, side) for side in (-1, 1)]
        (first, *_), (second, *_) = sides
        # Both jumps over the threshold (NaN's are not) and the centre between the two. (OpenCV's
        # absdiff: a third of NumPy's abs of a difference.) Few pass: the surface test runs on those.
        between = (first > depth) != (second > depth)
        at = np.nonzero(between & (cv2.absdiff(first, depth) > jump) & (cv2.absdiff(second, depth) > jump))
        value = depth[at]
        off_surface = np.maximum(FLYING_OFF_SURFACE_FOOTPRINTS * footprint[at], FLYING_MIN_JUMP_M)
        off_both = np.ones(len(value), dtype=bool)
        for near, hole, next_pixel, past in sides:
            beyond = np.where(hole[at], past[at], next_pixel[at])
            step = np.nan_to_num(near[at] - beyond)  # none past a hole or the border
            off_both &= np.abs(value - near[at] - step) > off_surface
        flying[tuple(a[off_both] for a in at)] = True
    out = depth.copy()
    out[flying] = np.nan
    return out, int(np.count_nonzero(flying))


def _beside(
    padded: np.ndarray, shape: tuple[int, ...], axis: int, side: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each pixel's neighbour on `side` (-1 or 1) along `axis`, the next pixel where that one
    reads nothing; and, to find the pixel beyond it, where it read nothing, the next two pixels
    (from the depth padded by 3 NaN's)."""
    height, width = shape

    def shifted(k: int) -> np.ndarray:
        dy, dx = (k, 0) if axis == 0 else (0, k)
        return padded[3 + dy : 3 + dy + height, 3 + dx : 3 + dx + width]

    neighbour, next_pixel, past = (shifted(side * k) for k in (1, 2, 3))
    hole = np.isnan(neighbour)
    return np.where(hole, next_pixel, neighbour), hole, next_pixel, past


def focal_px_of_rays(rays: np.ndarray, width: int) -> float:
    """The focal length a pixel's footprint is measured with: one over the spacing of the rays
    (z = 1, row by row, `width` a row) through the image's two centre pixels."""
    centre = (len(rays) // width // 2) * width + width // 2
    return 1.0 / float(np.hypot(*(rays[centre + 1, :2] - rays[centre, :2])))


def sharpness(gray: np.ndarray) -> float:
    """Variance of the Laplacian: falls by several times under motion or focus blur."""
    import cv2

    # OpenCV's standard deviation, not NumPy's var (a float64 copy and two passes): 20 % less.
    # The 3 x 3 Laplacian of 8-bit levels is an integer within +-2040: int16 holds it exactly
    # (the same value as float32's, bit for bit on the bench frames) at a third of the time.
    return float(cv2.meanStdDev(cv2.Laplacian(gray, cv2.CV_16S, ksize=3))[1][0, 0] ** 2)


def depth_color_offset_px(depth_m: np.ndarray, gray: np.ndarray, max_shift_px: int = 6) -> np.ndarray | None:
    """(dx, dy): the shift of the depth image's edges that best lands them on the colour image's
    edges, to a tenth of a pixel; None when the depth has too few edges to say. Registered
    streams give about (0, 0)."""
    import cv2

    depth = np.asarray(depth_m, dtype=np.float32)
    valid = depth > 0  # False at NaN; a jump next to a NaN is NaN, and no edge
    # Depth edges: jumps over 1 cm between valid neighbours (silhouettes against the background).
    # Both pixels of a jump are marked, so the edge sits between them, where colour's gradient peaks.
    # (OpenCV's absdiff: NumPy's abs of diff in a third of the time, NaN alike.)
    gx = (cv2.absdiff(depth[:, 1:], depth[:, :-1]) > 0.01) & valid[:, 1:] & valid[:, :-1]
    gy = (cv2.absdiff(depth[1:], depth[:-1]) > 0.01) & valid[1:] & valid[:-1]
    # Only jumps whose near side lies within _NEAR_FACTOR of the nearest depths (the 5th
    # percentile of every 8th row and column's): the object's and the table's. A far floor's or
    # wall's noise passes 1 cm between neighbours everywhere (sigma 14 mm at 3 m), where colour
    # has its own texture and no edge of the object.
    sample = depth[::8, ::8][valid[::8, ::8]]
    if sample.size:
        k = sample.size // 20
        far = depth > _NEAR_FACTOR * np.partition(sample, k)[k]  # False at NaN, which no jump has
        gx &= ~(far[:, 1:] & far[:, :-1])
        gy &= ~(far[1:] & far[:-1])
    edges = np.zeros(depth.shape, dtype=bool)
    edges[:, 1:] |= gx
    edges[:, :-1] |= gx
    edges[1:] |= gy
    edges[:-1] |= gy
    m = max_shift_px
    edges[:m], edges[-m:], edges[:, :m], edges[:, -m:] = False, False, False, False
    count = np.count_nonzero(edges)
    if count < 50:
        return None
    # The mean colour-edge strength along the depth edges at each shift: one cross-correlation
    # of the edges' box with the colour edges' magnitude about it.
    rows, cols = np.flatnonzero(edges.any(axis=1)), np.flatnonzero(edges.any(axis=0))
    top, bottom, left, right = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
    pad = m + 5  # Sobel and the Gaussian's reach beyond the shifted box
    y0, x0 = max(top - pad, 0), max(left - pad, 0)
    g = gray[y0 : bottom + pad, x0 : right + pad].astype(np.float32)
    magnitude = cv2.GaussianBlur(np.hypot(cv2.Sobel(g, cv2.CV_32F, 1, 0), cv2.Sobel(g, cv2.CV_32F, 0, 1)), (0, 0), 1.0)
    around = magnitude[top - m - y0 : bottom + m - y0, left - m - x0 : right + m - x0]
    box = edges[top:bottom, left:right].astype(np.float32)
    score = cv2.matchTemplate(around, box, cv2.TM_CCORR) / count  # (2m + 1, 2m + 1): [dy + m, dx + m]
    iy, ix = np.unravel_index(np.argmax(score), score.shape)

    def vertex(values: np.ndarray, i: int) -> float:  # the parabola's peak through three samples
        if 0 < i < len(values) - 1:
            denominator = values[i - 1] - 2 * values[i] + values[i + 1]
            if denominator < 0:
                return float(i + 0.5 * (values[i - 1] - values[i + 1]) / denominator)
        return float(i)

    return np.array([vertex(score[iy], ix), vertex(score[:, ix], iy)]) - m


def table_turn_rad(first_camera_from_table: np.ndarray, camera_from_table: np.ndarray) -> float:
    """The table's rotation about its own z between two poses of the fixed camera."""
    first_from_now = np.linalg.inv(first_camera_from_table) @ camera_from_table
    return math.atan2(first_from_now[1, 0], first_from_now[0, 0])


def turn_rate_rad_s(camera_from_tables: list[np.ndarray], times_s: list[float]) -> float | None:
    """The table's angular speed: the least-squares slope of its unwrapped angle over time
    (frames in time order, each less than half a turn from the last), one slope shared by the
    stretches it turns in; None below 3 frames. A still table's frames are left out: a still
    start or end (two frames or more within STILL_TURN_RAD of the run's first) and a pause
    (three or more): 8 s of a still table before a turn at 20 deg/s read 15.05 deg/s, a 4 s
    pause in mid-turn 11.1."""
    if len(times_s) < 3:
        return None
    angles = np.unwrap([table_turn_rad(camera_from_tables[0], c) for c in camera_from_tables])
    times = np.asarray(times_s, dtype=np.float64)
    still = _still_frames(angles)
    if np.count_nonzero(~still) < 3:
        still[:] = False
    # Each stretch between still runs keeps its own intercept: the pause's angle is not a turn's.
    stretch = np.concatenate([[0], np.cumsum(still[1:] != still[:-1])])[~still]
    times, angles = times[~still], angles[~still]
    dt = times - np.bincount(stretch, times)[stretch] / np.bincount(stretch)[stretch]
    da = angles - np.bincount(stretch, angles)[stretch] / np.bincount(stretch)[stretch]
    return float(dt @ da / (dt @ dt)) if dt @ dt > 0 else None


def _still_frames(angles: np.ndarray) -> np.ndarray:
    """Which frames are a still table's: runs within STILL_TURN_RAD of their first frame, of two
    frames or more at the start or the end (one is the first of a turning table), three or more
    between (a slow turn's two frames at 30 fps lie within it, its three do not)."""
    still = np.zeros(len(angles), dtype=bool)
    first = 0
    while first < len(angles):
        end = first + 1
        while end < len(angles) and abs(angles[end] - angles[first]) <= STILL_TURN_RAD:
            end += 1
        if end - first >= (2 if first == 0 or end == len(angles) else 3):
            still[first:end] = True
            first = end
        else:
            first += 1
    return still


def turned_table(axis_xy_m: np.ndarray, angle_rad: float) -> np.ndarray:
    """table_from_turned_table: the table turned by `angle_rad` about its axis, so that
    camera_from_table at a later time is camera_from_table @ this."""
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    rotation = np.array([[c, -s, 0.0, 0.0], [s, c, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
    shift = np.eye(4)
    shift[:2, 3] = axis_xy_m
    return shift @ rotation @ np.linalg.inv(shift)
