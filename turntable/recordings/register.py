"""Depth registered to colour when the recording did not: every depth pixel back-projected
with the depth camera (its distortion removed), moved by `color_from_depth`, and splatted over
the colour pixels its footprint covers, the nearest surface winning (as the RealSense SDK's
align does). No hole is filled: colour pixels no depth pixel reaches stay empty."""

from __future__ import annotations

import numpy as np

from homemodel.geometry.camera import Camera

_MAX_FOOTPRINT_PX = 4  # a depth pixel covers at most this many colour pixels a side


def register_depth(
    depth_m: np.ndarray, depth_camera: Camera, color_camera: Camera, color_from_depth: np.ndarray
) -> np.ndarray:
    """(color H, color W) float32 metres, NaN where no depth pixel lands."""
    depth_m = np.asarray(depth_m, dtype=np.float64)
    if depth_m.shape != (depth_camera.height, depth_camera.width):
        raise ValueError(f"{depth_m.shape=} but the depth camera is {depth_camera.width}x{depth_camera.height}")
    color_from_depth = np.asarray(color_from_depth, dtype=np.float64)
    if color_from_depth.shape != (4, 4):
        raise ValueError(f"{color_from_depth.shape=} but expected (4, 4)")
    valid = np.isfinite(depth_m) & (depth_m > 0)
    v, u = np.nonzero(valid)
    z = depth_m[v, u]
    # The footprint: the pixel's corners (u +- 1/2, v +- 1/2) at its depth, seen by colour.
    corners = []
    for du, dv in ((-0.5, -0.5), (0.5, 0.5)):
        rays = depth_camera.rays(np.column_stack([u + du, v + dv]))
        points = (rays * z[:, None]) @ color_from_depth[:3, :3].T + color_from_depth[:3, 3]
        front = points[:, 2] > 1e-6
        pixels = np.full((len(z), 2), np.nan)
        pixels[front] = color_camera.project(points[front])
        corners.append((pixels, points[:, 2]))
    (lo, z_lo), (hi, z_hi) = corners
    z_color = 0.5 * (z_lo + z_hi)
    # The colour pixel centres (integers) inside the footprint; at least the one nearest its middle.
    middle = np.round((lo + hi) / 2)
    first = np.minimum(np.ceil(np.minimum(lo, hi)), middle)
    last = np.maximum(np.floor(np.maximum(lo, hi)) + 1, middle + 1)  # exclusive
    ok = np.all(np.isfinite(first) & np.isfinite(last), axis=1) & (z_color > 0)
    first, last, z_color = first[ok].astype(np.int64), last[ok].astype(np.int64), z_color[ok]
    size = np.clip(last - first, 1, _MAX_FOOTPRINT_PX)
    out = np.full(color_camera.height * color_camera.width, np.inf)
    for dy in range(_MAX_FOOTPRINT_PX):
        for dx in range(_MAX_FOOTPRINT_PX):
            x, y = first[:, 0] + dx, first[:, 1] + dy
            inside = (dx < size[:, 0]) & (dy < size[:, 1])
            inside &= (x >= 0) & (x < color_camera.width) & (y >= 0) & (y < color_camera.height)
            np.minimum.at(out, y[inside] * color_camera.width + x[inside], z_color[inside])
    out[~np.isfinite(out)] = np.nan
    return out.reshape(color_camera.height, color_camera.width).astype(np.float32)
