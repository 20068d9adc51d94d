"""The ray-cast renderer of the synthetic photo set (photogrammetry/ray_rendering.py) against
values worked out by hand: Lambert's law under sky and sun, texture lookup and orientation,
the sun's shadow where geometry puts it, and anti-aliased edges."""

from __future__ import annotations

import numpy as np
import pytest

from homemodel.core.transforms import world_from_camera_looking_at
from homemodel.geometry.camera import Camera
from photogrammetry.ray_rendering import Lighting, RayRenderer, TexturedPart, linear_to_srgb8, srgb_to_linear

SKY, SUN = 0.3, 1.5  # linear sky radiance, sun irradiance (W/m^2)
# A 2 x 2 texture: rows from the top, so v = 1 is the top row (Blender's UV convention).
TEXTURE = np.array([[[200, 40, 40], [40, 200, 40]], [[40, 40, 200], [120, 120, 120]]], np.uint8)
CAMERA = Camera(fx=80.0, fy=80.0, cx=39.5, cy=39.5, width=80, height=80)


def _floor(half: float = 0.5, closest_texel: bool = True) -> TexturedPart:
    """A square at z = 0, x and y in [-half, half], the texture's u along x and v along y."""
    corners = np.array([[-half, -half, 0.0], [half, -half, 0.0], [half, half, 0.0], [-half, half, 0.0]])
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    return TexturedPart(vertices=corners, faces=np.array([[0, 1, 2, 3]]), uv=uv, texture_srgb=TEXTURE,
                        closest_texel=closest_texel)  # fmt: skip


def _box(lo: np.ndarray, hi: np.ndarray) -> TexturedPart:
    import trimesh

    box = trimesh.creation.box(bounds=[lo, hi])
    grey = np.full((1, 1, 3), 128, np.uint8)
    return TexturedPart(vertices=box.vertices, faces=box.faces, uv=np.zeros((len(box.vertices), 2)), texture_srgb=grey)


def _looking_down(height: float = 2.0) -> np.ndarray:
    """camera_from_world from above the origin, image x along world x, image y along -y."""
    world_from_camera = world_from_camera_looking_at(np.array([0.0, 0.0, height]), np.zeros(3), up=np.array([0.0, 1.0, 0.0]))
    return np.linalg.inv(world_from_camera)


def _pixel(world_xy: tuple[float, float], camera_from_world: np.ndarray) -> tuple[int, int]:
    point = camera_from_world @ np.array([*world_xy, 0.0, 1.0])
    u, v = CAMERA.project(point[None, :3])[0]
    return int(round(v)), int(round(u))


def test_srgb_round_trip_is_exact_on_every_grey_level() -> None:
    levels = np.arange(256, dtype=np.uint8)
    assert np.array_equal(linear_to_srgb8(srgb_to_linear(levels)), levels)


def test_lit_floor_has_lamberts_values_and_the_texture_upright() -> None:
    """Sun from straight above: each quarter of the floor is albedo x (sky + sun / pi); the sky
    is the background; the texture's top-left texel lies at -x, +y."""
    lighting = Lighting(sky_radiance=SKY, sun_irradiance_w_m2=SUN, to_sun=np.array([0.0, 0.0, 1.0]))
    pose = _looking_down()
    image = RayRenderer([_floor()], lighting).render(CAMERA, pose)
    albedo = srgb_to_linear(TEXTURE)
    quarters = {(-0.25, 0.25): albedo[0, 0], (0.25, 0.25): albedo[0, 1], (-0.25, -0.25): albedo[1, 0],
                (0.25, -0.25): albedo[1, 1]}  # fmt: skip
    for xy, colour in quarters.items():
        expected = linear_to_srgb8(colour * (SKY + SUN / np.pi))
        assert np.abs(image[_pixel(xy, pose)].astype(int) - expected).max() <= 1, (xy, image[_pixel(xy, pose)], expected)
    assert np.all(image[0, 0] == linear_to_srgb8(np.array([SKY]))[0])  # beyond the floor: the sky


def test_a_box_casts_its_shadow_where_the_sun_puts_it() -> None:
    """Sun 45 degrees up from +x: a box 0.2 m high over x in [0, 0.1] shades the floor from
    x = -0.2 to 0 (beside it, towards -x), lit by the sky alone; the floor at +x is in sunlight
    at cos 45 degrees."""
    to_sun = np.array([1.0, 0.0, 1.0]) / np.sqrt(2)
    lighting = Lighting(sky_radiance=SKY, sun_irradiance_w_m2=SUN, to_sun=to_sun)
    pose = _looking_down(3.0)
    box = _box(np.array([0.0, -0.3, 0.0]), np.array([0.1, -0.2, 0.2]))
    image = RayRenderer([_floor(), box], lighting).render(CAMERA, pose)
    albedo = srgb_to_linear(TEXTURE)[1, 0]  # the bottom-left quarter: x < 0, y < 0
    shadowed = image[_pixel((-0.1, -0.25), pose)].astype(int)
    assert np.abs(shadowed - linear_to_srgb8(albedo * SKY)).max() <= 1
    sunlit = image[_pixel((-0.1, -0.4), pose)].astype(int)  # beside the shadow, same quarter
    assert np.abs(sunlit - linear_to_srgb8(albedo * (SKY + SUN / np.pi * to_sun[2]))).max() <= 1


def test_edges_are_anti_aliased_and_inner_pixels_are_not_blurred() -> None:
    """A floor edge between pixel centres: the pixels it crosses take a value between the sky and
    the floor; one pixel inside keeps the floor's own value."""
    lighting = Lighting(sky_radiance=SKY, sun_irradiance_w_m2=SUN, to_sun=np.array([0.0, 0.0, 1.0]))
    pose = _looking_down()
    image = RayRenderer([_floor(half=0.41)], lighting).render(CAMERA, pose).astype(int)
    row = CAMERA.height // 2 - 10
    green = image[row, :, 1]  # across the top-right quarter (green texel) and its right edge
    floor_value = linear_to_srgb8(srgb_to_linear(TEXTURE)[0, 1] * (SKY + SUN / np.pi))[1]
    sky_value = linear_to_srgb8(np.array([SKY]))[0]
    edge = np.flatnonzero((green != floor_value) & (green != sky_value))
    edge = edge[edge > CAMERA.width // 2]
    assert len(edge) == 1, green
    assert min(floor_value, sky_value) < green[edge[0]] < max(floor_value, sky_value)
    assert green[edge[0] - 1] == floor_value and green[edge[0] + 1] == sky_value


def test_bad_scenes_are_refused() -> None:
    lighting = Lighting(sky_radiance=SKY, sun_irradiance_w_m2=SUN, to_sun=np.array([0.0, 0.0, 1.0]))
    with pytest.raises(ValueError, match="at least one part"):
        RayRenderer([], lighting)
    bad = _floor()
    bad.faces = np.array([[0, 1]])
    with pytest.raises(ValueError, match="expected"):
        RayRenderer([bad], lighting)
