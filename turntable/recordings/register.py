"""Depth registered to colour when the recording did not: the depth image as a surface (two
triangles per 2x2 block of valid pixels, none across a depth jump), its vertices
back-projected with the depth camera (distortion removed), moved by `color_from_depth`,
projected with the colour camera (distortion applied) and rasterised there with a z-buffer,
z interpolated inside each triangle. Each colour pixel so gets the depth of the surface point
on its own ray, whether colour is finer or coarser than depth; the nearest surface wins. No
hole is filled: colour pixels no triangle covers, and depth edges, stay empty."""

from __future__ import annotations

import numpy as np

from homemodel.geometry.camera import Camera

_MAX_TRIANGLE_PX = 8  # a triangle's projection larger than this a side: skipped (a grazing sliver)
_EDGE_RELATIVE_JUMP = 0.03  # a triangle whose depths differ more than this (x depth) spans an edge


def register_depth(
    depth_m: np.ndarray, depth_camera: Camera, color_camera: Camera, color_from_depth: np.ndarray
) -> np.ndarray:
    """(color H, color W) float32 metres, NaN where no depth lands."""
    depth = np.asarray(depth_m, dtype=np.float64)
    if depth.shape != (depth_camera.height, depth_camera.width):
        raise ValueError(f"{depth.shape=} but the depth camera is {depth_camera.width}x{depth_camera.height}")
    color_from_depth = np.asarray(color_from_depth, dtype=np.float64)
    if color_from_depth.shape != (4, 4):
        raise ValueError(f"{color_from_depth.shape=} but expected (4, 4)")
    height, width = depth.shape
    valid = np.isfinite(depth) & (depth > 0)
    # Every pixel's point in colour's frame and where colour sees it.
    points = depth_camera.pixel_rays() * np.where(valid, depth, 1.0).reshape(-1, 1)
    points = points @ color_from_depth[:3, :3].T + color_from_depth[:3, 3]
    front = valid.ravel() & (points[:, 2] > 1e-6)
    pixels = np.full((height * width, 2), np.nan)
    pixels[front] = color_camera.project(points[front])
    z = np.where(front, points[:, 2], np.nan)
    index = np.arange(height * width).reshape(height, width)
    a, b, c, d = index[:-1, :-1].ravel(), index[:-1, 1:].ravel(), index[1:, :-1].ravel(), index[1:, 1:].ravel()
    triangles = np.concatenate([np.column_stack([a, b, c]), np.column_stack([b, d, c])])
    # Per-triangle minima and maxima over the three corners pairwise: numpy's reductions
    # along a length-3 axis cost several times more (most of this function's time).
    tz = z[triangles]
    ok = np.isfinite(tz[:, 0]) & np.isfinite(tz[:, 1]) & np.isfinite(tz[:, 2])
    triangles, tz = triangles[ok], tz[ok]
    low = np.minimum(np.minimum(tz[:, 0], tz[:, 1]), tz[:, 2])
    high = np.maximum(np.maximum(tz[:, 0], tz[:, 1]), tz[:, 2])
    ok = (high - low) <= _EDGE_RELATIVE_JUMP * low
    triangles, tz = triangles[ok], tz[ok]
    tp = pixels[triangles]  # (T, 3, 2)
    first = np.ceil(np.minimum(np.minimum(tp[:, 0], tp[:, 1]), tp[:, 2])).astype(np.int64)
    size = np.floor(np.maximum(np.maximum(tp[:, 0], tp[:, 1]), tp[:, 2])).astype(np.int64) - first + 1
    ok = (size[:, 0] <= _MAX_TRIANGLE_PX) & (size[:, 1] <= _MAX_TRIANGLE_PX) & (size[:, 0] > 0) & (size[:, 1] > 0)
    tp, tz, first, size = tp[ok], tz[ok], first[ok], size[ok]
    # Barycentric coordinates from the triangle's edge vectors; 1/z interpolates linearly.
    e1, e2 = tp[:, 1] - tp[:, 0], tp[:, 2] - tp[:, 0]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    ok = np.abs(det) > 1e-12
    tp, tz, first, size, e1, e2, det = tp[ok], tz[ok], first[ok], size[ok], e1[ok], e2[ok], det[ok]
    inverse_z = 1.0 / tz
    out = np.full(color_camera.height * color_camera.width, np.inf)
    for dy in range(int(size[:, 1].max(initial=0))):
        for dx in range(int(size[:, 0].max(initial=0))):
            k = np.flatnonzero((size[:, 0] > dx) & (size[:, 1] > dy))  # most triangles cover 1-3 pixels a side
            x, y = first[k, 0] + dx, first[k, 1] + dy
            px, py = x - tp[k, 0, 0], y - tp[k, 0, 1]
            s = (px * e2[k, 1] - py * e2[k, 0]) / det[k]
            t = (e1[k, 0] * py - e1[k, 1] * px) / det[k]
            inside = (s >= -1e-9) & (t >= -1e-9) & (s + t <= 1 + 1e-9)
            inside &= (x >= 0) & (x < color_camera.width) & (y >= 0) & (y < color_camera.height)
            k, s, t = k[inside], s[inside], t[inside]
            values = 1.0 / (inverse_z[k, 0] * (1 - s - t) + inverse_z[k, 1] * s + inverse_z[k, 2] * t)
            np.minimum.at(out, y[inside] * color_camera.width + x[inside], values)
    out[~np.isfinite(out)] = np.nan
    return out.reshape(color_camera.height, color_camera.width).astype(np.float32)
