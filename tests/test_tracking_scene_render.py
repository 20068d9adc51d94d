"""`Renderer.render` gives its last rendering again when asked again: never a stale one; `depth_at` gives
the depth image's numbers at the pixels asked for."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from homemodel.core.transforms import world_from_camera_looking_along
from homemodel.geometry.camera import Camera
from tracking.scene import HomeScene, Renderer

CAMERA = Camera(width=160, height=120, fx=140.0, fy=140.0, cx=79.5, cy=59.5)


def test_a_rendering_asked_again_is_the_same_and_a_pose_changed_in_place_is_rendered_anew(kitchen_map: Path) -> None:
    scene = HomeScene.load(kitchen_map, structure=False)
    renderer = Renderer(scene.parts)
    only = scene.part_indices("cupboard_1")
    # The cupboard in the middle of the image, from 1.6 m.
    centre = scene.map_from_objects()["cupboard_1"][:3, 3] + (0.0, 0.0, 0.4)
    map_from_camera = world_from_camera_looking_along(centre + (1.0, -1.25, 0.3), (-1.0, 1.25, -0.3))
    map_from_parts = scene.pose({"cupboard_1": {"door_1_hinge": 0.3}})
    first = renderer.render(map_from_parts, CAMERA, map_from_camera, only=only)
    assert first.hit.mean() > 0.2
    assert renderer.render(map_from_parts, CAMERA, map_from_camera, only=only) is first
    with pytest.raises(ValueError, match="read-only"):
        first.depth_m[0, 0] = 1.0  # a caller changing it would change what the next one is given
    # The same list and arrays, one pose's numbers changed in place: the door seen elsewhere.
    door = next(i for i in only if scene.parts[i].joint == "door_1_hinge")
    map_from_parts[door][:3, :] = scene.pose({"cupboard_1": {"door_1_hinge": 1.0}})[door][:3, :]
    moved = renderer.render(map_from_parts, CAMERA, map_from_camera, only=only)
    fresh = Renderer(scene.parts).render(map_from_parts, CAMERA, map_from_camera, only=only)
    assert not np.array_equal(moved.depth_m, first.depth_m)
    for name in ("depth_m", "part_index", "normals_camera", "rgb"):
        assert np.array_equal(getattr(moved, name), getattr(fresh, name))
    # Another camera, or other parts, at the same poses are other renderings.
    wider = Camera(**{**CAMERA.model_dump(), "fx": 120.0, "fy": 120.0})
    assert not np.array_equal(renderer.render(map_from_parts, wider, map_from_camera, only=only).depth_m, moved.depth_m)
    body_alone = renderer.render(map_from_parts, CAMERA, map_from_camera, only=only[:1])
    assert not np.array_equal(body_alone.depth_m, moved.depth_m)


def test_the_depth_at_some_pixels_is_the_depth_image_there_bit_for_bit(kitchen_map: Path) -> None:
    """`depth_at` casts only the pixels asked for (the small-object search's points above a
    surface): the same numbers as the whole depth image, with the floor and walls, whose
    boxes reach behind the camera, and on a window cut from the image, as that search asks."""
    scene = HomeScene.load(kitchen_map)
    renderer = Renderer(scene.parts)
    centre = scene.map_from_objects()["cupboard_1"][:3, 3] + (0.0, 0.0, 0.4)
    map_from_camera = world_from_camera_looking_along(centre + (1.0, -1.25, 0.3), (-1.0, 1.25, -0.3))
    map_from_parts = scene.pose({"cupboard_1": {"door_1_hinge": 0.3}})
    window = Camera(**{**CAMERA.model_dump(), "width": 97, "height": 61, "cx": CAMERA.cx - 40, "cy": CAMERA.cy - 30})
    rng = np.random.default_rng(0)
    for camera in (CAMERA, window):
        everything = range(len(scene.parts))
        image = Renderer(scene.parts).depth(map_from_parts, camera, map_from_camera, everything).ravel()
        pixels = rng.choice(len(image), size=len(image) // 7, replace=False)
        depth = renderer.depth_at(map_from_parts, camera, map_from_camera, everything, pixels)
        assert np.array_equal(depth, image[pixels])
        assert np.isfinite(depth).mean() > 0.9  # the floor and walls behind the furniture
        door = [i for i in everything if scene.parts[i].joint == "door_1_hinge"]
        alone = renderer.depth_at(map_from_parts, camera, map_from_camera, door, pixels)
        assert np.array_equal(alone, renderer.depth(map_from_parts, camera, map_from_camera, door).ravel()[pixels])
        assert 0 < np.isfinite(alone).sum() < len(pixels)
