"""The view simulator (`homemodel map simulate-view`) and the scene renderer it shares with
`map observe`, on the demo kitchen: rendered depth against the models' own geometry, the
sensor noise against its published model, joints and moves against the truth it writes, and
bad input as one line with exit code 2."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from homemodel.cli import app
from homemodel.core.errors import InputError
from homemodel.core.transforms import world_from_camera_looking_along
from homemodel.geometry.camera import Camera
from tracking.observation_files import read_observation, save_observation_camera
from tracking.scene import HomeScene, Renderer
from tracking.sensor_noise import SensorNoise, axial_sigma_m, incidence_deg, noisy_depth
from tracking.simulate_view import SmallObjectMove, ViewOptions, ViewSimulator, write_view

CAMERA = Camera(width=160, height=120, fx=140.0, fy=140.0, cx=79.5, cy=59.5)
EXACT = SensorNoise(model="none")


def _part_mask(simulator: ViewSimulator, rendering, name: str) -> np.ndarray:
    names = np.array([p.name for p in simulator.scene.parts] + ["occluder"] * 8)
    return rendering.hit & (names[np.maximum(rendering.part_index, 0)] == name)


def _fridge_door_front(simulator: ViewSimulator) -> tuple[float, np.ndarray]:
    """x of the fridge door's front face in the map (the fridge faces +x) and the door's centre."""
    scene = simulator.scene
    index = scene.parts.index(next(p for p in scene.parts if p.name == "fridge_1/door_0"))
    map_from_door = scene.pose()[index]
    vertices = scene.parts[index].vertices_link @ map_from_door[:3, :3].T + map_from_door[:3, 3]
    return float(vertices[:, 0].max()), vertices.mean(axis=0)


def _run(*args: str):
    return CliRunner().invoke(app, ["map", "simulate-view", *map(str, args)])


def test_depth_png_is_the_door_plane_within_a_millimetre(simulator: ViewSimulator, kitchen_map: Path, tmp_path: Path) -> None:
    front_x, centre = _fridge_door_front(simulator)
    eye = centre.copy()
    eye[0] = front_x + 1.5
    map_from_camera = world_from_camera_looking_along(eye, (-1.0, 0.0, 0.0))
    save_observation_camera(tmp_path / "camera.yaml", CAMERA, map_from_camera)
    result = _run(kitchen_map, "--camera", tmp_path / "camera.yaml", "--noise", "none", "--out", tmp_path / "obs")
    assert result.exit_code == 0, result.output
    observation = read_observation(tmp_path / "obs")
    np.testing.assert_allclose(observation.map_from_camera, map_from_camera, atol=1e-9)
    rendering = simulator.renderer.render(simulator.scene.pose(), CAMERA, map_from_camera)
    door = _part_mask(simulator, rendering, "fridge_1/door_0") & (np.abs(rendering.normals_camera[..., 2]) > 0.999)
    assert door.sum() > 0.3 * door.size  # the door fills the middle of the view
    assert np.abs(observation.depth_m[door] - 1.5).max() <= 0.001
    assert observation.color_rgb is not None and observation.color_rgb.shape == (120, 160, 3)


def test_noise_follows_the_axial_model_at_two_depths(simulator: ViewSimulator) -> None:
    # The north wall (y = 5) seen square-on from 1 m and 3 m, away from the oven and fridge.
    for distance_m in (1.0, 3.0):
        map_from_camera = world_from_camera_looking_along((3.5, 5.0 - distance_m, 1.9), (0.0, 1.0, 0.0))
        options = ViewOptions(noise=SensorNoise(seed=7, dropout_fraction=0.0))
        view = simulator.render(CAMERA, map_from_camera, options)
        wall = _part_mask(simulator, view.rendering, "kitchen__wall_2")
        wall &= np.abs(view.rendering.depth_m - distance_m) < 1e-5
        read = view.observation.depth_m[wall]
        assert wall.sum() > 2000 and (read > 0).all()
        measured = float(np.std(read - distance_m))
        expected = float(np.hypot(axial_sigma_m(distance_m), 0.001 / np.sqrt(12)))  # with 1 mm steps
        assert abs(measured / expected - 1) < 0.2, (distance_m, measured, expected)
        assert np.allclose(read / 0.001, np.round(read / 0.001))


def test_no_reading_at_grazing_incidence_and_random_dropouts(simulator: ViewSimulator) -> None:
    # Looking along the floor: its far part is seen at grazing angles, its near part steeply.
    map_from_camera = world_from_camera_looking_along((3.5, 0.5, 0.6), (0.0, 1.0, -0.35))
    view = simulator.render(CAMERA, map_from_camera, ViewOptions(noise=SensorNoise(dropout_fraction=0.0)))
    rendering = view.rendering
    angle = incidence_deg(rendering.normals_camera, simulator.renderer.pixel_rays(CAMERA))
    floor = _part_mask(simulator, rendering, "floor")
    grazing, steep = floor & (angle > 75.5), floor & (angle < 74.5)
    assert grazing.sum() > 200 and steep.sum() > 200
    assert (view.observation.depth_m[grazing] == 0).all()
    assert (view.observation.depth_m[steep] > 0).all()
    # Dropouts: the fraction asked for, at random, on an otherwise exact image.
    depth = np.full((200, 300), 2.0)
    normals = np.zeros((200, 300, 3))
    normals[..., 2] = -1.0
    rays = np.tile([0.0, 0.0, 1.0], (200 * 300, 1))
    read = noisy_depth(depth, normals, rays, SensorNoise(dropout_fraction=0.05, seed=3))
    assert abs(float((read == 0).mean()) - 0.05) < 0.005
    assert np.array_equal(noisy_depth(depth, normals, rays, EXACT), depth)


def test_a_joint_change_moves_only_that_parts_pixels(simulator: ViewSimulator) -> None:
    map_from_camera = simulator.camera_looking_at("fridge_1", distance_m=2.2, height_m=1.4, bearing_deg=-20)
    closed = simulator.render(CAMERA, map_from_camera, ViewOptions(noise=EXACT)).rendering
    opened = simulator.render(
        CAMERA, map_from_camera, ViewOptions(joint_positions={"fridge_1": {"door_0_hinge": 0.5}}, noise=EXACT)
    ).rendering
    changed = np.abs(opened.depth_m - closed.depth_m) > 1e-6
    door = np.zeros_like(changed)
    for name in ("fridge_1/door_0", "fridge_1/door_0_handle"):
        door |= _part_mask(simulator, closed, name) | _part_mask(simulator, opened, name)
    assert changed.sum() > 500
    assert not (changed & ~door).any()  # nothing but the door (and what it covers or uncovers) moved
    drawer_0 = _part_mask(simulator, closed, "fridge_1/drawer_0")
    assert drawer_0.any() and not changed[drawer_0 & ~door].any()


def test_truth_json_holds_joints_moves_and_visibility(simulator: ViewSimulator, kitchen_map: Path, tmp_path: Path) -> None:
    map_from_camera = simulator.camera_looking_at("table_1", distance_m=1.6, height_m=1.6)
    save_observation_camera(tmp_path / "camera.yaml", CAMERA, map_from_camera)
    out = tmp_path / "obs"
    result = _run(
        kitchen_map, "--camera", tmp_path / "camera.yaml", "--out", out, "--seed", "4",
        "--joint", "fridge_1/door_0_hinge=0.8", "--joint", "oven_1/knob_0_turn=2",
        "--move", "red_cup=cupboard_1:0.0,0.1,0.5", "--move", "blue_cup=0.1,-0.2,1.0",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    truth = json.loads((out / "truth.json").read_text())
    assert truth["joints"]["fridge_1"]["door_0_hinge"] == pytest.approx(0.8)
    assert truth["joints"]["oven_1"]["knob_0_turn"] == pytest.approx(np.pi / 3)  # the knob's state "2"
    assert truth["joints"]["cupboard_1"]["door_0_hinge"] == 0.0  # unchanged joints are there too
    red = truth["objects"]["red_cup"]
    assert (red["parent"], red["relation"]) == ("cupboard_1", "on")
    cupboard = simulator.scene.object("cupboard_1").model.world_mesh()
    assert red["xyz_in_parent"][2] == pytest.approx(cupboard.bounds[1][2], abs=1e-6)  # on its top
    assert red["yaw_in_parent_rad"] == pytest.approx(0.5)
    blue = truth["objects"]["blue_cup"]
    assert blue["parent"] == "table_1" and blue["xyz_in_parent"] == pytest.approx([0.1, -0.2, 0.75])
    table_from_blue = np.linalg.inv(simulator.scene.map_from_objects()["table_1"]) @ np.array(blue["map_from_object"])
    assert table_from_blue[:3, 3] == pytest.approx([0.1, -0.2, 0.75])
    parts = {(p["object"], p["link"]): p for p in truth["parts"]}
    assert parts[("table_1", "body")]["visible_fraction"] > 0.5
    assert parts[("blue_cup", "body")]["pixels"] > 20
    assert all(0 <= p["visible_fraction"] <= 1 and p["pixels"] <= p["pixels_unoccluded"] for p in truth["parts"])
    assert yaml.safe_load((out / "camera.yaml").read_text())["width"] == 160


def test_an_occluder_hides_the_fraction_asked(simulator: ViewSimulator, tmp_path: Path) -> None:
    map_from_camera = simulator.camera_looking_at("oven_1", distance_m=1.8, height_m=1.3)
    bare = simulator.render(CAMERA, map_from_camera, ViewOptions(noise=EXACT))
    hidden = simulator.render(CAMERA, map_from_camera, ViewOptions(noise=EXACT, occlude={"oven_1": 0.3}))
    oven = simulator.scene.part_indices("oven_1")
    before = np.isin(bare.rendering.part_index, oven).sum()
    after = np.isin(hidden.rendering.part_index, oven).sum()
    assert after / before == pytest.approx(0.7, abs=0.05)
    seen = sum(p["pixels"] for p in hidden.observation.truth["parts"] if p["object"] == "oven_1")
    assert seen == after
    write_view(hidden, tmp_path / "obs")
    assert read_observation(tmp_path / "obs").truth["occluders"][0]["size_m"][2] == pytest.approx(0.1)


def test_a_moved_small_object_is_rendered_where_the_truth_says(simulator: ViewSimulator) -> None:
    map_from_camera = simulator.camera_looking_at("table_1", distance_m=1.4, height_m=1.7)
    move = SmallObjectMove(object_id="red_cup", x_m=-0.2, y_m=-0.1, yaw_rad=0.0)
    view = simulator.render(CAMERA, map_from_camera, ViewOptions(moves=[move], noise=EXACT))
    cup = _part_mask(simulator, view.rendering, "red_cup/body")
    v, u = np.nonzero(cup)
    points = CAMERA.rays(np.column_stack([u, v])) * view.rendering.depth_m[cup][:, None]
    points_map = points @ map_from_camera[:3, :3].T + map_from_camera[:3, 3]
    expected = np.array(view.observation.truth["objects"]["red_cup"]["map_from_object"])[:3, 3]
    assert np.linalg.norm(points_map[:, :2].mean(axis=0) - expected[:2]) < 0.05  # the cup's seen side
    assert abs(points_map[:, 2].min() - expected[2]) < 0.03  # it stands on the table


def test_renderer_repose_is_cheap_and_consistent(kitchen_map: Path) -> None:
    scene = HomeScene.load(kitchen_map, structure=False)
    renderer = Renderer(scene.parts)
    map_from_camera = world_from_camera_looking_along((2.0, 3.0, 1.2), (0.0, 1.0, -0.2))
    a = renderer.render(scene.pose(), CAMERA, map_from_camera)
    b = renderer.render(scene.pose({"oven_1": {"door_0_hinge": 1.0}}), CAMERA, map_from_camera)
    c = renderer.render(scene.pose(), CAMERA, map_from_camera)
    assert np.array_equal(a.depth_m, c.depth_m) and not np.array_equal(a.depth_m, b.depth_m)
    assert not any(p.object_id is None for p in scene.parts)  # no floor or walls without structure
    only = renderer.render(scene.pose(), CAMERA, map_from_camera, only=scene.part_indices("oven_1"))
    assert set(np.unique(only.part_index)) <= {-1, *scene.part_indices("oven_1")}


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--joint", "no_such_thing/door=0.3"], "no object 'no_such_thing'"),
        (["--joint", "fridge_1/no_joint=0.3"], "has no joint 'no_joint'"),
        (["--joint", "fridge_1/door_0_hinge=9"], "object 'fridge_1': joint 'door_0_hinge': position 9"),
        (["--joint", "fridge_1/door_0_hinge=wide"], "object 'fridge_1': joint 'door_0_hinge': 'wide' is neither a number"),
        (["--joint", "fridge_1=0.3"], "expected OBJECT/JOINT=VALUE"),
        (["--move", "fridge_1=0,0,0"], "not a small object"),
        (["--move", "red_cup=0,0"], "expected OBJECT=[PARENT:]x,y,yaw"),
        (["--occlude", "fridge_1=2"], "occlude.fridge_1: must lie in"),
    ],
)
def test_bad_options_give_one_line_and_exit_2(kitchen_map: Path, tmp_path: Path, args: list[str], message: str) -> None:
    save_observation_camera(tmp_path / "camera.yaml", CAMERA, world_from_camera_looking_along((2, 2, 1), (0, 1, 0)))
    result = _run(kitchen_map, "--camera", tmp_path / "camera.yaml", "--out", tmp_path / "obs", *args)
    assert result.exit_code == 2, result.output
    assert message in result.output and len(result.output.strip().splitlines()) == 1, result.output
    assert not (tmp_path / "obs").exists()


def test_an_unknown_noise_model_is_a_usage_error(kitchen_map: Path, tmp_path: Path) -> None:
    """--noise takes its choices from SensorNoise.model: Click refuses another before any work."""
    save_observation_camera(tmp_path / "camera.yaml", CAMERA, world_from_camera_looking_along((2, 2, 1), (0, 1, 0)))
    result = _run(kitchen_map, "--camera", tmp_path / "camera.yaml", "--out", tmp_path / "obs", "--noise", "lidar")
    assert result.exit_code == 2 and "'lidar' is not one of 'kinect'" in result.output, result.output
    assert not (tmp_path / "obs").exists()


@pytest.mark.parametrize(
    ("camera_text", "message"),
    [
        ("map_from_camera: [[1, 0, 0, 0], [0, 2, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]", "not a rigid transform"),
        ("map_from_camera: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]", "4x4"),
        ("", "no map_from_camera"),
    ],
)
def test_bad_camera_gives_one_line_and_exit_2(kitchen_map: Path, tmp_path: Path, camera_text: str, message: str) -> None:
    camera = tmp_path / "camera.yaml"
    camera.write_text("width: 160\nheight: 120\nfx: 140\nfy: 140\ncx: 79.5\ncy: 59.5\n" + camera_text + "\n")
    result = _run(kitchen_map, "--camera", camera, "--out", tmp_path / "obs")
    assert result.exit_code == 2, result.output
    assert message in result.output and len(result.output.strip().splitlines()) == 1, result.output


def test_an_observation_whose_depth_disagrees_with_its_camera_is_refused(
    simulator: ViewSimulator, tmp_path: Path
) -> None:
    map_from_camera = simulator.camera_looking_at("fridge_1")
    write_view(simulator.render(CAMERA, map_from_camera), tmp_path / "obs")
    save_observation_camera(tmp_path / "obs" / "camera.yaml", CAMERA.scaled(2.0), map_from_camera)
    with pytest.raises(InputError, match=r"depth.png: the image is 160x120 but camera.yaml says 320x240"):
        read_observation(tmp_path / "obs")
    # An existing folder is kept unless --force.
    save_observation_camera(tmp_path / "camera.yaml", CAMERA, map_from_camera)
    result = _run(simulator.scene.map_path, "--camera", tmp_path / "camera.yaml", "--out", tmp_path / "obs")
    assert result.exit_code == 2 and "not empty" in result.output


def test_a_map_whose_models_are_missing_is_refused(kitchen_map: Path, tmp_path: Path) -> None:
    moved = tmp_path / "map.xml"
    moved.write_bytes(kitchen_map.read_bytes())  # its models' paths are relative: none beside it
    save_observation_camera(tmp_path / "camera.yaml", CAMERA, world_from_camera_looking_along((2, 2, 1), (0, 1, 0)))
    result = _run(moved, "--camera", tmp_path / "camera.yaml", "--out", tmp_path / "obs")
    assert result.exit_code == 2, result.output
    assert "its model" in result.output and "does not exist" in result.output
    assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "obs").exists()


def test_a_view_is_not_written_over_the_maps_models(kitchen_map: Path, tmp_path: Path) -> None:
    """`--out` naming the map's models folder, with --force, deleted the models (exit 0): refused
    before the render, the models kept. A copy of the kitchen: the shared one must not be at stake."""
    home = tmp_path / "kitchen"
    shutil.copytree(kitchen_map.parent, home)
    fridge = sorted((home / "models" / "fridge_1").iterdir())
    save_observation_camera(tmp_path / "camera.yaml", CAMERA, world_from_camera_looking_along((2, 2, 1), (0, 1, 0)))
    result = _run(home / "map.xml", "--camera", tmp_path / "camera.yaml", "--out", home / "models", "--force")
    assert result.exit_code == 2, result.output
    assert "the output folder must lie outside the input" in result.output and "models" in result.output
    assert len(result.output.strip().splitlines()) == 1
    assert sorted((home / "models" / "fridge_1").iterdir()) == fridge


@pytest.mark.parametrize("distortion", [None, (0.12, -0.05, 0.001, -0.002, 0.0)])
def test_per_part_rendering_is_one_mesh_cast_whole(simulator: ViewSimulator, distortion) -> None:
    """The renderer casts each part's rays in its own frame, only where its clipped bounds
    project: the same depth as one mesh of the whole posed scene ray-cast at every pixel."""
    import trimesh

    from homemodel.geometry.raycast import RayCaster

    camera = Camera(**{**CAMERA.model_dump(), "distortion": distortion})
    scene = simulator.scene
    map_from_parts = scene.pose({"cupboard_1": {"door_1_hinge": 1.2, "drawer_0_slide": 0.25}})
    meshes = [
        trimesh.Trimesh(p.vertices_link @ m[:3, :3].T + m[:3, 3], p.faces, process=False)
        for p, m in zip(scene.parts, map_from_parts)
    ]
    # The camera stands inside the room, so the walls behind it cross its image plane.
    map_from_camera = simulator.camera_looking_at("cupboard_1", distance_m=1.6, height_m=1.2, bearing_deg=25)
    whole = RayCaster(trimesh.util.concatenate(meshes)).depth(camera, np.linalg.inv(map_from_camera))
    parts = simulator.renderer.render(map_from_parts, camera, map_from_camera).depth_m
    assert np.isfinite(whole).all() and (parts > 0).all()
    assert np.abs(parts - whole).max() < 1e-4


@pytest.mark.parametrize("distortion", [None, (0.12, -0.05, 0.001, -0.002, 0.0)])
def test_a_stack_of_poses_has_each_poses_rendered_depth(simulator: ViewSimulator, distortion) -> None:
    """`depth_stack` (the fitters' batched, cached depth of many poses) is, pose by pose, the
    depth `render` draws of the same parts: exactly, with the walls behind the camera crossing
    its near plane, a pose asked twice in one stack, and the stack asked again from the cache."""
    camera = Camera(**{**CAMERA.model_dump(), "distortion": distortion})
    scene = simulator.scene
    renderer = Renderer(scene.parts)
    map_from_camera = simulator.camera_looking_at("cupboard_1", distance_m=1.6, height_m=1.2, bearing_deg=25)
    poses = [scene.pose({"cupboard_1": {"door_1_hinge": angle, "drawer_0_slide": 0.1}}) for angle in (0.0, 0.6, 1.2, 0.6)]
    # The cupboard's parts first (what the fitters move), then the floor and walls.
    only = scene.part_indices("cupboard_1") + [i for i, p in enumerate(scene.parts) if p.object_id is None]
    for _ in range(2):
        stack = renderer.depth_stack(poses, camera, map_from_camera, only)
        for depth, map_from_parts in zip(stack, poses, strict=True):
            rendering = renderer.render(map_from_parts, camera, map_from_camera, only=only)
            assert rendering.hit.mean() > 0.9
            assert np.array_equal(depth, np.where(rendering.hit, rendering.depth_m, np.inf))
    assert not np.array_equal(stack[0], stack[2])
