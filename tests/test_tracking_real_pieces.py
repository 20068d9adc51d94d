"""`observe` as the independent check runs it: real pieces (`real_piece_views`: truth meshes
with plinths, face frames, thick doors, door bins, drawer boxes, knobs in pockets), the map
built with `homemodel build` from the specs an installer's tape gives for them, 2 cm and
2 degrees off where each stands; views rendered from the truth meshes, each part moved about
its real axis, with Kinect noise, 1.9-2.5 m away, some with a box over 30 % of the object
looked at. The rule that matters most for a robot: no state or pose written wrong; "not
seen" or "ambiguous" where the view cannot tell.

Each view is one that the checker's stand-in (60 views a set) found a fault in."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from real_piece_views import (RealPieceScene, built_home, fitted_out, glazed, pose_errors, real_pieces, write_prior,
                              write_room)

from homemodel.core.transforms import world_from_camera_looking_at
from homemodel.geometry.camera import Camera
from tracking import ObserveOptions, observe
from tracking.sensor_noise import SensorNoise
from tracking.simulate_view import ViewOptions, ViewSimulator

CAMERA = Camera(width=640, height=480, fx=525.0, fy=525.0, cx=319.5, cy=239.5)
# Where the map has each piece: (x m, y m, yaw deg) off the truth, in the piece's frame.
PRIOR = {
    "wardrobe_4": (-0.01304, -0.015164, 2.0), "cupboard_14": (0.0193, 0.0051, -2.0), "dishwasher_3": (0.0199, 0.0021, -2.0),
    "drawers_21": (0.0171, -0.0104, 2.0), "oven_3": (-0.0157, -0.0124, 2.0), "fridge_3": (-0.0193, -0.0054, 2.0),
    "cupboard_35": (0.0184, -0.0079, -2.0), "cupboard_34": (0.02, 0.0003, 2.0), "microwave_3": (0.0125, -0.0156, 2.0),
    "wall_6": (-0.0025, -0.0198, -2.0),
}
# The held-out views' map: the fridge turned the other way.
PRIOR_HELD_OUT = {
    "wardrobe_4": (-0.01994, -0.00148, 2.0), "cupboard_14": (0.01234, 0.01574, 2.0), "dishwasher_3": (0.01897, -0.00634, -2.0),
    "drawers_21": (-0.01772, 0.00927, -2.0), "oven_3": (0.00938, -0.01766, -2.0), "fridge_3": (-0.01904, -0.00613, -2.0),
    "cupboard_35": (0.0197, 0.00345, 2.0), "cupboard_34": (-0.01943, -0.00475, 2.0), "microwave_3": (-0.00961, 0.01754, -2.0),
    "wall_6": (-0.00656, 0.01889, 2.0),
}


@pytest.fixture(scope="module")
def real_room(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(the built map, the prior map): `homemodel build` of the installer's specs, made once per content."""
    specs = write_room(tmp_path_factory.mktemp("real_room_specs"), real_pieces())
    built = built_home(specs, "real_room", tmp_path_factory.mktemp("real_room") / "out")
    return built, write_prior(built, PRIOR, built.parent / "prior.xml")


@pytest.fixture(scope="module")
def real_furniture(real_room: tuple[Path, Path]) -> ViewSimulator:
    return ViewSimulator(RealPieceScene.of(real_room[0], real_pieces()))


@pytest.fixture(scope="module")
def fitted_furniture(real_room: tuple[Path, Path]) -> ViewSimulator:
    """The pieces with the handles, rounded fronts and tapered knobs their specs leave out."""
    return ViewSimulator(RealPieceScene.of(real_room[0], fitted_out(real_pieces())))


@pytest.fixture(scope="module")
def held_out_prior(real_room: tuple[Path, Path]) -> Path:
    return write_prior(real_room[0], PRIOR_HELD_OUT, real_room[0].parent / "prior_held_out.xml")


def _observed(furniture: ViewSimulator, prior: Path, eye, forward, noise_seed: int, fit: ObserveOptions | None = None,
              **options):
    """The report of `observe` (with `fit`) on the view from `eye` looking along `forward`, and its truth."""
    map_from_camera = world_from_camera_looking_at(np.array(eye), np.array(eye) + np.array(forward))
    view = furniture.render(CAMERA, map_from_camera, ViewOptions(noise=SensorNoise(seed=noise_seed), **options))
    return observe(prior, view.observation, fit).report, view.observation.truth


def _within_targets(errors: dict[str, float]) -> bool:
    return all(abs(e) <= (5.0 if "slide" in name else 2.0) for name, e in errors.items())


def _assert_written_right(report, truth: dict, object_id: str, joints: tuple[str, ...]) -> None:
    """`joints` of `object_id`, which the view pins, written within the targets: a rule that
    makes every joint "ambiguous" would pass the tests of what is not written."""
    errors = _written_errors(report, truth, object_id)
    assert set(joints) <= errors.keys() and _within_targets(errors), (object_id, errors)


def _written_errors(report, truth: dict, object_id: str) -> dict[str, float]:
    """{joint written into the map: its error in degrees or millimetres}."""
    obj = next(o for o in report.objects if o.id == object_id)
    errors = {}
    for joint in obj.joints:
        if joint.status == "fitted":
            error = joint.position - truth["joints"][object_id][joint.name]
            errors[joint.name] = error * 1000 if joint.type == "prismatic" else np.degrees(error)
    return errors


def test_a_shut_door_first_fitted_wide_open_is_searched_again(
    real_room: tuple[Path, Path], real_furniture: ViewSimulator
) -> None:
    """2.5 m in front of the wardrobe, the cupboard beside it is seen askew, 27 mm nearer than
    the map has it after its first pose fit: no angle of its shut right door explains the
    depth there, and the search picked 88 deg open. The pose then came right (0.2 mm), but the
    door's refits searched only near 88 deg: written 88.4 deg off, its model explaining 1 % of
    its points. Searched over its whole range at the final pose it is shut; the pose, refined
    with the door far off, is not written, and the door, read otherwise at the map's pose, is
    not written either (not seen is allowed; wrong is not)."""
    report, truth = _observed(real_furniture, real_room[1], (2.571, 1.705, 1.4), (-0.898, -0.401, -0.183), 4,
                              joint_positions={"wardrobe_4": {"door_0_hinge": 1.1134, "drawer_0_slide": 0.1025,
                                                              "drawer_1_slide": 0.2094}})
    errors = _written_errors(report, truth, "cupboard_14")
    assert abs(errors.get("door_1_hinge", 0.0)) <= 2.0, errors


def test_a_drawer_out_by_the_bodys_error_is_not_written(real_room: tuple[Path, Path], real_furniture: ViewSimulator) -> None:
    """1.9 m in front of the oven, the fridge beside it shows its side and its shut freezer
    drawer: its body too little seen, its pose stays the map's, 19 mm off along the drawer's
    slide, and the drawer was written 19.8 mm out. A drawer out by no more than the map's
    doubt, where the body moved by as much explains the depth as well, is "ambiguous"."""
    report, truth = _observed(real_furniture, real_room[1], (2.123, 3.254, 1.4), (-0.859, 0.002, -0.512), 26,
                              joint_positions={"oven_3": {"door_0_hinge": 1.1109}})
    fridge = next(o for o in report.objects if o.id == "fridge_3")
    drawer = next(j for j in fridge.joints if j.name == "drawer_0_slide")
    assert not fridge.pose_refined and drawer.visible_fraction >= 0.5  # the case looked at
    errors = _written_errors(report, truth, "fridge_3")
    assert all(abs(e) <= (5.0 if "slide" in name else 2.0) for name, e in errors.items()), errors


def test_drawers_out_by_the_bodys_error_together_are_not_written(
    real_room: tuple[Path, Path], real_furniture: ViewSimulator
) -> None:
    """The wardrobe at 1.9 m behind a box over 30 % of it, its door 63 deg open, its lower
    drawer 101 mm out: too little of it seen to refine its pose, the map's, 13 mm off along
    the slides. Its shut drawer was written 15 mm out, the other one 15 mm too far: both
    drawers that much less out in a body moved by as much explain the depth as well, so
    neither is written."""
    report, truth = _observed(real_furniture, real_room[1], (2.039448, 0.090241, 1.4), (-0.918169, 0.312317, -0.243769), 3,
                              joint_positions={"wardrobe_4": {"door_0_hinge": 1.1078, "drawer_0_slide": 0.1011}},
                              occlude={"wardrobe_4": 0.3})
    wardrobe = next(o for o in report.objects if o.id == "wardrobe_4")
    assert not wardrobe.pose_refined
    errors = _written_errors(report, truth, "wardrobe_4")
    assert all(abs(e) <= (5.0 if "slide" in name else 2.0) for name, e in errors.items()), errors


def test_knobs_with_no_pointer_are_not_written(real_room: tuple[Path, Path], real_furniture: ViewSimulator) -> None:
    """The real oven's knobs are plain cylinders in pockets: no depth or colour tells their
    turn. 1.9 m away, a box over 30 % of the oven, one of them was written 120 deg off, its
    best detent 0.021 of its 38 pixels better than the next: less than one pixel. Here the
    bar on that share is taken away (`min_contrast` 0): the bar in pixels alone keeps them
    all unwritten (without it, a detent picked by noise is written)."""
    report, _ = _observed(real_furniture, real_room[1], (2.123, 3.254, 1.4), (-0.859, 0.002, -0.512), 27,
                          ObserveOptions(min_contrast=0.0), joint_positions={"oven_3": {"door_0_hinge": 1.1109}},
                          occlude={"oven_3": 0.3})
    oven = next(o for o in report.objects if o.id == "oven_3")
    knobs = {j.name: j.status for j in oven.joints if j.name.startswith("knob")}
    assert len(knobs) == 4 and "fitted" not in knobs.values(), knobs


def _assert_fridge_beside_the_oven_written_right(furniture: ViewSimulator, prior: Path) -> None:
    """The view 1.9 m from the oven, the fridge beside it kept at the map's pose (the case
    looked at): what is written of the fridge is within target, and the oven's door right."""
    report, truth = _observed(furniture, prior, (2.01953758935667, 3.869220603270326, 1.4),
                              (-0.8109642607522416, -0.2836145578631412, -0.5117614193651816), 1026,
                              joint_positions={"oven_3": {"door_0_hinge": 0.34714126725886296}})
    assert not next(o for o in report.objects if o.id == "fridge_3").pose_refined
    errors = _written_errors(report, truth, "fridge_3")
    assert _within_targets(errors), errors
    _assert_written_right(report, truth, "oven_3", ("door_0_hinge",))


def test_a_door_and_a_drawer_that_pin_each_other_are_tested_shut_together(
    real_room: tuple[Path, Path], real_furniture: ViewSimulator, held_out_prior: Path
) -> None:
    """1.9 m from the oven, the fridge beside it, its body too little seen, is kept at the
    map's pose, 2 cm and 2 deg off: its shut drawer was written 11 mm out, its shut door
    partly seen at 4 deg. The drawer alone shut in a body moved to match explains the depth
    worse (the door then misfits); both shut, the body refitted, explain it far better, so
    the drawer is not written."""
    _assert_fridge_beside_the_oven_written_right(real_furniture, held_out_prior)


def test_a_drawer_out_by_a_refined_poses_error_is_not_written(
    real_room: tuple[Path, Path], fitted_furniture: ViewSimulator, held_out_prior: Path
) -> None:
    """2.5 m in front of the bank of drawers, the fronts with handles: the fridge beside it,
    seen by its side and cut by the image's edge, has its pose refined along the view only
    and written; its shut drawer was written 32 mm out and its shut door 5.2 deg open, the
    body's error. Both shut, the body refitted, explain the depth as well: neither is
    written."""
    report, truth = _observed(fitted_furniture, held_out_prior, (2.693136, 1.840328, 1.4), (-0.885265, 0.278677, -0.372351),
                              1022, joint_positions={"drawers_21": {"drawer_0_slide": 0.2285, "drawer_1_slide": 0.1501,
                                                                    "drawer_2_slide": 0.1109}})
    assert next(o for o in report.objects if o.id == "fridge_3").pose_refined  # the case looked at
    errors = _written_errors(report, truth, "fridge_3")
    assert _within_targets(errors), errors
    _assert_written_right(report, truth, "drawers_21", ("drawer_0_slide", "drawer_1_slide", "drawer_2_slide"))


def test_a_shut_door_its_model_far_off_is_tested_shut(
    real_room: tuple[Path, Path], fitted_furniture: ViewSimulator
) -> None:
    """1.2 m from the cupboard beside it, the fridge's shut door with its bar handle, 2 cm
    and 2 deg off at the map's pose (its body too little seen to refine): no angle explains
    its points (0.76 unexplained at the best), and it was written 54 deg open. Shut, in a
    body refitted within twice the map's doubt, it explains the depth far better: the door
    is not written."""
    report, truth = _observed(fitted_furniture, real_room[1], (1.384041, 4.374584, 1.4), (-0.713402, 0.320622, -0.623104),
                              42, joint_positions={"cupboard_34": {"door_1_hinge": 1.5032}})
    errors = _written_errors(report, truth, "fridge_3")
    assert _within_targets(errors), errors
    _assert_written_right(report, truth, "cupboard_34", ("door_0_hinge", "door_1_hinge"))


def test_a_door_a_box_hides_all_of_is_not_written(real_room: tuple[Path, Path], fitted_furniture: ViewSimulator) -> None:
    """2.5 m from the microwave, a box over 30 % of it hides all of its door, 74 deg open.
    The fitter found the door at its limit, 101 deg, where it sticks out past the box and
    the camera sees through 0.89 of it: written 27 deg off. Where a position in its range
    hides it all, the view cannot tell: not written."""
    report, truth = _observed(fitted_furniture, real_room[1], (2.700943, 4.509215, 1.4), (-0.987163, -0.074332, -0.141366),
                              53, joint_positions={"microwave_3": {"door_0_hinge": 1.2846}}, occlude={"microwave_3": 0.3})
    door = next(p for p in truth["parts"] if p["object"] == "microwave_3" and p["joint"] == "door_0_hinge")
    assert door["visible_fraction"] == 0.0  # the case looked at
    errors = _written_errors(report, truth, "microwave_3")
    assert _within_targets(errors), errors
    _assert_written_right(report, truth, "fridge_3", ("door_0_hinge", "drawer_0_slide"))


def test_a_cupboard_in_a_row_is_not_slid_along_its_front(real_room: tuple[Path, Path], fitted_furniture: ViewSimulator) -> None:
    """2.5 m from the dishwasher, a box over 30 % of it: the cupboard beside it, in a row,
    shows its fronts, its sides hidden by its neighbours and its outline against them, not
    against anything far behind: nothing pins a slide along its front. The fit slid it
    33 mm along it, where the model explained the depth better (0.058 against 0.089 with
    the slide taken out), and that pose was written. A free slide past the issue's 3 cm is
    taken out: the pose is written put right across its front (5 mm from the truth)."""
    report, truth = _observed(fitted_furniture, real_room[1], (2.799653, 1.869691, 1.4), (-0.931158, 0.040379, -0.362374),
                              17, occlude={"dishwasher_3": 0.3})
    cupboard = next(o for o in report.objects if o.id == "cupboard_14")
    (map_m, written_m), _ = pose_errors(cupboard, np.array(truth["objects"]["cupboard_14"]["map_from_object"]))
    assert cupboard.pose_refined, cupboard.pose_note
    assert written_m <= 0.010 < map_m, (map_m, written_m)


def test_a_door_whose_angle_trades_with_its_bodys_turn_is_not_written(
    real_room: tuple[Path, Path], fitted_furniture: ViewSimulator, held_out_prior: Path
) -> None:
    """1.9 m from the fridge, a box over 30 % of it, its door 17 deg open: its body, little
    seen, was fitted turned the wrong way and the door as much further open, written 2.7 deg
    off. The body turned 2.5 deg back about the hinge, the door held where it was seen,
    explains the depth as well: the door's angle is no surer than the body's turn, so it is
    not written."""
    report, truth = _observed(fitted_furniture, held_out_prior, (2.160892, 3.532896, 1.4), (-0.955598, 0.154141, -0.251144),
                              1033, joint_positions={"fridge_3": {"door_0_hinge": 0.2917, "drawer_0_slide": 0.0012}},
                              occlude={"fridge_3": 0.3})
    errors = _written_errors(report, truth, "fridge_3")
    assert _within_targets(errors), errors
    _assert_written_right(report, truth, "cupboard_35", ("door_0_hinge", "drawer_0_slide"))


def test_a_drawer_shut_in_the_body_its_door_holds_is_not_written(
    real_room: tuple[Path, Path], fitted_furniture: ViewSimulator, held_out_prior: Path
) -> None:
    """The view of the door-and-drawer test above, the pieces fitted out: the fridge, kept at
    the map's pose, was fitted turned 3.8 deg with a sliver of its shut door 3.8 deg open and
    its shut drawer 11 mm out. Refitted with both shut, its body drifted into the oven beside
    it, so all-shut was never judged, and the drawer was written 9 mm out. The body that
    holds the door, shut, where it was seen explains the depth far better: not written."""
    _assert_fridge_beside_the_oven_written_right(fitted_furniture, held_out_prior)


def test_a_pose_turned_with_a_partly_seen_door_is_judged_as_the_map_will_hold_it(
    real_room: tuple[Path, Path], fitted_furniture: ViewSimulator, held_out_prior: Path
) -> None:
    """1.2 m from the wardrobe, its door 40 deg open and cut by the image's edge, partly
    seen, so not written: the body was refined with the door's estimate, 30 mm and 3.3 deg
    off (the map's 20 mm and 2 deg), and written, its door kept shut in the map. With the
    door at the map's position that pose explains the depth far worse than the map's (0.26
    -> 0.88): not written. A pose is written only as no worse than the map's (evaluate's
    bar: 2 mm, 0.5 deg)."""
    report, truth = _observed(fitted_furniture, held_out_prior, (1.4870120573789583, 0.6373164682887713, 1.4),
                              (-0.9316737996293717, 0.03782878636594235, -0.3613210677586474), 1000,
                              joint_positions={"wardrobe_4": {"door_0_hinge": 0.6900103577724477,
                                                              "drawer_0_slide": 0.06913193170654912}})
    wardrobe = next(o for o in report.objects if o.id == "wardrobe_4")
    (map_m, written_m), (map_deg, written_deg) = pose_errors(
        wardrobe, np.array(truth["objects"]["wardrobe_4"]["map_from_object"]))
    assert written_m <= map_m + 0.002 and written_deg <= map_deg + 0.5, (written_m, written_deg, wardrobe.pose_note)


def test_a_glazed_door_fitted_out_of_the_way_is_not_written(real_room: tuple[Path, Path]) -> None:
    """1.9 m from the cupboard beside the microwave, its door glazed (a frame round a pane
    the sensor sees through; the model's door is solid) and open 35 deg: the depth seen
    through the pane is explained best with the door out of the way, and it was written
    93.6 deg open, its model explaining 1 % of its points there. A joint whose model
    explains almost none of its points is not written off the map's position."""
    furniture = ViewSimulator(RealPieceScene.of(real_room[0], glazed(fitted_out(real_pieces()), "cupboard_35", "door_0_hinge")))
    map_from_camera = furniture.camera_looking_at("cupboard_35", distance_m=1.9, height_m=1.4, bearing_deg=10.0)
    report, truth = _observed(furniture, real_room[1], map_from_camera[:3, 3], map_from_camera[:3, 2], 1,
                              joint_positions={"cupboard_35": {"door_0_hinge": np.radians(35.0)}})
    errors = _written_errors(report, truth, "cupboard_35")
    assert _within_targets(errors), errors
    _assert_written_right(report, truth, "cupboard_34", ("door_0_hinge", "door_1_hinge"))
