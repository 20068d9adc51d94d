"""The completed shape's frame: the support plane found in a rendered depth image of a cup on a
table, and the upright object frame from the camera's pose, from that plane, or neither."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from homemodel.core.transforms import world_from_camera_looking_at
from homemodel.geometry.raycast import RayCaster
from shape_completion.procedural import generate_instances
from shape_completion.queries import FILLER_CAMERA, random_query_pose
from shape_completion.support import find_support
from shape_completion.symmetry import RevolutionAxis
from shape_completion.upright import object_frame


def table_scene(world_from_camera: np.ndarray) -> dict:
    """A generated mug standing at the world origin on a 1.2 m table top (z = 0), seen by
    FILLER_CAMERA at `world_from_camera`: the whole depth image, the mug's own pixels, the mug."""
    mug = generate_instances("cup", 3, seed=5)[2]
    table = trimesh.creation.box(extents=(1.2, 1.2, 0.03)).apply_translation((0.1, 0.2, -0.015))
    camera_from_world = np.linalg.inv(world_from_camera)
    depth = RayCaster(trimesh.util.concatenate([mug, table])).depth(FILLER_CAMERA, camera_from_world)
    mug_depth = RayCaster(mug).depth(FILLER_CAMERA, camera_from_world)
    on_mug = np.isfinite(mug_depth) & (np.abs(mug_depth - depth) < 1e-4)
    return {"depth": depth, "on_mug": on_mug, "mug": mug, "camera_from_world": camera_from_world}


SIDE_VIEW = world_from_camera_looking_at((0.45, -0.35, 0.4), (0.0, 0.0, 0.05))
TOP_VIEW = world_from_camera_looking_at((0.05, -0.08, 0.6), (0.0, 0.0, 0.0))


@pytest.mark.parametrize("world_from_camera", [SIDE_VIEW, TOP_VIEW], ids=["side", "top"])
@pytest.mark.parametrize("masked", [True, False], ids=["mask", "no mask"])
def test_the_table_is_found_under_the_mug_with_or_without_a_mask(world_from_camera, masked: bool) -> None:
    scene = table_scene(world_from_camera)
    plane, object_pixels = find_support(
        scene["depth"], FILLER_CAMERA, scene["on_mug"] if masked else None, np.random.default_rng(0)
    )
    assert plane is not None
    true_up = scene["camera_from_world"][:3, 2]  # the world's z in the camera frame
    assert np.degrees(np.arccos(min(1.0, plane.normal @ true_up))) < 0.5
    # The table top passes through the world origin: its height there is zero.
    assert abs(plane.height_m(scene["camera_from_world"][:3, 3][None])[0]) < 0.002
    truth = scene["on_mug"]
    overlap = (object_pixels & truth).sum() / (object_pixels | truth).sum()
    assert overlap > (0.999 if masked else 0.95), overlap


def test_no_support_is_found_in_object_only_images_or_inside_a_bowl() -> None:
    rng = np.random.default_rng(0)
    scene = table_scene(SIDE_VIEW)
    object_only = np.where(scene["on_mug"], scene["depth"], np.nan)
    assert find_support(object_only, FILLER_CAMERA, None, rng) == (None, None)
    # Generated objects alone from random views: flat bottoms, bowls and spoons are no table.
    for class_name in ("bottle", "bowl", "cup", "glass", "spoon"):
        for mesh in generate_instances(class_name, 3, seed=3):
            for _ in range(2):
                depth = RayCaster(mesh).depth(FILLER_CAMERA, random_query_pose(mesh, rng))
                assert find_support(depth, FILLER_CAMERA, None, rng) == (None, None), class_name
    # Looking down into a wide bowl: its flat inner bottom is a plane, but the walls surround it.
    bowl = trimesh.creation.annulus(r_min=0.07, r_max=0.08, height=0.05).apply_translation((0, 0, 0.025))
    bowl = trimesh.util.concatenate([bowl, trimesh.creation.cylinder(radius=0.08, height=0.01)])
    camera_from_world = np.linalg.inv(world_from_camera_looking_at((0.0, -0.05, 0.35), (0.0, 0.0, 0.0)))
    depth = RayCaster(bowl).depth(FILLER_CAMERA, camera_from_world)
    assert find_support(depth, FILLER_CAMERA, None, rng) == (None, None)


def _in_frame(scene: dict, frame) -> trimesh.Trimesh:
    mug_camera = scene["mug"].copy().apply_transform(scene["camera_from_world"])
    return mug_camera.apply_transform(np.linalg.inv(frame.camera_from_object))


def test_with_a_camera_pose_the_mug_stands_on_z0_with_the_maps_axes() -> None:
    scene = table_scene(SIDE_VIEW)
    mug_camera = scene["mug"].copy().apply_transform(scene["camera_from_world"])
    frame = object_frame(mug_camera, map_from_camera=SIDE_VIEW, support=None, axis=None)
    assert frame.up_from == "camera pose"
    # The map's axes: the frame is the world moved, not turned; the mug's foot is at z = 0.
    np.testing.assert_allclose(frame.map_from_object[:3, :3], np.eye(3), atol=1e-9)
    np.testing.assert_allclose(_in_frame(scene, frame).vertices, scene["mug"].vertices - frame.map_from_object[:3, 3],
                               atol=1e-9)  # fmt: skip
    assert abs(_in_frame(scene, frame).bounds[0, 2]) < 1e-9
    # A revolved match's upright axis puts the origin on it (the mug's body axis is the world's z).
    axis_camera = RevolutionAxis(point=np.zeros(3), direction=np.array([0.0, 0.0, 1.0])).transformed(
        scene["camera_from_world"]
    )
    frame = object_frame(mug_camera, map_from_camera=SIDE_VIEW, support=None, axis=axis_camera)
    np.testing.assert_allclose(frame.map_from_object[:3, 3], 0.0, atol=1e-9)


def test_from_the_support_plane_alone_the_mug_stands_upright_on_it() -> None:
    scene = table_scene(SIDE_VIEW)
    plane, _ = find_support(scene["depth"], FILLER_CAMERA, scene["on_mug"], np.random.default_rng(0))
    mug_camera = scene["mug"].copy().apply_transform(scene["camera_from_world"])
    frame = object_frame(mug_camera, map_from_camera=None, support=plane, axis=None)
    assert frame.up_from == "support plane" and "support plane" in frame.description
    upright = _in_frame(scene, frame)
    # Same shape as the mug in its own frame, turned about z only: height and foot match.
    assert abs(upright.bounds[0, 2]) < 0.002
    assert abs(upright.extents[2] - scene["mug"].extents[2]) < 0.001
    object_from_world = np.linalg.inv(frame.camera_from_object) @ scene["camera_from_world"]
    assert object_from_world[2, 2] > np.cos(np.radians(0.5))
    # y points away from the camera: the camera is on the -y side.
    assert (np.linalg.inv(frame.camera_from_object) @ [0, 0, 0, 1])[1] < 0


def test_with_neither_the_mesh_stays_in_the_camera_frame_and_the_frame_says_so() -> None:
    scene = table_scene(SIDE_VIEW)
    mug_camera = scene["mug"].copy().apply_transform(scene["camera_from_world"])
    frame = object_frame(mug_camera, map_from_camera=None, support=None, axis=None)
    assert frame.up_from is None and frame.map_from_object is None
    np.testing.assert_array_equal(frame.camera_from_object, np.eye(4))
    assert frame.description.startswith("query camera, OpenCV") and "up is unknown" in frame.description
