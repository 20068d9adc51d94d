"""The surface a queried object stands on, seen around it in the depth image.

A robot's depth image of a cup on a table holds the table too. RANSAC finds planes among the
pixels that are not the object (all of them when no mask is given); a plane counts as the
support when the object stands on it: the object lies above it, its lowest seen point near
it, the plane is seen on at least three sides of the object in the image (so the flat
inner bottom of a bowl, which the walls surround, is not taken for a table), and it reaches
at least twice as far as the object and 25 cm (so neither is a bottle's flat bottom). Without a mask
the object is then the largest blob of pixels above that plane whose base touches it.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from homemodel.geometry.camera import Camera

RANSAC_POINTS = 2000  # planes are hypothesised and scored on a random sample this large
RANSAC_ITERATIONS = 200
MAX_PLANES = 3  # a floor or a wall may be larger than the table: try the next plane
MIN_PLANE_SHARE = 0.05  # of the image's valid pixels
MIN_PLANE_PIXELS = 300
MAX_BASE_GAP_M = 0.03  # the object's lowest seen point is at most this (plus the tolerance) above the plane
MIN_SIDES = 3  # of left, right, above, below: where the plane must be seen around the object
# A support reaches well past the object (a table around a cup); a flat face of the object
# itself (a bottle's bottom seen from below) does not.
MIN_PLANE_SPREAD = 2.0
MIN_PLANE_SPREAD_M = 0.25  # and a table or shelf seen around an object is at least this wide


@dataclass(kw_only=True)
class SupportPlane:
    """Points p with normal . p + offset_m = 0 (camera frame); the normal points up, to the camera."""

    normal: np.ndarray
    offset_m: float
    inlier_pixels: int
    tolerance_m: float

    def height_m(self, points: np.ndarray) -> np.ndarray:
        return points @ self.normal + self.offset_m


def plane_tolerance_m(depth_m: float) -> float:
    """Inlier distance at a depth: structured-light and time-of-flight noise grows with depth squared."""
    return 0.002 + 0.003 * max(1.0, depth_m) ** 2


def _ransac_plane(points: np.ndarray, tolerance_m: float, rng: np.random.Generator) -> tuple[np.ndarray, float]:
    """The plane (unit normal, offset) with most points within `tolerance_m`, refitted to them."""
    sample = points[rng.choice(len(points), min(len(points), RANSAC_POINTS), replace=False)]
    triples = sample[rng.integers(0, len(sample), size=(RANSAC_ITERATIONS, 3))]
    normals = np.cross(triples[:, 1] - triples[:, 0], triples[:, 2] - triples[:, 0])
    lengths = np.linalg.norm(normals, axis=1)
    ok = lengths > 1e-12
    normals = normals[ok] / lengths[ok, None]
    offsets = -np.einsum("ij,ij->i", normals, triples[ok, 0])
    counts = (np.abs(sample @ normals.T + offsets) < tolerance_m).sum(axis=0)
    best = int(np.argmax(counts))
    inliers = points[np.abs(points @ normals[best] + offsets[best]) < tolerance_m]
    inliers = inliers[rng.choice(len(inliers), min(len(inliers), 10 * RANSAC_POINTS), replace=False)]
    centroid = inliers.mean(axis=0)
    normal = np.linalg.svd(inliers - centroid, full_matrices=False)[2][-1]
    return normal, float(-normal @ centroid)


def _sides_seen(plane_pixels: np.ndarray, object_pixels: np.ndarray) -> int:
    """Of left, right, above and below the object's box in the image: where the plane is seen."""
    rows, cols = np.nonzero(object_pixels)
    top, bottom, left, right = rows.min(), rows.max(), cols.min(), cols.max()
    band_rows, band_cols = plane_pixels[top : bottom + 1], plane_pixels[:, left : right + 1]
    return int(band_rows[:, :left].any()) + int(band_rows[:, right + 1 :].any()) + int(
        band_cols[:top].any()
    ) + int(band_cols[bottom + 1 :].any())


def _spread_m(points: np.ndarray) -> float:
    """The largest of the cloud's extents along x, y and z, 2nd to 98th percentile."""
    low, high = np.percentile(points, [2, 98], axis=0)
    return float(np.max(high - low))


def _blob_on_plane(candidates: np.ndarray, heights: np.ndarray, tolerance_m: float) -> np.ndarray | None:
    """The largest 8-connected blob of pixels clearly above the plane whose lowest point is within
    MAX_BASE_GAP_M of it, grown down to the plane's tolerance (so the object keeps its foot)."""
    above = candidates & (heights > 1.5 * tolerance_m)
    count, labels, stats, _ = cv2.connectedComponentsWithStats(above.astype(np.uint8), connectivity=8)
    best, best_area = None, 0
    for label in range(1, count):
        area = stats[label, cv2.CC_STAT_AREA]
        if area <= best_area:
            continue
        blob = labels == label
        if np.percentile(heights[blob], 2) <= MAX_BASE_GAP_M + tolerance_m:
            best, best_area = blob, area
    if best is None:
        return None
    _, grown = cv2.connectedComponents((candidates & (heights > tolerance_m)).astype(np.uint8), connectivity=8)
    return np.isin(grown, np.unique(grown[best]))


def find_support(
    depth_m: np.ndarray, camera: Camera, object_mask: np.ndarray | None, rng: np.random.Generator
) -> tuple[SupportPlane | None, np.ndarray | None]:
    """The plane the object stands on and the object's pixels (the mask given, or the blob found
    on the plane); (None, None) when no plane under the object is seen. `depth_m` is the whole
    image in metres (NaN or 0 where nothing was measured), seen by the distortion-free `camera`."""
    valid = np.isfinite(depth_m) & (depth_m > 0)
    if valid.sum() < MIN_PLANE_PIXELS:
        return None, None
    rays = camera.pixel_rays().reshape(camera.height, camera.width, 3)
    points = rays * np.where(valid, depth_m, 0.0)[..., None]
    tolerance = plane_tolerance_m(float(np.median(depth_m[valid])))
    candidates = valid & ~object_mask if object_mask is not None else valid.copy()
    for _ in range(MAX_PLANES):
        if candidates.sum() < max(MIN_PLANE_PIXELS, MIN_PLANE_SHARE * valid.sum()):
            return None, None
        normal, offset = _ransac_plane(points[candidates], tolerance, rng)
        if offset < 0:
            normal, offset = -normal, -offset  # up is the camera's side: the camera has positive height
        heights = np.where(valid, points @ normal + offset, np.nan)
        on_plane = candidates & (np.abs(heights) < tolerance)
        if on_plane.sum() < max(MIN_PLANE_PIXELS, MIN_PLANE_SHARE * valid.sum()):
            return None, None
        base_gap = MAX_BASE_GAP_M + tolerance
        if object_mask is not None:
            blob = object_mask & valid if (object_mask & valid).any() else None
        else:
            blob = _blob_on_plane(candidates, heights, tolerance)
        if (
            blob is not None
            and np.percentile(heights[blob], 5) > -3 * tolerance
            and np.percentile(heights[blob], 2) <= base_gap
            and _sides_seen(on_plane, blob) >= MIN_SIDES
            and _spread_m(points[on_plane]) >= max(MIN_PLANE_SPREAD * _spread_m(points[blob]), MIN_PLANE_SPREAD_M)
        ):
            plane = SupportPlane(normal=normal, offset_m=offset, inlier_pixels=int(on_plane.sum()), tolerance_m=tolerance)
            return plane, blob
        candidates &= ~on_plane
    return None, None
