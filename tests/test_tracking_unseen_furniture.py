"""`observe` on views of furniture it has not seen: the depth is rendered from the kitchen's
pieces with every link's size and place a few millimetres off the map's models
(`unlike_their_models`), as real furniture differs from what an installer measured; Kinect
noise, 640x480, the map 2 cm and 2 degrees off. The issue's targets for every part at least
half visible: doors and flaps within 2 degrees, drawers within 5 mm, small objects within
1 cm; with a box over 30 % of the object too. The refined pose of the object looked at is
never written worse than the map's.

Then a room of furniture unlike the kitchen's, built from specs as an installer writes them:
the catalogue's wardrobe and a chest of four drawers."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from real_piece_views import built_home, pose_errors

from homemodel.core.transforms import transform_from_xyz_rpy, world_from_camera_looking_at
from homemodel.geometry.camera import Camera
from prior_maps import write_prior_map
from tracking import observe
from tracking.fit_state import FitState
from tracking.pose_gate import PoseGate, past_the_doubt
from tracking.scene import HomeScene
from tracking.sensor_noise import SensorNoise
from tracking.simulate_view import SmallObjectMove, ViewOptions, ViewSimulator, unlike_their_models, write_view

CAMERA = Camera(width=640, height=480, fx=525.0, fy=525.0, cx=319.5, cy=239.5)
OFF_M = 0.005  # each link's size off by 3-5 mm along each axis, its place by up to 2.5 mm
PRIOR_OFF = transform_from_xyz_rpy((-0.012, 0.016, 0.0), (0.0, 0.0, np.radians(-2.0)))  # 2 cm, 2 deg


@pytest.fixture(scope="module")
def furniture(kitchen_map: Path) -> ViewSimulator:
    """The real kitchen: its pieces are not the map's models."""
    return ViewSimulator(unlike_their_models(HomeScene.load(kitchen_map), off_m=OFF_M, seed=11))


@pytest.fixture(scope="module")
def prior_map(kitchen_map: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_prior_map(kitchen_map, PRIOR_OFF, tmp_path_factory.mktemp("prior") / "map.xml")


def test_the_furniture_differs_from_its_models(furniture: ViewSimulator, kitchen_map: Path) -> None:
    models = HomeScene.load(kitchen_map)
    for real, model in zip(furniture.scene.parts, models.parts):
        if real.object_id is None:
            continue
        size = np.ptp(model.vertices_link, axis=0)
        size_off = np.abs(np.ptp(real.vertices_link, axis=0) - size)
        assert np.all(size_off <= OFF_M + 1e-9), real.name
        # (a part thinner than that is halved at most: a lid)
        assert np.all((size_off >= 0.6 * OFF_M - 1e-9) | (size < 2 * OFF_M)), real.name


def _observed(furniture: ViewSimulator, prior_map: Path, folder: Path, map_from_camera: np.ndarray, options: ViewOptions):
    write_view(furniture.render(CAMERA, map_from_camera, options), folder)
    return observe(prior_map, folder), json.loads((folder / "truth.json").read_text())


def _visible_fractions(truth: dict, object_id: str) -> dict[str, float]:
    """{joint: the visible fraction of the largest link it moves (a door, not its handle)}."""
    parts = sorted((p for p in truth["parts"] if p["object"] == object_id and p["joint"]), key=lambda p: p["pixels"])
    return {p["joint"]: p["visible_fraction"] for p in parts}


# The targets, on every view (the occluded cupboard's right door: 3.5 deg before its
# drawer, 0.47 visible, was refined with the pose; 1.1 deg since).
DOOR_DEG, DRAWER_MM = 2.0, 5.0


@pytest.mark.parametrize(
    ("object_id", "joints", "distance_m", "occluded"),
    [
        ("cupboard_1", {"door_0_hinge": 0.7, "drawer_0_slide": 0.12}, 1.5, False),
        ("cupboard_1", {"door_1_hinge": 0.9, "drawer_0_slide": 0.2}, 1.8, True),  # the box over the left door
        ("fridge_1", {"door_0_hinge": 1.1, "drawer_0_slide": 0.25}, 2.3, False),
        ("oven_1", {"door_0_hinge": 0.6, "drawer_0_slide": 0.15}, 1.4, False),  # a bottom-hinged flap
        ("oven_1", {"door_0_hinge": 0.6, "drawer_0_slide": 0.15}, 1.8, True),
    ],
)
def test_joints_of_unseen_furniture_within_the_targets(
    furniture: ViewSimulator, prior_map: Path, tmp_path: Path, object_id: str, joints: dict, distance_m: float,
    occluded: bool,
) -> None:
    options = ViewOptions(joint_positions={object_id: joints}, occlude={object_id: 0.3} if occluded else {},
                          noise=SensorNoise(seed=21))
    map_from_camera = furniture.camera_looking_at(object_id, distance_m=distance_m, height_m=1.4, bearing_deg=15.0)
    result, truth = _observed(furniture, prior_map, tmp_path / "obs", map_from_camera, options)
    visible = _visible_fractions(truth, object_id)
    obj = next(o for o in result.report.objects if o.id == object_id)
    checked = 0
    for joint in obj.joints:
        if joint.name.startswith("knob") or visible.get(joint.name, 0.0) < 0.5:
            continue
        error = joint.position - truth["joints"][object_id][joint.name]
        error, limit = (error * 1000, DRAWER_MM) if joint.type == "prismatic" else (np.degrees(error), DOOR_DEG)
        assert joint.status == "fitted" and abs(error) <= limit, (joint.name, joint.status, error)
        checked += 1
    assert checked >= 1
    # The object looked at (a neighbour cut by the image's edge can still come out worse:
    # the fridge beside the occluded cupboard, 27 mm against the map's 20).
    true_xy = np.array(truth["objects"][object_id]["map_from_object"])[:2, 3]
    before, after = (np.linalg.norm(p[:2, 3] - true_xy) for p in (obj.previous_map_from_object, obj.map_from_object))
    assert after <= before + 0.002, (obj.pose_note, before, after)


def test_small_objects_of_unseen_shapes_within_a_centimetre(
    furniture: ViewSimulator, prior_map: Path, tmp_path: Path
) -> None:
    options = ViewOptions(
        moves=[
            SmallObjectMove(object_id="blue_cup", x_m=-0.3, y_m=0.2, yaw_rad=2.0),
            SmallObjectMove(object_id="red_cup", x_m=0.0, y_m=0.1, yaw_rad=-0.7, parent_id="cupboard_1"),
        ],
        noise=SensorNoise(seed=22),
    )
    map_from_camera = world_from_camera_looking_at(np.array([2.7, 3.3, 1.6]), np.array([1.1, 2.3, 0.7]))
    result, truth = _observed(furniture, prior_map, tmp_path / "obs", map_from_camera, options)
    visible = {p["object"]: p["visible_fraction"] for p in truth["parts"] if not p["joint"]}
    found = {s.id: s for o in result.report.objects for s in o.small_objects if s.status == "found"}
    wanted = [i for i in ("red_cup", "blue_cup", "sugar_container") if visible.get(i, 0.0) >= 0.5]
    assert "red_cup" in wanted and "blue_cup" in wanted
    for object_id in wanted:
        assert object_id in found and found[object_id].parent == truth["objects"][object_id]["parent"], object_id
        error = found[object_id].map_from_object[:3, 3] - np.array(truth["objects"][object_id]["map_from_object"])[:3, 3]
        assert np.linalg.norm(error) < 0.01, (object_id, error)


CHEST_OF_DRAWERS = """\
# A chest of four drawers 0.7 m wide, 0.45 m deep, 0.85 m high: its front is all drawers.
kind: cupboard
width_m: 0.7
depth_m: 0.45
height_m: 0.85
wall_thickness_m: 0.018
plinth_height_m: 0.06
doors: []
drawers:
  - {left_m: 0.002, width_m: 0.696, bottom_m: 0.062, height_m: 0.19, depth_m: 0.4, travel_m: 0.35, handle: {length_m: 0.2}}
  - {left_m: 0.002, width_m: 0.696, bottom_m: 0.254, height_m: 0.19, depth_m: 0.4, travel_m: 0.35, handle: {length_m: 0.2}}
  - {left_m: 0.002, width_m: 0.696, bottom_m: 0.446, height_m: 0.19, depth_m: 0.4, travel_m: 0.35, handle: {length_m: 0.2}}
  - {left_m: 0.002, width_m: 0.696, bottom_m: 0.638, height_m: 0.19, depth_m: 0.4, travel_m: 0.35, handle: {length_m: 0.2}}
colour: oak
handle_colour: black
mass_kg: 30
"""
ROOM = """\
apartment: {id: other_house, name: Other house}
rooms:
  - id: room
    name: Room
    outline: [[0.0, 0.0], [5.0, 0.0], [5.0, 5.0], [0.0, 5.0]]
    objects:
      - id: wardrobe_1
        spec: wardrobe.yaml
        pose: {xyz: [0.3, 1.2, 0.0], rpy_deg: [0, 0, 0]}
        parking: [{name: front, xy: [1.3, 1.2], yaw_deg: 180}]
      - id: chest_1
        spec: chest.yaml
        pose: {xyz: [0.225, 3.4, 0.0], rpy_deg: [0, 0, 0]}
        parking: [{name: front, xy: [1.2, 3.4], yaw_deg: 180}]
"""
# The prior the bench drew for a wardrobe whose side, seen at the image's edge, had its origin
# written 47 mm off (the map's 20 mm): its turn, put right about that side, swung the rest.
ROOM_PRIOR_OFF = transform_from_xyz_rpy((0.019, 0.005, 0.0), (0.0, 0.0, np.radians(-2.0)))


@pytest.fixture(scope="module")
def other_room(catalogue_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """`homemodel build` of the room (its map.xml), made once per content (fixture_cache)."""
    specs = tmp_path_factory.mktemp("other_room_specs")
    shutil.copy(catalogue_dir / "wardrobe.yaml", specs)
    (specs / "chest.yaml").write_text(CHEST_OF_DRAWERS)
    (specs / "home.yaml").write_text(ROOM)
    return built_home(specs, "other_room", tmp_path_factory.mktemp("other_room") / "out")


@pytest.fixture(scope="module")
def other_furniture(other_room: Path) -> ViewSimulator:
    """The room's real pieces: not its map's models."""
    return ViewSimulator(unlike_their_models(HomeScene.load(other_room), off_m=OFF_M, seed=11))


def _chest_seen(furniture: ViewSimulator, distance_m: float, bearing_deg: float) -> tuple[np.ndarray, ViewOptions]:
    """A view of the chest, two of its drawers out: (the camera's pose, the view's options)."""
    options = ViewOptions(joint_positions={"chest_1": {"drawer_0_slide": 0.1, "drawer_2_slide": 0.25}},
                          noise=SensorNoise(seed=21))
    return furniture.camera_looking_at("chest_1", distance_m=distance_m, height_m=1.4, bearing_deg=bearing_deg), options


def test_a_neighbour_seen_by_its_side_at_the_edge_keeps_the_maps_origin(
    other_room: Path, other_furniture: ViewSimulator, tmp_path: Path
) -> None:
    """The camera 2.3 m in front of the chest sees the wardrobe's side at the image's left
    edge, and a sliver of its front: the side pins its turn and its place across the side,
    not its slide along it; what the view leaves free stays where the map has the origin."""
    prior = write_prior_map(other_room, ROOM_PRIOR_OFF, tmp_path / "prior.xml")
    result, truth = _observed(other_furniture, prior, tmp_path / "obs", *_chest_seen(other_furniture, 2.3, -5.0))
    wardrobe = next(o for o in result.report.objects if o.id == "wardrobe_1")
    assert wardrobe.pose_refined and "cut by the image's edge" in wardrobe.pose_note  # the case looked at
    (before, after), (_, turn) = pose_errors(wardrobe, np.array(truth["objects"]["wardrobe_1"]["map_from_object"]))
    assert after <= before + 0.002, (wardrobe.pose_note, before, after)
    assert turn <= 0.5, turn  # put right (the map's 2 deg)


def test_a_sliver_of_a_neighbour_turned_far_off_is_not_written(
    other_room: Path, other_furniture: ViewSimulator, tmp_path: Path
) -> None:
    """Straight in front of the chest at 2 m, the wardrobe shows the image's left edge a
    sliver of its side, edge-on: fitted, it turned 11 deg and its origin went 133 mm off (the
    map's 20 mm, 2 deg). No pose that moves the object so much more than the map's error is
    written."""
    prior = write_prior_map(other_room, PRIOR_OFF, tmp_path / "prior.xml")
    map_from_camera, options = _chest_seen(other_furniture, 2.0, 0.0)
    view = other_furniture.render(CAMERA, map_from_camera, options)
    result = observe(prior, view.observation)  # in memory: read from its files, it is not fitted at all
    wardrobe = next(o for o in result.report.objects if o.id == "wardrobe_1")
    (before, after), (turn_before, turn_after) = pose_errors(
        wardrobe, np.array(view.observation.truth["objects"]["wardrobe_1"]["map_from_object"]))
    assert after <= before + 0.002 and turn_after <= turn_before + 0.5, (wardrobe.pose_note, after, turn_after)


def test_a_chest_of_drawers_seen_from_the_front(other_room: Path, other_furniture: ViewSimulator, tmp_path: Path) -> None:
    """Straight in front of the chest at 2.5 m its front is all drawers and its body too
    little seen to pin its depth, the map's 12 mm behind the truth: every drawer at least
    half visible within 5 mm all the same (each came out 9-11 mm, the shut one too)."""
    prior = write_prior_map(other_room, PRIOR_OFF, tmp_path / "prior.xml")
    result, truth = _observed(other_furniture, prior, tmp_path / "obs", *_chest_seen(other_furniture, 2.5, 0.0))
    visible = _visible_fractions(truth, "chest_1")
    chest = next(o for o in result.report.objects if o.id == "chest_1")
    errors = {j.name: (j.status, (j.position - truth["joints"]["chest_1"][j.name]) * 1000)
              for j in chest.joints if visible.get(j.name, 0.0) >= 0.5}
    assert len(errors) >= 3, visible
    assert all(status == "fitted" and abs(error) <= DRAWER_MM for status, error in errors.values()), errors


def test_the_bound_on_a_pose_grows_with_the_object(other_room: Path) -> None:
    """A refined pose that moves a corner of the object's box more than twice the map's doubt
    there, or turns it more than twice the map's 2 deg, is not written: the 1.5 m wardrobe
    corrected by 3 cm and 4 deg passes, turned 11 deg it does not; the 0.7 m chest's bound is
    tighter, and turned 5 deg in place (its corners 3.6 cm off, within their 6.9 cm) it is refused."""
    state = FitState.start(HomeScene.load(other_room))
    gate = PoseGate()

    def refused(object_id: str, x_m: float, yaw_deg: float) -> bool:
        before = state.map_from_objects[object_id].copy()
        state.map_from_objects[object_id] = before @ transform_from_xyz_rpy((x_m, 0.0, 0.0), (0.0, 0.0, np.radians(yaw_deg)))
        why = past_the_doubt(state, object_id, before, gate)
        state.map_from_objects[object_id] = before
        return why is not None

    assert not refused("wardrobe_1", 0.03, 4.0) and refused("wardrobe_1", 0.0, 11.0)
    assert not refused("chest_1", 0.03, 4.0) and refused("chest_1", 0.0, 14.0) and refused("chest_1", 0.08, 0.0)
    assert refused("chest_1", 0.0, 5.0) and not refused("chest_1", 0.0, 3.5)
