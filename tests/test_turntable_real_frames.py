"""Flying pixels at depth edges (turntable.real_frames.drop_flying_pixels): mixed pixels go
and surfaces stay, at a 640x480 depth camera's focal length and a 256x192 one's, where a
pixel's footprint is four times as wide."""

from __future__ import annotations

import numpy as np
import pytest

from turntable.real_frames import drop_flying_pixels, focal_px_of_rays


def test_flying_pixels_go_and_slanted_surfaces_stay() -> None:
    depth = np.full((40, 60), 1.2, np.float32)
    depth[:, :30] = 0.6  # a foreground edge at column 30 ...
    depth[:, 30] = 0.9  # ... with a column of flying pixels between the two surfaces
    cleaned, dropped = drop_flying_pixels(depth, 600.0)
    assert dropped == 40 and np.all(np.isnan(cleaned[:, 30])) and np.isfinite(cleaned[:, :30]).all()
    slope = 0.6 + np.arange(60, dtype=np.float32)[None, :].repeat(40, 0) * 0.004  # 76 degrees from the view
    assert drop_flying_pixels(slope, 600.0)[1] == 0


@pytest.mark.parametrize("focal_px", [577.0, 152.0])
def test_pixels_mixed_across_a_step_go_and_grazing_or_curving_surfaces_stay(focal_px: float) -> None:
    """A step of 14 pixel footprints at 0.6 m (15 mm at f 577 px, 55 mm at f 152 px), its edge
    pixels mixed 35-65 % of the way: all go, with holes beside them too (a hole is looked past;
    before, none of those went). At 577 px each differs from either neighbour by less than 2 %
    of the depth, which the rule by depth alone let through (0 of 40). Planes 70 to 80 degrees
    from the view, a cylinder's silhouette curving away (r 40 mm at 0.5 m, 40 sub-pixel phases)
    and a wall with the sensor's noise, whole or a quarter holes, keep their pixels: at 152 px
    the rule by depth alone dropped the 76-degree plane whole and 12 of the silhouette's pixels."""
    rng = np.random.default_rng(0)
    z = 0.6
    footprint = z / focal_px
    depth = np.full((40, 60), z + 14 * footprint, np.float32)
    depth[:, :30] = z
    depth[:, 30] = z + 14 * footprint * rng.uniform(0.35, 0.65, 40)
    cleaned, dropped = drop_flying_pixels(depth, focal_px)
    assert dropped == 40 and np.isnan(cleaned[:, 30]).all()
    holed = depth.copy()  # a dark surface's holes beside the mixed pixels, on one side or the other
    holed[::2, 29], holed[1::2, 31] = np.nan, np.nan
    assert np.isnan(drop_flying_pixels(holed, focal_px)[0][:, 30]).all()
    for degrees in (70.0, 76.0, 80.0):
        plane = z + np.arange(60)[None, :].repeat(40, 0) * footprint * np.tan(np.radians(degrees))
        assert drop_flying_pixels(plane.astype(np.float32), focal_px)[1] == 0, degrees
    radius = 0.04
    x = (np.arange(200)[None, :] - 100 + np.linspace(0, 1, 40, endpoint=False)[:, None]) * 0.5 / focal_px
    cylinder = np.where(np.abs(x) < radius, 0.54 - np.sqrt(np.clip(radius**2 - x**2, 0, None)), 0.6)
    assert drop_flying_pixels(cylinder.astype(np.float32), focal_px)[1] == 0
    wall = (z + rng.normal(0, 0.0013, (200, 200))).astype(np.float32)  # sigma(0.6 m) of a structured-light sensor
    assert drop_flying_pixels(wall, focal_px)[1] <= 0.001 * wall.size
    wall[rng.random(wall.shape) < 0.25] = np.nan  # and with a quarter of its pixels reading none
    assert drop_flying_pixels(wall, focal_px)[1] <= 0.001 * wall.size


def test_focal_length_of_the_rays_is_the_cameras() -> None:
    from homemodel.geometry.camera import Camera

    camera = Camera(width=256, height=192, fx=152.5, fy=152.5, cx=127.5, cy=95.5)
    assert focal_px_of_rays(camera.pixel_rays(), camera.width) == pytest.approx(152.5, rel=1e-9)
