"""Undistortion at the size the later stages use: a large photo is decoded at a reduced size by
libjpeg and written at 1600 px, with the same pixels as the full-size undistortion shrunk."""

from __future__ import annotations

import time
from pathlib import Path
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from photogrammetry.undistortion import undistort_photos

BUDDHA = Path(__file__).resolve().parents[2] / "shared" / "data" / "photogrammetry" / "buddha" / "images"


def _one_photo_model(path: Path, focal_px: float, k: float):
    """A reconstruction-shaped object holding one real pycolmap camera (SIMPLE_RADIAL) and one image."""
    import pycolmap

    height, width = cv2.imread(str(path)).shape[:2]
    camera = pycolmap.Camera(model="SIMPLE_RADIAL", width=width, height=height,
                             params=[focal_px, width / 2, height / 2, k])  # fmt: skip
    image = SimpleNamespace(name=path.name, camera_id=1, camera=camera)
    return SimpleNamespace(cameras={1: camera}, images={1: image})


@pytest.mark.shared_data
def test_undistortion_capped_at_1600_px_matches_the_full_size_one_shrunk_and_is_faster(tmp_path: Path) -> None:
    """A Buddha photo upsampled to 3200 px (decoded at half size; the full-size path is the
    test's cost, so not 4272 px): written at 1600 px, the view's camera is the full one
    scaled, its pixels are the full-size undistortion's shrunk (mean difference under 2 grey
    levels of 255), and it takes under half the time."""
    photo = cv2.imread(str(BUDDHA / "00040.jpg"))
    big = cv2.resize(photo, (3200, round(photo.shape[0] * 3200 / photo.shape[1])), interpolation=cv2.INTER_CUBIC)
    cv2.imwrite(str(tmp_path / "big.jpg"), big, [cv2.IMWRITE_JPEG_QUALITY, 92])
    model = _one_photo_model(tmp_path / "big.jpg", focal_px=1088.2 * 2, k=-0.03)
    times, written = {}, {}
    for name, cap in (("full", None), ("capped", 1600)):
        start = time.perf_counter()
        written[name] = undistort_photos(model, tmp_path, tmp_path / name, workers=1, max_side_px=cap)["big.jpg"]
        times[name] = time.perf_counter() - start
    (full_path, full_camera), (capped_path, capped_camera) = written["full"], written["capped"]
    assert max(capped_camera.width, capped_camera.height) == 1600
    factor = capped_camera.width / full_camera.width
    assert abs(capped_camera.fx - full_camera.fx * factor) < 1e-6 * full_camera.fx
    capped = cv2.imread(str(capped_path)).astype(float)
    shrunk = cv2.resize(cv2.imread(str(full_path)), (capped_camera.width, capped_camera.height),
                        interpolation=cv2.INTER_AREA).astype(float)  # fmt: skip
    inner = (slice(20, -20), slice(20, -20))  # the black border outside the photo may differ by a pixel
    assert np.mean(np.abs(capped[inner] - shrunk[inner])) < 2.0
    assert times["capped"] < 0.5 * times["full"], times
    # A PNG (which OpenCV shrinks after decoding, rounding sizes down) is read whole: same view.
    cv2.imwrite(str(tmp_path / "big.png"), big)
    png_model = _one_photo_model(tmp_path / "big.png", focal_px=1088.2 * 2, k=-0.03)
    png_path, png_camera = undistort_photos(png_model, tmp_path, tmp_path / "png", workers=1, max_side_px=1600)["big.png"]
    assert (png_camera.width, png_camera.fx) == (capped_camera.width, capped_camera.fx)
    assert np.mean(np.abs(cv2.imread(str(png_path)).astype(float)[inner] - shrunk[inner])) < 2.0
