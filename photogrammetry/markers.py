"""Markers of known size in the photos: detection and the names of their dictionaries.

D3.1's "hand crafted featured areas" (Figure 16) become printed ArUco or AprilTag
markers; their corners, seen in several registered photos, give the model its metric scale.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np

from homemodel.core.errors import InputError
from homemodel.core.srgb import srgb_decode

# The user-facing names of OpenCV's predefined dictionaries (`cv2.aruco.DICT_<NAME>`).
MarkerDictionary = Literal["apriltag_36h11", "apriltag_25h9", "4x4_50", "4x4_250", "5x5_100", "5x5_250", "6x6_250"]
DICTIONARIES: tuple[str, ...] = get_args(MarkerDictionary)


def aruco_dictionary(name: str):
    """The OpenCV dictionary called `name` (one of DICTIONARIES)."""
    import cv2

    if name not in DICTIONARIES:
        raise InputError(f"unknown marker dictionary {name!r}; choose one of {', '.join(DICTIONARIES)}")
    return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, f"DICT_{name.upper()}"))


@dataclass(kw_only=True)
class MarkerSighting:
    """One marker seen in one photo: its four corners in pixels, OpenCV's order
    (top-left, top-right, bottom-right, bottom-left of the printed marker)."""

    image_name: str
    marker_id: int
    corners_px: np.ndarray  # (4, 2)


def _linear_light_lut() -> np.ndarray:
    """sRGB-encoded 8-bit values to linear light (8-bit), the inverse of the sRGB curve."""
    x = np.arange(256) / 255.0
    return np.round(srgb_decode(x) * 255).astype(np.uint8)


def _detector(dictionary: str, refinement: int):
    import cv2

    parameters = cv2.aruco.DetectorParameters()
    parameters.cornerRefinementMethod = refinement
    return cv2.aruco.ArucoDetector(aruco_dictionary(dictionary), parameters)


def detect_markers(gray: np.ndarray, image_name: str, dictionary: str) -> list[MarkerSighting]:
    """Markers of `dictionary` in one 8-bit sRGB grey image, corners refined to sub-pixel.

    A photo's blur happens in linear light and is then sRGB-encoded, which makes black squares
    look smaller: measured on renders with known cameras, marker edges came out 2% short. In
    linear light, with OpenCV's AprilTag edge-fitting refinement, they came out within 0.1%.
    That refinement costs 0.25 s on a whole 1600 px photo, so markers are found without it and
    refined in a crop around each (the same corners, within 1e-4 px, in a third of the time).
    """
    import cv2

    linear = cv2.LUT(gray, _linear_light_lut())
    corners, ids, _ = _detector(dictionary, cv2.aruco.CORNER_REFINE_NONE).detectMarkers(linear)
    if ids is None:
        return []
    refiner = _detector(dictionary, cv2.aruco.CORNER_REFINE_APRILTAG)
    sightings = []
    for found, marker_id in zip(corners, ids.ravel()):
        found = found.reshape(4, 2)
        low, high = found.min(axis=0), found.max(axis=0)
        margin = max(16.0, 0.5 * float((high - low).max()))  # the quiet zone and the edges' blur
        x0, y0 = np.maximum(np.floor(low - margin).astype(int), 0)
        x1, y1 = np.minimum(np.ceil(high + margin).astype(int), (linear.shape[1], linear.shape[0]))
        refined, refined_ids, _ = refiner.detectMarkers(np.ascontiguousarray(linear[y0:y1, x0:x1]))
        for quad, refined_id in zip(refined, refined_ids.ravel() if refined_ids is not None else []):
            if refined_id == marker_id:
                sightings.append(MarkerSighting(image_name=image_name, marker_id=int(marker_id),
                                                corners_px=np.asarray(quad, np.float64).reshape(4, 2) + (x0, y0)))  # fmt: skip
                break
    return sightings


@dataclass(kw_only=True)
class TriangulatedMarker:
    """A marker's four corners in the SfM frame, from at least two registered views."""

    marker_id: int
    corners: np.ndarray  # (4, 3), OpenCV's corner order
    views: int
    reprojection_error_px: float

    @property
    def edge_lengths(self) -> np.ndarray:
        return np.linalg.norm(self.corners - np.roll(self.corners, -1, axis=0), axis=1)


def triangulate_point(projections: list[np.ndarray], pixels: list[np.ndarray]) -> np.ndarray:
    """Linear (DLT) triangulation of one point from 3x4 projection matrices and its pixels."""
    rows = []
    for p, (u, v) in zip(projections, pixels):
        rows += [u * p[2] - p[0], v * p[2] - p[1]]
    _, _, vt = np.linalg.svd(np.array(rows))
    return vt[-1, :3] / vt[-1, 3]


def _reprojection_errors(projections: list[np.ndarray], pixels: list[np.ndarray], point: np.ndarray) -> np.ndarray:
    homogeneous = np.append(point, 1.0)
    errors = []
    for p, px in zip(projections, pixels):
        x = p @ homogeneous
        errors.append(np.linalg.norm(x[:2] / x[2] - px) if x[2] > 0 else np.inf)
    return np.array(errors)


def triangulate_markers(
    sightings: list[MarkerSighting],
    projections: dict[str, np.ndarray],
    *,
    max_error_px: float = 2.0,
) -> list[TriangulatedMarker]:
    """Each marker seen in two or more views, corners triangulated; a sighting whose corners
    reproject worse than `max_error_px` (a misdetection, a blurred photo) is dropped."""
    by_id: dict[int, list[MarkerSighting]] = {}
    for s in sightings:
        if s.image_name in projections:
            by_id.setdefault(s.marker_id, []).append(s)
    markers = []
    for marker_id, seen in sorted(by_id.items()):
        for _ in range(3):  # triangulate, drop the sightings that disagree, again
            if len(seen) < 2:
                break
            ps = [projections[s.image_name] for s in seen]
            corners = np.array([triangulate_point(ps, [s.corners_px[c] for s in seen]) for c in range(4)])
            errors = np.max(
                [_reprojection_errors(ps, [s.corners_px[c] for s in seen], corners[c]) for c in range(4)], axis=0
            )
            keep = errors <= max_error_px
            if keep.all():
                markers.append(
                    TriangulatedMarker(
                        marker_id=marker_id,
                        corners=corners,
                        views=len(seen),
                        reprojection_error_px=float(errors.mean()),
                    )
                )
                break
            seen = [s for s, k in zip(seen, keep) if k]
    return markers
