"""Photos to texture images: read and check a photo, find a face in it, rectify it (no bpy).

A planar face is rectified with OpenCV's perspective warp onto an image of the face's
metric aspect ratio. A round side (`wrap`) becomes one image round the whole
circumference: the photographed band is unrolled into its angular span (as sin of the
angle for a side view, linearly for a flat label) and the rest is the part's colour.

Pixel coordinates: x right, y down, pixel centres at integers, so an image W wide spans
-0.5 .. W - 0.5. Problems with a photo raise `FieldError` naming the `FacePhoto` field
to blame; the caller adds the spec file and `photos.<i>`.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from homemodel.core.atomic import write_bytes_atomic
from homemodel.core.checks import require_at_least, require_between, require_positive
from homemodel.core.errors import InputError
from homemodel.core.images import read_image
from homemodel.core.yaml_specs import FieldError
from modeller.specs.photos import FacePhoto, quad_problem

# A detected outline must cover this much of its region, so specks are not taken for a face.
_MIN_DETECTED_FRACTION = 0.05


@dataclass(kw_only=True)
class FaceTextureOptions:
    """How finely a photo is resampled onto a face.

    The texture takes the photo's own pixel density on the face (its sharpest edge),
    capped by `max_px_per_m` and by `max_side_px` for the longer side; JPEG at
    `jpeg_quality` keeps a typical face texture at tens of kilobytes.
    """

    max_px_per_m: float = 2000.0
    max_side_px: int = 1024
    min_side_px: int = 8
    jpeg_quality: int = 90

    def check(self) -> None:
        require_positive("max_px_per_m", self.max_px_per_m)
        require_at_least("min_side_px", self.min_side_px, 1)
        require_at_least("max_side_px", self.max_side_px, self.min_side_px)
        require_between("jpeg_quality", self.jpeg_quality, 1, 100)


_TEXTURE_ROOT: tempfile.TemporaryDirectory | None = None


def texture_folder() -> Path:
    """A new folder for one build's texture images, inside a folder of this process that is
    removed when it exits: the model refers to its textures by path until it is exported."""
    global _TEXTURE_ROOT
    if _TEXTURE_ROOT is None:
        _TEXTURE_ROOT = tempfile.TemporaryDirectory(prefix="homemodel-textures-")
    return Path(tempfile.mkdtemp(dir=_TEXTURE_ROOT.name))


def check_photo(photo: FacePhoto) -> np.ndarray:
    """Read the photo and find the face in it, as a build will; returns the corners."""
    return face_corners_px(photo, read_photo(photo.photo))


def read_photo(path: Path) -> np.ndarray:
    """The photo at `path` as an 8-bit BGR image (H, W, 3)."""
    try:
        return read_image(path)
    except InputError as exc:
        raise FieldError(("photo",), str(exc)) from None


def face_corners_px(photo: FacePhoto, image: np.ndarray) -> np.ndarray:
    """The face's four corners in `image` (top-left, top-right, bottom-right, bottom-left): the
    given ones, checked to lie in the photo, or those detected in `region_px`."""
    height, width = image.shape[:2]
    if photo.corners_px is not None:
        corners = np.asarray(photo.corners_px, dtype=np.float64)
        outside = [
            i for i, (x, y) in enumerate(corners) if not (-0.5 <= x <= width - 0.5 and -0.5 <= y <= height - 0.5)
        ]
        if outside:
            names = ("top-left", "top-right", "bottom-right", "bottom-left")
            i = outside[0]
            raise FieldError(
                ("corners_px", i),
                f"{names[i]} corner {corners[i].tolist()} lies outside the {width}x{height} photo {photo.photo.name}",
            )
        return corners
    x_min, y_min, x_max, y_max = photo.region_px
    if x_min < -0.5 or y_min < -0.5 or x_max > width - 0.5 or y_max > height - 0.5:
        raise FieldError(
            ("region_px",),
            f"region {list(photo.region_px)} reaches outside the {width}x{height} photo {photo.photo.name}",
        )
    corners = detect_quad(image, (x_min, y_min, x_max, y_max))
    if corners is None:
        raise FieldError(("region_px",), f"no convex four-cornered outline found in region {list(photo.region_px)}")
    return corners


def detect_quad(image: np.ndarray, region_px: tuple[float, float, float, float]) -> np.ndarray | None:
    """The largest convex quadrilateral outline in the region, its sides refined by fitting
    lines to the edge pixels along them; None when there is none."""
    x0, y0 = max(int(np.floor(region_px[0])), 0), max(int(np.floor(region_px[1])), 0)
    x1, y1 = int(np.ceil(region_px[2])) + 1, int(np.ceil(region_px[3])) + 1
    crop = cv2.GaussianBlur(image[y0:y1, x0:x1], (5, 5), 0)
    # Edges in any colour channel: a red face on a grey wall can have no edge in grey levels.
    edges = np.bitwise_or.reduce([cv2.Canny(crop[..., c], 30, 90) for c in range(3)])
    closed = cv2.dilate(edges, np.ones((3, 3), np.uint8))
    contours, _ = cv2.findContours(closed, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    best, best_area = None, _MIN_DETECTED_FRACTION * edges.size
    for contour in contours:
        hull = cv2.convexHull(contour)
        quad = _four_corners(hull)
        if quad is not None and cv2.contourArea(quad) > best_area:
            best, best_area = quad.reshape(4, 2).astype(np.float64), cv2.contourArea(quad)
    if best is None:
        return None
    corners = _refine_sides(_clockwise_from_top_left(best), edges)
    if quad_problem(corners) is not None:
        return None
    return corners + (x0, y0)


def _four_corners(hull: np.ndarray) -> np.ndarray | None:
    """The hull simplified to four corners with the least tolerance that does it, if any."""
    perimeter = cv2.arcLength(hull, True)
    for fraction in (0.01, 0.02, 0.03, 0.05, 0.08):
        quad = cv2.approxPolyDP(hull, fraction * perimeter, True)
        if len(quad) == 4 and cv2.isContourConvex(quad):
            return quad
        if len(quad) < 4:
            return None
    return None


def _clockwise_from_top_left(corners: np.ndarray) -> np.ndarray:
    centre = corners.mean(axis=0)
    # With y down, increasing atan2 runs clockwise on screen.
    order = np.argsort(np.arctan2(corners[:, 1] - centre[1], corners[:, 0] - centre[0]))
    corners = corners[order]
    return np.roll(corners, -int(np.argmin(corners.sum(axis=1))), axis=0)


def _refine_sides(corners: np.ndarray, edges: np.ndarray, band_px: float = 4.0) -> np.ndarray:
    """Corners as intersections of lines fitted to the edge pixels within `band_px` of each side."""
    ys, xs = np.nonzero(edges)
    points = np.column_stack([xs, ys]).astype(np.float64)
    lines = []
    for a, b in zip(corners, np.roll(corners, -1, axis=0)):
        direction = (b - a) / np.linalg.norm(b - a)
        normal = np.array([-direction[1], direction[0]])
        along = (points - a) @ direction
        near = (np.abs((points - a) @ normal) < band_px) & (along > 0.1 * np.linalg.norm(b - a))
        near &= along < 0.9 * np.linalg.norm(b - a)
        if near.sum() < 10:
            return corners
        # Canny marks the pixel on the brighter or darker side of a step; half a pixel either way.
        vx, vy, x, y = cv2.fitLine(points[near].astype(np.float32), cv2.DIST_HUBER, 0, 0.01, 0.01).ravel()
        lines.append((np.array([x, y], dtype=np.float64), np.array([vx, vy], dtype=np.float64)))
    refined = []
    for k in range(4):
        (p1, d1), (p2, d2) = lines[k - 1], lines[k]
        matrix = np.column_stack([d1, -d2])
        if abs(np.linalg.det(matrix)) < 1e-6:
            return corners
        s, _ = np.linalg.solve(matrix, p2 - p1)
        refined.append(p1 + s * d1)
    return np.asarray(refined)


def _density_px_per_m(corners: np.ndarray, width_m: float, height_m: float) -> float:
    """The photo's pixels per metre on the face, along its better-resolved direction."""
    edge = np.linalg.norm(np.roll(corners, -1, axis=0) - corners, axis=1)  # top, right, bottom, left
    return max((edge[0] + edge[2]) / 2 / width_m, (edge[1] + edge[3]) / 2 / height_m)


def texture_size_px(
    corners: np.ndarray,
    width_m: float,
    height_m: float,
    options: FaceTextureOptions,
    *,
    source_width_m: float | None = None,
) -> tuple[int, int]:
    """(width, height) in pixels of a texture `width_m` x `height_m` (the photographed part
    `source_width_m` wide, if only a part of the width is photographed)."""
    density = min(_density_px_per_m(corners, source_width_m or width_m, height_m), options.max_px_per_m)
    density = min(density, options.max_side_px / max(width_m, height_m))
    size = np.maximum(np.round(np.array([width_m, height_m]) * density), options.min_side_px)
    return int(size[0]), int(size[1])


def rectify_planar(image: np.ndarray, corners: np.ndarray, size_px: tuple[int, int]) -> np.ndarray:
    """The quadrilateral `corners` of `image` warped onto a `size_px` (width, height) image."""
    width, height = size_px
    target = np.array([[-0.5, -0.5], [width - 0.5, -0.5], [width - 0.5, height - 0.5], [-0.5, height - 0.5]])
    homography = cv2.getPerspectiveTransform(corners.astype(np.float32), target.astype(np.float32))
    return cv2.warpPerspective(
        image, homography, (width, height), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE
    )


def wrap_u(relative_angle_rad: np.ndarray) -> np.ndarray:
    """Texture u of a direction `relative_angle_rad` from the band's centre: the centre at
    0.5, the seam opposite it."""
    return 0.5 + relative_angle_rad / (2 * np.pi)


def rectify_wrap(
    image: np.ndarray,
    corners: np.ndarray,
    photo: FacePhoto,
    size_px: tuple[int, int],
    fill_bgr: tuple[int, int, int],
) -> np.ndarray:
    """The whole circumference as a `size_px` (width, height) image: the photographed band
    unrolled at its angles (u by `wrap_u`), the rest `fill_bgr`."""
    width, height = size_px
    unit_square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float32)
    square_to_photo = cv2.getPerspectiveTransform(unit_square, corners.astype(np.float32))
    angle = ((np.arange(width) + 0.5) / width - 0.5) * 2 * np.pi
    half = np.radians(photo.wrap_span_deg) / 2
    inside = np.abs(angle) <= half
    if photo.wrap_projection == "side_view":
        across = (np.sin(angle) + np.sin(half)) / (2 * np.sin(half))
    else:
        across = (angle + half) / (2 * half)
    down = (np.arange(height) + 0.5) / height
    grid = np.stack(np.meshgrid(across, down), axis=-1).reshape(-1, 1, 2).astype(np.float32)
    source = cv2.perspectiveTransform(grid, square_to_photo).reshape(height, width, 2)
    texture = cv2.remap(image, source[..., 0], source[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    texture[:, ~inside] = fill_bgr
    return texture


def write_texture(texture: np.ndarray, path: Path, options: FaceTextureOptions) -> Path:
    """Write a BGR texture as JPEG (atomically): photos compress well and stay small."""
    ok, data = cv2.imencode(".jpg", texture, [cv2.IMWRITE_JPEG_QUALITY, options.jpeg_quality])
    if not ok:
        raise InputError(f"{path}: cannot encode the texture")
    write_bytes_atomic(Path(path), data.tobytes())
    return Path(path)
