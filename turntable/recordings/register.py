"""Depth registered to colour when the recording did not: the depth image as a surface (two
triangles per 2x2 block of valid pixels, none across a depth jump), its vertices
back-projected with the depth camera (distortion removed), moved by `color_from_depth`,
projected with the colour camera (distortion applied) and rasterised there with a z-buffer,
z interpolated inside each triangle. Each colour pixel so gets the depth of the surface point
on its own ray, whether colour is finer or coarser than depth; the nearest surface wins. No
hole is filled: colour pixels no triangle covers, and depth edges, stay empty.

Edges are found in the depth camera's own pixels, before any interpolation: its flying pixels
go first (the filter reconstruct runs on registered depth, which cannot see them once a
triangle has spread one over several colour pixels), then a triangle is left out when its
depths differ more than a surface seen `_GRAZING_DEG` off its normal would across one depth
pixel (z tan(angle) / f: the shadow/veil-point filters' rule in angle terms, so the same for
a 320x240 and a 1280x720 depth), or more than the depth's own noise makes likely
(`_NOISE_RANGES` sigmas, the noise read off the frame)."""

from __future__ import annotations

import math

import numpy as np

from homemodel.geometry.camera import Camera
from turntable.real_frames import drop_flying_pixels

_MAX_TRIANGLE_PX = 8  # a triangle's projection larger than this a side: skipped (a grazing sliver)
# A triangle steeper than this to the depth camera's ray spans an edge. 3 % of depth a pixel
# (80 deg at a 320x240 depth's f = 191 px) joined a bottle's silhouette to the table behind it
# near its base (jumps of 0-20 mm at 0.68 m): a flared skirt 16 mm high, 1.25 mm from the
# truth; 75 deg 1.04 mm, 70 deg 1.00 (the same frames registered by the simulator: 0.97-1.01).
_GRAZING_DEG = 75.0
# ... unless the depth's noise makes that much likely between a triangle's corners: the angle's
# rule is 0.55 % of depth a pixel for a 1280x720 depth, and the simulated sensor's noise
# (1.2 mm at 0.5 m) dropped 24 % of a flat wall's triangles facing the camera at 0.5 m, 34 %
# at 45 degrees. Three corners' range passes 5 sigmas once in 800.
_NOISE_RANGES = 5.0
# The median of |N(0, 6 sigma^2)|: a noisy surface's median second difference along a row
# (a plane's own, even steep, is near 0, so slopes do not pass for noise).
_MEDIAN_CURVE_SIGMAS = 1.652


def _triangle_columns(
    x: np.ndarray, y: np.ndarray, z: np.ndarray, image_size: tuple[int, int], edge_relative_jump: float
) -> list[np.ndarray]:
    """Per drawn triangle of each 2x2 block of (H, W) colour-pixel coordinates x, y and depth z
    (NaN: none; a triangle whose depths differ more than `edge_relative_jump` x its nearest
    spans an edge): its bounding box clipped to the (width, height) `image_size` as first pixel
    and size (size 0 for a degenerate one), and s, t, 1/z as affine functions of the pixel
    (x, y) (the barycentric coordinates; 1/z interpolates linearly). A triangle with a corner
    without depth, across a depth jump, too large or off the image is left out: those tests run
    on the blocks' corner views, the rest only on the triangles they pass."""
    a, b, c, d = (np.s_[:-1, :-1], np.s_[:-1, 1:], np.s_[1:, :-1], np.s_[1:, 1:])
    width = x.shape[1]
    # Both triangles, (a, b, c) and (b, d, c), share the diagonal b-c: its extremes once
    # (minimum and maximum are exact in any order).
    low_x, high_x = np.minimum(x[b], x[c]), np.maximum(x[b], x[c])
    low_y, high_y = np.minimum(y[b], y[c]), np.maximum(y[b], y[c])
    low_z, high_z = np.fmin(z[b], z[c]), np.fmax(z[b], z[c])
    corner_index = []
    for apex, corner_offsets in ((a, (0, 1, width)), (d, (1, width + 1, width))):
        with np.errstate(invalid="ignore"):
            low, high = np.fmin(low_z, z[apex]), np.fmax(high_z, z[apex])
            ok = (high - low) <= edge_relative_jump * low  # False with a NaN corner
            for low_v, high_v, v, limit in ((low_x, high_x, x, image_size[0]), (low_y, high_y, y, image_size[1])):
                first, last = np.ceil(np.minimum(low_v, v[apex])), np.floor(np.maximum(high_v, v[apex]))
                size = last - first + 1
                ok &= (size <= _MAX_TRIANGLE_PX) & (size > 0) & (last >= 0) & (first < limit)
        rows, cols = np.nonzero(ok)
        anchor = rows * width + cols
        corner_index.append([anchor + offset for offset in corner_offsets])
    flat = [v.ravel() for v in (x, y, z)]
    (x0, y0, z0), (x1, y1, z1), (x2, y2, z2) = (
        tuple(v[index] for v in flat) for index in map(np.concatenate, zip(*corner_index))
    )
    bounds = []
    for v0, v1, v2, limit in ((x0, x1, x2, image_size[0]), (y0, y1, y2, image_size[1])):
        first = np.maximum(np.ceil(np.minimum(np.minimum(v0, v1), v2)), 0).astype(np.int64)
        end = np.minimum(np.floor(np.maximum(np.maximum(v0, v1), v2)) + 1, limit).astype(np.int64)
        bounds.append((first, end - first))
    (first_x, size_x), (first_y, size_y) = bounds
    e1x, e1y, e2x, e2y = x1 - x0, y1 - y0, x2 - x0, y2 - y0
    det = e1x * e2y - e1y * e2x
    size_x[np.abs(det) <= 1e-12] = 0
    with np.errstate(divide="ignore", invalid="ignore"):  # the degenerate ones: not drawn
        s_x, s_y, t_x, t_y = e2y / det, -e2x / det, -e1y / det, e1x / det
        s_c, t_c = -(s_x * x0 + s_y * y0), -(t_x * x0 + t_y * y0)
        w0, w1, w2 = 1.0 / z0, 1.0 / z1 - 1.0 / z0, 1.0 / z2 - 1.0 / z0
        w_x, w_y, w_c = w1 * s_x + w2 * t_x, w1 * s_y + w2 * t_y, w0 + w1 * s_c + w2 * t_c
    return [first_x, first_y, size_x, size_y, s_x, s_y, s_c, t_x, t_y, t_c, w_x, w_y, w_c]


def _relative_noise(depth: np.ndarray) -> float:
    """The depth's pixel noise as a share of depth (sigma), from the median relative second
    difference along every fourth row; 0 for a noise-free depth."""
    rows = depth[::4]
    with np.errstate(invalid="ignore", divide="ignore"):
        curves = np.abs(rows[:, 2:] - 2 * rows[:, 1:-1] + rows[:, :-2]) / rows[:, 1:-1]
    curves = curves[np.isfinite(curves)]
    return float(np.median(curves)) / _MEDIAN_CURVE_SIGMAS if curves.size else 0.0


def register_depth(
    depth_m: np.ndarray,
    depth_camera: Camera,
    color_camera: Camera,
    color_from_depth: np.ndarray,
    depth_rays: np.ndarray | None = None,
) -> np.ndarray:
    """(color H, color W) float32 metres, NaN where no depth lands; `depth_rays` (h*w, 3) the
    depth pixels' rays by a lens `depth_camera` only approximates."""
    depth = np.asarray(depth_m, dtype=np.float64)
    if depth.shape != (depth_camera.height, depth_camera.width):
        raise ValueError(f"{depth.shape=} but the depth camera is {depth_camera.width}x{depth_camera.height}")
    color_from_depth = np.asarray(color_from_depth, dtype=np.float64)
    if color_from_depth.shape != (4, 4):
        raise ValueError(f"{color_from_depth.shape=} but expected (4, 4)")
    height, width = depth.shape
    depth = drop_flying_pixels(depth, math.sqrt(depth_camera.fx * depth_camera.fy))[0].astype(np.float64)
    valid = np.isfinite(depth) & (depth > 0)
    # Every pixel's point in colour's frame and where colour sees it.
    rays = depth_camera.pixel_rays() if depth_rays is None else depth_rays
    points = rays * np.where(valid, depth, 1.0).reshape(-1, 1)
    points = points @ color_from_depth[:3, :3].T + color_from_depth[:3, 3]
    front = valid.ravel() & (points[:, 2] > 1e-6)
    pixel_x, pixel_y = np.full((2, height * width), np.nan)  # each contiguous, for the views' passes
    pixel_x[front], pixel_y[front] = color_camera.project(points[front]).T
    z = np.where(front, points[:, 2], np.nan)
    edge_relative_jump = max(
        math.tan(math.radians(_GRAZING_DEG)) / math.sqrt(depth_camera.fx * depth_camera.fy),
        _NOISE_RANGES * _relative_noise(depth),
    )
    first_x, first_y, size_x, size_y, *coefficients = _triangle_columns(
        *(v.reshape(height, width) for v in (pixel_x, pixel_y, z)),
        (color_camera.width, color_camera.height),
        edge_relative_jump,
    )
    # Triangles grouped by their box's size: each group's passes over its boxes' pixels run on
    # contiguous arrays (most triangles cover 1-3 pixels a side).
    drawn = np.flatnonzero(size_x > 0)
    size_key = (size_y[drawn] * (_MAX_TRIANGLE_PX + 1) + size_x[drawn]).astype(np.uint8)
    drawn = drawn[np.argsort(size_key, kind="stable")]  # a radix sort on the small key
    first_index = (first_y * color_camera.width + first_x)[drawn]
    columns = [v[drawn] for v in (first_x.astype(np.float64), first_y.astype(np.float64), *coefficients)]
    size = np.column_stack([size_x[drawn], size_y[drawn]])
    starts = np.flatnonzero(np.any(np.diff(size, axis=0, prepend=-1) != 0, axis=1))  # none if none drawn
    out = np.full(color_camera.height * color_camera.width, np.inf)
    for start, end in zip(starts, np.r_[starts[1:], len(size)]):
        fx, fy, sx, sy, sc, tx, ty, tc, wx, wy, wc = (v[start:end] for v in columns)
        for dy in range(size[start, 1]):
            y = fy + dy
            s_row, t_row, w_row = sy * y + sc, ty * y + tc, wy * y + wc
            for dx in range(size[start, 0]):
                x = fx + dx
                s, t = sx * x + s_row, tx * x + t_row
                inside = (s >= -1e-9) & (t >= -1e-9) & (s + t <= 1 + 1e-9)
                index = first_index[start:end][inside] + (dy * color_camera.width + dx)
                np.minimum.at(out, index, 1.0 / (wx[inside] * x[inside] + w_row[inside]))
    out[~np.isfinite(out)] = np.nan
    return out.reshape(color_camera.height, color_camera.width).astype(np.float32)


def expected_edge_offset_px(depth_camera: Camera, color_camera: Camera, color_from_depth: np.ndarray) -> np.ndarray:
    """(dx, dy) colour px: what `real_frames.depth_color_offset_px` reads on depth registered
    here with an exact extrinsic. The surface joins the depth pixels' centres, so a near
    object's registered silhouette ends half a depth pixel inside its own; and only on its side
    towards the depth camera's offset (`color_from_depth`'s x, y) does the farther surface
    continue under it (the other side is the depth camera's shadow, left empty), so only there
    does depth jump between two pixels with depth, which is all the estimate sees: half a depth
    pixel (in colour px) along the offset. On import_fix's bottle probe (ray-cast, colour from a
    4x supersampled mask, depth 15 mm beside): read 0.86-1.45 px where this gives 0.61-1.52,
    within 0.2-0.7 px of it; (0, 0) for depth of colour's own camera."""
    offset = np.asarray(color_from_depth, dtype=np.float64)[:2, 3]
    length = float(np.hypot(*offset))
    if length == 0.0:
        return np.zeros(2)
    depth_pixel_px = math.sqrt(color_camera.fx * color_camera.fy / (depth_camera.fx * depth_camera.fy))
    return 0.5 * depth_pixel_px * offset / length
