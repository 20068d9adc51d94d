"""The observed depth image as the fitters compare it with rendered depth: at a reduced
resolution (each pixel the median of a block of valid readings, which also averages the
sensor's noise down), with a per-pixel tolerance that grows with the sensor's axial noise.

A view at `factor` k is seen through `Camera.scaled(1 / k)`, whose pixel centres are the
blocks' centres, so the scene renders onto it directly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from homemodel.geometry.camera import Camera
from tracking.sensor_noise import axial_sigma_m


@dataclass(kw_only=True)
class FitView:
    """Observed depth on `camera`'s pixels; `depth_m` is NaN where there is no reading."""

    camera: Camera
    map_from_camera: np.ndarray
    depth_m: np.ndarray  # (H, W) float64
    tolerance_m: np.ndarray  # (H, W) float64: a residual beyond it is not noise
    color_rgb: np.ndarray | None = None  # (H, W, 3) uint8, registered to the depth; full resolution only

    @classmethod
    def from_depth(
        cls,
        camera: Camera,
        map_from_camera: np.ndarray,
        depth_m: np.ndarray,
        *,
        factor: int,
        min_tolerance_m: float,
        tolerance_sigmas: float,
        color_rgb: np.ndarray | None = None,
    ) -> FitView:
        """The view of a full-resolution depth image (NaN or 0 = no reading) in blocks of
        `factor` x `factor` pixels; the edge rows and columns that fill no block are dropped.
        The colour image is kept at full resolution (`factor` 1) only."""
        depth = np.asarray(depth_m, dtype=np.float64)
        depth = np.where(np.isfinite(depth) & (depth > 0), depth, np.nan)
        if factor > 1:
            h, w = depth.shape[0] // factor, depth.shape[1] // factor
            blocks = depth[: h * factor, : w * factor].reshape(h, factor, w, factor).transpose(0, 2, 1, 3)
            depth = _nan_median(blocks.reshape(h, w, -1))
            camera = _scaled(camera, factor, w, h)
        tolerance = np.maximum(min_tolerance_m, tolerance_sigmas * axial_sigma_m(np.nan_to_num(depth, nan=0.0)))
        return cls(camera=camera, map_from_camera=np.asarray(map_from_camera, dtype=np.float64), depth_m=depth,
                   tolerance_m=tolerance, color_rgb=color_rgb if factor == 1 else None)

    def around(self, corners_map: np.ndarray, margin_px: int = 2) -> tuple[FitView, tuple[slice, slice]] | None:
        """The view cut down to the image box of (N, 3) map-frame points (a box's corners, in
        front of the camera), and the (rows, columns) of this view it keeps; None when the box
        is out of the image. What fits one small thing renders and compares only that window."""
        camera_from_map = np.linalg.inv(self.map_from_camera)
        points = np.asarray(corners_map, dtype=np.float64) @ camera_from_map[:3, :3].T + camera_from_map[:3, 3]
        in_front = points[:, 2] > 0.05
        if not in_front.any():
            return None
        if self.camera.has_distortion or not in_front.all():
            # A lens bends the box's outline; a box reaching behind the camera has no image box.
            return self, (slice(None), slice(None))
        uv = self.camera.project(points)
        u0, v0 = np.maximum(np.floor(uv.min(axis=0)).astype(int) - margin_px, 0)
        u1, v1 = np.minimum(np.ceil(uv.max(axis=0)).astype(int) + margin_px, [self.camera.width - 1, self.camera.height - 1])
        if u0 > u1 or v0 > v1:
            return None
        rows, columns = slice(int(v0), int(v1) + 1), slice(int(u0), int(u1) + 1)
        return self.crop(rows, columns), (rows, columns)

    def crop(self, rows: slice, columns: slice) -> FitView:
        """The view of the pixels `rows` x `columns` (slices with a start and a stop, in the image)."""
        camera = Camera(**{**self.camera.model_dump(), "width": columns.stop - columns.start,
                           "height": rows.stop - rows.start, "cx": self.camera.cx - columns.start,
                           "cy": self.camera.cy - rows.start})
        color = None if self.color_rgb is None else self.color_rgb[rows, columns]
        return FitView(camera=camera, map_from_camera=self.map_from_camera, depth_m=self.depth_m[rows, columns],
                       tolerance_m=self.tolerance_m[rows, columns], color_rgb=color)

    def strided(self, stride: int) -> FitView:
        """The view of every `stride`-th pixel in each direction (from the first): the same
        readings and tolerances on a 1 / stride² share of the pixels, each ray unchanged."""
        depth = self.depth_m[::stride, ::stride]
        camera = Camera(**{**self.camera.model_dump(), "width": depth.shape[1], "height": depth.shape[0],
                           "fx": self.camera.fx / stride, "fy": self.camera.fy / stride,
                           "cx": self.camera.cx / stride, "cy": self.camera.cy / stride})
        color = None if self.color_rgb is None else self.color_rgb[::stride, ::stride]
        return FitView(camera=camera, map_from_camera=self.map_from_camera, depth_m=depth,
                       tolerance_m=self.tolerance_m[::stride, ::stride], color_rgb=color)

    @property
    def valid(self) -> np.ndarray:
        return np.isfinite(self.depth_m)

    def points_map(self, depth_m: np.ndarray, mask: np.ndarray) -> np.ndarray:
        """(N, 3) map-frame points of `depth_m` (this view's shape) at the pixels of `mask` where
        it holds a depth (finite, positive), row by row."""
        return self.points_map_at(mask & np.isfinite(depth_m) & (depth_m > 0), depth_m)[0]

    def points_map_at(self, mask: np.ndarray, *depths_m: np.ndarray) -> list[np.ndarray]:
        """(N, 3) map-frame points of each depth image (this view's shape) at the pixels of
        `mask`, where each holds a depth, row by row: the pixels' rays found once for all."""
        v, u = np.nonzero(mask)
        rays = self.camera.rays(np.column_stack([u, v]))
        rotation, origin = self.map_from_camera[:3, :3], self.map_from_camera[:3, 3]
        return [(rays * depth[v, u].astype(np.float64)[:, None]) @ rotation.T + origin for depth in depths_m]

    def directions_map(self, mask: np.ndarray) -> np.ndarray:
        """(N, 3) rays (z = 1 in the camera) through the pixels of `mask`, in the map frame."""
        v, u = np.nonzero(mask)
        return self.camera.rays(np.column_stack([u, v])) @ self.map_from_camera[:3, :3].T


def _nan_median(values: np.ndarray) -> np.ndarray:
    """`np.nanmedian` over the last axis (NaN where all are NaN) by one sort: NaNs sort last,
    so the k valid values' middle two sit at (k - 1) // 2 and k // 2 (one, for odd k)."""
    ordered = np.sort(values, axis=-1)
    count = np.isfinite(ordered).sum(axis=-1, keepdims=True)
    low = np.take_along_axis(ordered, np.maximum(count - 1, 0) // 2, axis=-1)
    high = np.take_along_axis(ordered, np.minimum(count // 2, values.shape[-1] - 1), axis=-1)
    return np.where(count > 0, (low + high) / 2, np.nan)[..., 0]


def _scaled(camera: Camera, factor: int, width: int, height: int) -> Camera:
    # Camera.scaled rounds the size; blocks drop the edge pixels that fill no block.
    return Camera(**{**camera.scaled(1.0 / factor).model_dump(), "width": width, "height": height})


def chromaticity(rgb: np.ndarray) -> np.ndarray:
    """(..., 3) colour with its brightness divided out (r, g, b over their sum), so shading
    does not change it; black gives grey."""
    rgb = np.asarray(rgb, dtype=np.float64)
    total = rgb.sum(axis=-1, keepdims=True)
    return np.where(total > 1e-9, rgb / np.maximum(total, 1e-9), 1.0 / 3.0)
