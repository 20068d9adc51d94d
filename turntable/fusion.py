"""Merge the frames in the table frame: back-project each depth image, keep the points above
the table top and inside the cylinder over the turntable's axis, and average coordinates,
colours and viewing directions per voxel (D3.1 section 3.3.3)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from homemodel.core.errors import ModelError


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


_FLUSH_POINTS = 250_000
_KEY_BITS = 21  # per axis of a voxel's key: +-1.5 km at 1.5 mm
_KEY_OFFSET = 1 << (_KEY_BITS - 1)
_KEY_MASK = (1 << _KEY_BITS) - 1
# Sums per voxel, one row each: the coordinates, the colour, the viewing direction, the count.
_POINT_ROWS, _COLOR_ROWS, _VIEW_ROWS, _COUNT_ROW = slice(0, 3), slice(3, 6), slice(6, 9), 9
# Voxels are grouped through a dense grid over the keys' box while it holds at most this many
# cells a point (the object's box does); beyond it (stray points far apart) by sorting.
_DENSE_CELLS_PER_POINT = 8


@dataclass(kw_only=True)
class VoxelAccumulator:
    """Running sums per voxel. Frames are buffered and folded into the sums a few million
    points at a time, so memory stays bounded and the grouping runs rarely."""

    voxel_size_m: float
    _keys: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    _sums: np.ndarray = field(default_factory=lambda: np.zeros((10, 0)))  # rows as _POINT_ROWS ...
    _pending: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=list)
    _pending_points: int = 0

    def add(self, points: np.ndarray, colors: np.ndarray, view_dirs: np.ndarray) -> None:
        """A frame's points (N, 3), colours (N, 3) and directions (N, 3); the arrays are kept, not
        copied, until the next fold: the caller does not change them after."""
        if len(points) == 0:
            return
        index = np.floor(points / self.voxel_size_m).astype(np.int64)
        index += _KEY_OFFSET
        keys = index[:, 0] << 2 * _KEY_BITS
        keys |= index[:, 1] << _KEY_BITS
        keys |= index[:, 2]
        self._pending.append((keys, points, colors, view_dirs))
        self._pending_points += len(points)
        if self._pending_points > _FLUSH_POINTS:
            self._flush()

    def _flush(self) -> None:
        if not self._pending:
            return
        keys = np.concatenate([self._keys, *(pending[0] for pending in self._pending)])
        groups, self._keys = _voxels(keys)
        # One contiguous row per summed quantity, made just before its weighted bin count reads
        # it in one pass (a (N, 10) array's strided columns and np.unique's sort had cost 2.5x
        # the CPU time). A row at a time in one buffer, not all ten at once: a fresh 20 MB
        # block's first touch had cost a 40-frame merge 6,400 page faults (10 ms of kernel time).
        sums, weights = np.empty((10, len(self._keys))), np.empty(len(keys))
        for row in range(10):
            if row == _COUNT_ROW:
                frames = [np.ones(len(pending[0])) for pending in self._pending]
            else:
                quantity, column = divmod(row, 3)  # the points', the colours', the directions' columns
                frames = [pending[1 + quantity][:, column] for pending in self._pending]
            np.concatenate([self._sums[row], *frames], out=weights)
            sums[row] = np.bincount(groups, weights=weights, minlength=len(self._keys))
        self._sums = sums
        self._pending, self._pending_points = [], 0

    def cloud(self, min_count: int = 1) -> MergedCloud:
        """The voxel centroids of coordinates and colours, and mean viewing directions."""
        self._flush()
        n = self._sums[_COUNT_ROW]
        keep = n >= min_count
        if not np.any(keep):
            raise ModelError("no depth point fell inside the object's cylinder above the table")
        sums, n = self._sums[:, keep].T, n[keep, None]
        view = sums[:, _VIEW_ROWS] / np.maximum(np.linalg.norm(sums[:, _VIEW_ROWS], axis=1, keepdims=True), 1e-12)
        points, colors = sums[:, _POINT_ROWS] / n, sums[:, _COLOR_ROWS] / n
        return MergedCloud(points=points, colors=colors, view_dirs=view, counts=n[:, 0].astype(np.int64))


def _voxels(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(each key's voxel index, the voxels' keys in increasing order): np.unique's inverse and
    unique, through a dense grid over the keys' box when it is small enough (no sort)."""
    axes = (keys >> 2 * _KEY_BITS, (keys >> _KEY_BITS) & _KEY_MASK, keys & _KEY_MASK)
    low = [int(axis.min()) for axis in axes]
    span = [int(axis.max()) - start + 1 for axis, start in zip(axes, low)]
    if span[0] * span[1] * span[2] > _DENSE_CELLS_PER_POINT * len(keys):
        unique, inverse = np.unique(keys, return_inverse=True)
        return inverse, unique
    # Cells in the keys' own order (x, then y, then z): the ranks of the occupied ones are
    # np.unique's inverse. The grid holds a flag a cell, and a rank where one is occupied (the
    # rest of `rank` is never written, so never touched): a count and a cumulative sum over
    # every cell had been 16 bytes a cell, 36 MB of fresh pages at 200 frames.
    cell = axes[0] - low[0]
    for axis, start, size in zip(axes[1:], low[1:], span[1:]):
        cell *= size
        cell += axis - start
    occupied = np.zeros(span[0] * span[1] * span[2], dtype=bool)
    occupied[cell] = True
    cells = np.flatnonzero(occupied)
    rank = np.empty(len(occupied), dtype=np.intp)
    rank[cells] = np.arange(len(cells))
    x, y, z = np.unravel_index(cells, span)
    unique = ((x + low[0]) << 2 * _KEY_BITS) | ((y + low[1]) << _KEY_BITS) | (z + low[2])
    return rank[cell], unique


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
    from turntable.real_frames import drop_flying_pixels, focal_px_of_rays

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
        cleaned, flying = drop_flying_pixels(depth_m[top:bottom, left:right], focal_px_of_rays(rays, width))
        index = index[np.isfinite(cleaned[rows - top, cols - left])]
    pixels = ObjectPixels(
        index=index.astype(np.int32), depth_m=depth[index].astype(np.float32), rgb=rgb.reshape(-1, 3)[index]
    )
    return pixels, flying


def pixel_points(
    pixels: ObjectPixels, rays: np.ndarray, table_from_camera: np.ndarray, cylinder: Cylinder
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pixels' points inside `cylinder`, in the table frame, with colours in [0, 1] and
    unit directions towards the camera, in the rays' precision (float32: 0.02 um at 0.3 m; the
    voxel sums are float64 all the same). Rows are gathered by `np.take` and `np.compress`,
    a fifth of fancy and boolean indexing's time on (n, 3) arrays (with float32: 0.85 -> 0.35
    CPU-ms a bench mug frame of 8,900 pixels)."""
    dtype = rays.dtype
    eye = table_from_camera[:3, 3].astype(dtype)
    points = np.take(rays, pixels.index, axis=0)
    points *= pixels.depth_m[:, None]
    points = points @ table_from_camera[:3, :3].T.astype(dtype)
    points += eye
    x, y, z = points.T
    radial = x - dtype.type(cylinder.axis_xy_m[0])  # squared, in place
    radial *= radial
    across = y - dtype.type(cylinder.axis_xy_m[1])
    across *= across
    radial += across
    inside = (z > cylinder.z_min_m) & (z < cylinder.z_max_m) & (radial < cylinder.radius_m**2)
    points = np.compress(inside, points, axis=0)
    colors = np.compress(inside, pixels.rgb, axis=0) * dtype.type(1 / 255)
    to_camera = eye - points
    to_camera /= np.sqrt(np.einsum("ij,ij->i", to_camera, to_camera))[:, None]
    return points, colors, to_camera
