"""Registered photos to pinhole views: each photo read once, remapped, written once.

COLMAP's own undistorter wrote every photo back with its default (slow) compression and took
tens of seconds for 50 photos. Here the lookup from pinhole pixels to the photo's distorted
pixels comes from COLMAP's camera model (so every model COLMAP fits is handled), the warp is
OpenCV's remap, the write an uncompressed BMP, and the photos are spread over the cores. The
views are scratch files, read again by the dense, marker and texturing stages: a 1600 x 1200
view cost 268 CPU-ms to write and 88 to read as a PNG (zlib level 1), 4 and 3.5 as a BMP.
Nothing downstream looks at more than `max_side_px` pixels (texturing samples 1600 px, dense
matching fewer): the views are written at that size, a JPEG decoded at a half, quarter or
eighth of its size by libjpeg's own scaling where that still holds the view's pixels (a
4272 px photo cost 0.7 s to read, remap and write at full size).
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from homemodel.core.errors import ModelError
from homemodel.core.images import read_image
from homemodel.geometry.camera import Camera

VIEW_SUFFIX = ".bmp"


def pinhole_camera(camera) -> Camera:
    """The pinhole camera COLMAP's undistorter gives a (distorted) pycolmap camera, in
    OpenCV's pixel convention (COLMAP puts pixel centres at +0.5, OpenCV at whole numbers)."""
    import pycolmap

    pinhole = pycolmap.undistort_camera(pycolmap.UndistortCameraOptions(), camera)
    matrix = pinhole.calibration_matrix().copy()
    matrix[:2, 2] -= 0.5
    return Camera.from_matrix(matrix, width=int(pinhole.width), height=int(pinhole.height))


def _lookup(camera, pinhole: Camera) -> tuple[np.ndarray, np.ndarray]:
    """For every pinhole pixel, where it lies in the distorted photo (float32 maps for remap)."""
    rays = pinhole.pixel_rays()
    pixels = camera.img_from_cam(rays, check_cheirality=False) - 0.5  # to OpenCV's convention
    return (
        pixels[:, 0].reshape(pinhole.height, pinhole.width).astype(np.float32),
        pixels[:, 1].reshape(pinhole.height, pinhole.width).astype(np.float32),
    )


REDUCED_READS = {2: "IMREAD_REDUCED_COLOR_2", 4: "IMREAD_REDUCED_COLOR_4", 8: "IMREAD_REDUCED_COLOR_8"}


def _reduction(photo_side_px: int, view_side_px: int) -> int:
    """The largest decoding reduction (1, 2, 4, 8) that keeps at least the view's pixels."""
    return max((r for r in (1, 2, 4, 8) if photo_side_px / r >= view_side_px), default=1)


def undistort_photos(
    reconstruction, image_dir: Path, out_dir: Path, *, workers: int, max_side_px: int | None = None
) -> dict[str, tuple[Path, Camera]]:
    """Write every registered photo of `reconstruction` undistorted into `out_dir`, its longer
    side at most `max_side_px` (None: the photo's size); by image name, the written file and
    its pinhole camera."""
    import cv2

    out_dir.mkdir(parents=True, exist_ok=True)
    lookups = {}
    for camera_id, camera in reconstruction.cameras.items():
        pinhole = pinhole_camera(camera)
        longest = max(pinhole.width, pinhole.height)
        if max_side_px is not None and longest > max_side_px:
            pinhole = pinhole.scaled(max_side_px / longest)
        # libjpeg's scaling rounds sizes up; other formats are shrunk after decoding, rounding
        # down: only JPEG photos are read reduced.
        jpeg = all(Path(im.name).suffix.lower() in (".jpg", ".jpeg") for im in reconstruction.images.values()
                   if im.camera_id == camera_id)  # fmt: skip
        reduction = _reduction(max(camera.width, camera.height), max(pinhole.width, pinhole.height)) if jpeg else 1
        map_x, map_y = _lookup(camera, pinhole)
        # Full-size pixel x is (x + 0.5) / r - 0.5 in the photo decoded at 1/r.
        lookups[camera_id] = (pinhole, reduction, (map_x + 0.5) / reduction - 0.5, (map_y + 0.5) / reduction - 0.5)

    # Plain values for the worker threads: pycolmap's objects stay on this thread.
    jobs = [(im.name, im.camera_id, (im.camera.height, im.camera.width)) for im in reconstruction.images.values()]

    def one(job: tuple[str, int, tuple[int, int]]) -> tuple[str, tuple[Path, Camera]]:
        name, camera_id, size = job
        pinhole, reduction, map_x, map_y = lookups[camera_id]
        flags = getattr(cv2, REDUCED_READS[reduction]) if reduction > 1 else cv2.IMREAD_COLOR
        photo = read_image(image_dir / name, flags)
        if photo.shape[:2] != tuple(-(-side // reduction) for side in size):
            raise ModelError(f"{image_dir / name}: its size changed during the reconstruction")
        warped = cv2.remap(photo, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)
        path = out_dir / (Path(name).stem + VIEW_SUFFIX)
        if not cv2.imwrite(str(path), warped):
            raise ModelError(f"{path}: cannot write the undistorted photo")
        return name, (path, pinhole)

    with ThreadPoolExecutor(max_workers=workers) as pool:  # OpenCV's decode, remap and encode release the GIL
        return dict(pool.map(one, jobs))
