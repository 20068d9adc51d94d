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


def _ring_model(count: int, width: int, height: int, focal_px: float, distance: float):
    """A sparse-model-shaped object: `count` cameras on a ring `distance` from the origin, looking at it."""
    from homemodel.geometry.camera import Camera
    from photogrammetry.sfm import View

    views = []
    for angle in np.linspace(0, 2 * np.pi, count, endpoint=False):
        centre = distance * np.array([np.cos(angle), np.sin(angle), 0.5])
        z = -centre / np.linalg.norm(centre)
        x = np.cross(z, [0.0, 0.0, 1.0])
        x /= np.linalg.norm(x)
        pose = np.eye(4)
        pose[:3, :3] = np.vstack([x, np.cross(z, x), z])
        pose[:3, 3] = -pose[:3, :3] @ centre
        camera = Camera(width=width, height=height, fx=focal_px, fy=focal_px, cx=width / 2, cy=height / 2)
        views.append(View(name=f"{angle:.3f}", image_path=Path("unused.png"), camera=camera, camera_from_world=pose))
    return SimpleNamespace(views=views)


def test_depth_image_side_comes_from_the_photos() -> None:
    """The depth maps' side: the points they make (every 2nd pixel) a fusion voxel apart at the
    object (a 1600 px photo with a 1400 px focal, voxel 1/500 of the distance: 1,143 px);
    never above the photos' own size (Kermit's 640 px); all views within the work budget (66
    photos: 729 px, their sides cubed adding up to 50 views' of 800 px); a given size wins."""
    from photogrammetry.stereo import DenseOptions, depth_image_side_px

    options = DenseOptions()
    distance = float(np.linalg.norm([1.0, 0.0, 0.5]))

    def side(count: int, width: int, focal_px: float, **fields) -> int:
        model = _ring_model(count, width, width * 3 // 4, focal_px, 1.0)
        return depth_image_side_px(model, DenseOptions(**fields), focus=np.zeros(3), voxel=0.002 * distance)

    assert abs(side(11, 1600, 1400.0) - 2 * 1600 / (0.002 * 1400)) <= 1
    assert side(11, 640, 700.0) == 640
    assert abs(side(66, 1600, 1400.0) - (options.max_work_px3 / 66) ** (1 / 3)) <= 1
    assert side(66, 1600, 1400.0, max_image_size_px=700) == 700
