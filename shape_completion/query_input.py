"""Read and check a query: a 16-bit depth PNG (or float EXR), its camera.yaml, and an optional mask."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from homemodel.core.errors import InputError
from homemodel.core.images import read_image
from homemodel.geometry.camera import Camera, load_camera_and_pose
from homemodel.geometry.depth_io import read_depth_m
from shape_completion.features import clean_object_depth
from shape_completion.support import SupportPlane, find_support

MIN_QUERY_PIXELS = 30  # fewer valid pixels on the object: no query


def undistorted_depth(depth_m: np.ndarray, camera: Camera) -> np.ndarray:
    """The depth image resampled (nearest pixel, so depths are never mixed) to the distortion-free
    pinhole camera with the same intrinsics."""
    import cv2

    map_x, map_y = cv2.initUndistortRectifyMap(
        camera.matrix, camera.distortion_coefficients, None, camera.matrix, (camera.width, camera.height), cv2.CV_32FC1
    )
    return cv2.remap(depth_m, map_x, map_y, cv2.INTER_NEAREST, borderValue=float("nan"))


def read_mask(path: Path) -> np.ndarray:
    """An 8- or 16-bit single-channel image; non-zero pixels are the object."""
    import cv2

    image = read_image(path, cv2.IMREAD_UNCHANGED)
    if image.ndim != 2:
        raise InputError(f"{path}: a mask must be single-channel, got shape {image.shape}")
    return image > 0


@dataclass(kw_only=True)
class Query:
    """A query read from its files: the object-only depth (metres, NaN elsewhere) and the
    distortion-free camera it is seen with, the camera's pose in the map when camera.yaml gives
    one, and the support plane seen under the object, if any."""

    depth_m: np.ndarray
    camera: Camera
    map_from_camera: np.ndarray | None
    support: SupportPlane | None


def load_query(depth_path: Path, camera_path: Path, mask_path: Path | None = None, *, seed: int = 0) -> Query:
    """The query of a depth image, its camera.yaml and an optional mask; every problem is an
    InputError naming the file. Without a mask the object is the blob standing on the support
    plane when one is seen, else every measured pixel."""
    camera, map_from_camera = load_camera_and_pose(Path(camera_path))
    depth = read_depth_m(Path(depth_path), depth_scale_m=camera.depth_scale_m)
    if depth.shape != (camera.height, camera.width):
        raise InputError(
            f"{depth_path}: the image is {depth.shape[1]}x{depth.shape[0]} px but {camera_path} says"
            f" {camera.width}x{camera.height}"
        )
    mask = None
    if mask_path is not None:
        mask = read_mask(Path(mask_path))
        if mask.shape != depth.shape:
            raise InputError(
                f"{mask_path}: the mask is {mask.shape[1]}x{mask.shape[0]} px, the depth image is"
                f" {depth.shape[1]}x{depth.shape[0]}"
            )
    if camera.has_distortion:
        depth = undistorted_depth(depth, camera)
        if mask is not None:
            mask = undistorted_depth(mask.astype(np.float32), camera) > 0.5
    camera = camera.without_distortion()
    support, on_support = find_support(depth, camera, mask, np.random.default_rng(seed))
    object_pixels = mask if mask is not None else on_support
    if object_pixels is not None:
        depth = np.where(object_pixels, depth, np.nan).astype(np.float32)
    try:
        depth = check_query(depth, camera, None)
    except InputError as exc:
        raise InputError(f"{depth_path}: {exc}") from None
    return Query(depth_m=depth, camera=camera, map_from_camera=map_from_camera, support=support)


def check_query(depth_m: np.ndarray, camera: Camera, mask: np.ndarray | None) -> np.ndarray:
    """The object-only depth (NaN elsewhere) of a query, or an InputError saying what is wrong."""
    depth = np.asarray(depth_m, dtype=np.float32)
    if depth.shape != (camera.height, camera.width):
        raise InputError(
            f"depth image is {depth.shape[1]}x{depth.shape[0]} px but the camera is {camera.width}x{camera.height} px"
        )
    depth = np.where(np.isfinite(depth) & (depth > 0), depth, np.nan).astype(np.float32)
    if mask is not None:
        if mask.shape != depth.shape:
            raise InputError(
                f"mask is {mask.shape[1]}x{mask.shape[0]} px but the depth image is {camera.width}x{camera.height}"
            )
        depth[~mask.astype(bool)] = np.nan
    count = int(np.isfinite(depth).sum())
    if count == 0:
        raise InputError("depth image has no valid depth on the object (empty, all zero or all NaN)")
    if count < MIN_QUERY_PIXELS:
        raise InputError(f"depth image has only {count} valid pixels on the object (need {MIN_QUERY_PIXELS})")
    depth = clean_object_depth(depth)
    rows, cols = np.nonzero(np.isfinite(depth))
    median = float(np.nanmedian(depth))
    across = max(cols.ptp() / camera.fx, rows.ptp() / camera.fy) * median
    if not (0.005 <= across <= 2.0) or median > 20.0:
        raise InputError(
            f"the object would be {across:.3g} m across at {median:.3g} m: the depth image does not match the camera"
            " (check depth_scale_m and the focal lengths)"
        )
    return depth
