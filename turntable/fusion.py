"""Merge the frames in the table frame: back-project each depth image, keep the points above
the table top and inside the cylinder over the turntable's axis, and average coordinates,
colours and viewing directions per voxel (D3.1 section 3.3.3)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from homemodel.core.errors import ModelError
from homemodel.geometry.voxel_cells import group_sums


@dataclass(kw_only=True)
class Cylinder:
    """The region the object stands in, in the table frame."""

    axis_xy_m: np.ndarray
    radius_m: float
    z_min_m: float  # above the table top, clear of its depth noise
    z_max_m: float


@dataclass(kw_only=True)
class MergedCloud:
    points: np.ndarray  # (N, 3) table frame
    colors: np.ndarray  # (N, 3) in [0, 1]
    view_dirs: np.ndarray  # (N, 3) unit, from the point towards the cameras that saw it
    counts: np.ndarray  # (N,) raw points per voxel


_FLUSH_POINTS = 2_000_000


@dataclass(kw_only=True)
class VoxelAccumulator:
    """Running sums per voxel. Frames are buffered and folded into the sums a few million
    points at a time, so memory stays bounded and the grouping sort runs rarely."""

    voxel_size_m: float
    _keys: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    _sums: np.ndarray = field(default_factory=lambda: np.zeros((0, 10)))
    _pending: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)
    _pending_points: int = 0

    def add(self, points: np.ndarray, colors: np.ndarray, view_dirs: np.ndarray) -> None:
        if len(points) == 0:
            return
        index = np.floor(points / self.voxel_size_m).astype(np.int64) + (1 << 20)
        keys = (index[:, 0] << 42) | (index[:, 1] << 21) | index[:, 2]
        self._pending.append((keys, np.column_stack([points, colors, view_dirs, np.ones(len(points))])))
        self._pending_points += len(points)
        if self._pending_points > _FLUSH_POINTS:
            self._flush()

    def _flush(self) -> None:
        if not self._pending:
            return
        keys = np.concatenate([self._keys, *(k for k, _ in self._pending)])
        values = np.concatenate([self._sums, *(v for _, v in self._pending)])
        unique, inverse = np.unique(keys, return_inverse=True)
        self._keys, self._sums = unique, group_sums(inverse, values, len(unique))
        self._pending, self._pending_points = [], 0

    def cloud(self, min_count: int = 1) -> MergedCloud:
        """The voxel centroids of coordinates and colours, and mean viewing directions."""
        self._flush()
        n = self._sums[:, 9]
        keep = n >= min_count
        if not np.any(keep):
            raise ModelError("no depth point fell inside the object's cylinder above the table")
        sums, n = self._sums[keep], n[keep, None]
        view = sums[:, 6:9] / np.maximum(np.linalg.norm(sums[:, 6:9], axis=1, keepdims=True), 1e-12)
        return MergedCloud(
            points=sums[:, 0:3] / n, colors=sums[:, 3:6] / n, view_dirs=view, counts=n[:, 0].astype(np.int64)
        )


@dataclass(kw_only=True)
class ObjectPixels:
    """A frame's pixels that may show the object, kept from its one reading for the merge:
    flat pixel indices, their depth and colour."""

    index: np.ndarray  # (n,) int32 into the image's pixels, row by row
    depth_m: np.ndarray  # (n,) float32
    rgb: np.ndarray  # (n, 3) uint8


def object_pixels(
    depth_m: np.ndarray,
    rgb: np.ndarray,
    rays: np.ndarray,
    table_from_camera: np.ndarray,
    region: Cylinder,
    *,
    drop_flying: bool,
) -> tuple[ObjectPixels, int]:
    """The pixels whose points lie inside `region` (table frame), and how many flying pixels
    went. Flying pixels are looked for only around those pixels: the object's edges, not the
    room's."""
    from turntable.real_frames import drop_flying_pixels

    height, width = depth_m.shape
    depth = depth_m.reshape(-1)
    rotation, eye = table_from_camera[:3, :3], table_from_camera[:3, 3]
    # Height above the table first, with one product per pixel: the table top and the room
    # (most pixels) go before any other arithmetic on them. NaN compares False.
    z = depth * (rays @ rotation[2].astype(rays.dtype)) + eye[2]  # in the rays' precision (float32: half the time)
    index = np.flatnonzero((z > region.z_min_m) & (z < region.z_max_m))
    points = (rays[index] * depth[index, None]) @ rotation[:2].T + eye[:2]
    index = index[np.hypot(*(points - region.axis_xy_m).T) < region.radius_m]
    flying = 0
    if drop_flying and len(index):
        rows, cols = np.divmod(index, width)
        top, left = max(int(rows.min()) - 1, 0), max(int(cols.min()) - 1, 0)
        bottom, right = min(int(rows.max()) + 2, height), min(int(cols.max()) + 2, width)
        cleaned, flying = drop_flying_pixels(depth_m[top:bottom, left:right])
        index = index[np.isfinite(cleaned[rows - top, cols - left])]
    pixels = ObjectPixels(
        index=index.astype(np.int32), depth_m=depth[index].astype(np.float32), rgb=rgb.reshape(-1, 3)[index]
    )
    return pixels, flying


def pixel_points(
    pixels: ObjectPixels, rays: np.ndarray, table_from_camera: np.ndarray, cylinder: Cylinder
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pixels' points inside `cylinder`, in the table frame, with colours in [0, 1] and
    unit directions towards the camera."""
    eye = table_from_camera[:3, 3]
    points = (rays[pixels.index] * pixels.depth_m[:, None]) @ table_from_camera[:3, :3].T + eye
    radial = np.hypot(points[:, 0] - cylinder.axis_xy_m[0], points[:, 1] - cylinder.axis_xy_m[1])
    inside = (points[:, 2] > cylinder.z_min_m) & (points[:, 2] < cylinder.z_max_m) & (radial < cylinder.radius_m)
    points = points[inside]
    colors = pixels.rgb[inside].astype(np.float64) / 255.0
    to_camera = eye - points
    to_camera /= np.linalg.norm(to_camera, axis=1, keepdims=True)
    return points, colors, to_camera
