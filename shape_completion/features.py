"""Features of a depth image for the retrieval forest: Rock et al.'s pixel tests, plus size.

The object's pixels are cropped to a square around their bounding box and resampled to a
`PATCH` x `PATCH` patch, so the tests do not depend on where the object is in the image or
how far away it is. Two kinds of binary test, drawn once at random and kept in the model:
a silhouette test (is pixel p inside the object?) and a depth-order test (is p nearer than
q?, the background counting as infinitely far).

Departure from the paper: the paper draws new random tests at every node of its trees.
scikit-learn's forests split on given columns, so a fixed pool of tests is drawn up front
and each node searches a random subset of it (`max_features`), which is the same sampling
in a different order. Also added (not in the paper): the object's metric width, height and
depth range, which tell a spoon from a bottle when their silhouettes agree.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from homemodel.geometry.camera import Camera

PATCH = 32


@dataclass(kw_only=True, frozen=True)
class PixelTests:
    """Indices into a flattened PATCH x PATCH patch: silhouette tests and depth-order pairs."""

    silhouette: np.ndarray  # (S,)
    depth_pairs: np.ndarray  # (D, 2)

    @classmethod
    def draw(cls, *, n_silhouette: int, n_depth: int, seed: int) -> PixelTests:
        rng = np.random.default_rng(seed)
        pixels = PATCH * PATCH
        pairs = rng.integers(0, pixels, size=(n_depth, 2))
        pairs = pairs[pairs[:, 0] != pairs[:, 1]]
        return cls(silhouette=rng.integers(0, pixels, size=n_silhouette), depth_pairs=pairs)

    @property
    def n_features(self) -> int:
        return len(self.silhouette) + len(self.depth_pairs) + len(SIZE_FEATURES)


SIZE_FEATURES = ("width_m", "height_m", "depth_range_m")


def object_patch(depth_m: np.ndarray) -> np.ndarray:
    """PATCH x PATCH depth relative to the nearest object point, +inf off the object.

    `depth_m` holds the object alone (NaN elsewhere). Nearest-neighbour resampling keeps
    the silhouette sharp and depths unmixed.
    """
    valid = np.isfinite(depth_m)
    rows, cols = np.nonzero(valid)
    top, bottom, left, right = rows.min(), rows.max() + 1, cols.min(), cols.max() + 1
    side = max(bottom - top, right - left)
    centre_r, centre_c = 0.5 * (top + bottom), 0.5 * (left + right)
    # Sample the square's pixel grid directly (it may reach past the image border).
    offsets = (np.arange(PATCH) + 0.5) / PATCH * side - 0.5 * side
    r = np.floor(centre_r + offsets).astype(int)
    c = np.floor(centre_c + offsets).astype(int)
    rr, cc = np.meshgrid(r, c, indexing="ij")
    inside = (rr >= 0) & (rr < depth_m.shape[0]) & (cc >= 0) & (cc < depth_m.shape[1])
    patch = np.full((PATCH, PATCH), np.inf)
    patch[inside] = depth_m[rr[inside], cc[inside]]
    patch[~np.isfinite(patch)] = np.inf
    return patch - np.min(depth_m[valid])


def size_features(depth_m: np.ndarray, camera: Camera) -> np.ndarray:
    """Metric width and height of the silhouette at the object's median depth, and its depth range."""
    rows, cols = np.nonzero(np.isfinite(depth_m))
    z = depth_m[rows, cols]
    median = float(np.median(z))
    width = (cols.max() - cols.min() + 1) * median / camera.fx
    height = (rows.max() - rows.min() + 1) * median / camera.fy
    return np.array([width, height, float(np.percentile(z, 98) - np.percentile(z, 2))])


def view_features(depth_m: np.ndarray, camera: Camera, tests: PixelTests) -> np.ndarray:
    """The feature vector of one object-only depth image (NaN off the object)."""
    patch = object_patch(depth_m).ravel()
    silhouette = np.isfinite(patch[tests.silhouette])
    nearer = patch[tests.depth_pairs[:, 0]] < patch[tests.depth_pairs[:, 1]]
    return np.concatenate([silhouette, nearer, size_features(depth_m, camera)]).astype(np.float32)


def clean_object_depth(depth_m: np.ndarray, *, min_fraction: float = 0.05) -> np.ndarray:
    """Drop specks (blobs under `min_fraction` of the largest) that would stretch the crop;
    a mug's handle seen apart from its body is kept."""
    valid = np.isfinite(depth_m).astype(np.uint8)
    count, labels, stats, _ = cv2.connectedComponentsWithStats(valid, connectivity=8)
    if count <= 2:
        return depth_m
    areas = stats[1:, cv2.CC_STAT_AREA]
    keep = np.concatenate([[False], areas >= min_fraction * areas.max()])
    return np.where(keep[labels], depth_m, np.nan).astype(depth_m.dtype)
