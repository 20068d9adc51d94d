"""Read a query: a 16-bit depth PNG (or float EXR), its camera.yaml, and an optional mask."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from homemodel.core.errors import InputError
from homemodel.core.images import read_image
from homemodel.geometry.camera import Camera, load_camera
from homemodel.geometry.depth_io import read_depth_m
from shape_completion.pipeline import check_query


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


def load_query(depth_path: Path, camera_path: Path, mask_path: Path | None = None) -> tuple[np.ndarray, Camera]:
    """The object-only depth (metres, NaN elsewhere) and the distortion-free camera it is seen
    with; every problem is an InputError naming the file."""
    camera = load_camera(Path(camera_path))
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
        depth[~mask] = np.nan
    if camera.has_distortion:
        depth = undistorted_depth(depth, camera)
    camera = camera.without_distortion()
    try:
        return check_query(depth, camera, None), camera
    except InputError as exc:
        raise InputError(f"{depth_path}: {exc}") from None
