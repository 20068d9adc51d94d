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
from real_piece_views import RealPieceScene, built_home, real_pieces, write_prior, write_room

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


@pytest.fixture(scope="module")
def real_room(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(the built map, the prior map): `homemodel build` of the installer's specs, made once per content."""
    specs = write_room(tmp_path_factory.mktemp("real_room_specs"), real_pieces())
    built = built_home(specs, "real_room", tmp_path_factory.mktemp("real_room") / "out")
    return built, write_prior(built, PRIOR, built.parent / "prior.xml")


@pytest.fixture(scope="module")
def real_furniture(real_room: tuple[Path, Path]) -> ViewSimulator:
    return ViewSimulator(RealPieceScene.of(real_room[0], real_pieces()))


def _observed(furniture: ViewSimulator, prior: Path, eye, forward, noise_seed: int, fit: ObserveOptions | None = None,
              **options):
    """The report of `observe` (with `fit`) on the view from `eye` looking along `forward`, and its truth."""
    map_from_camera = world_from_camera_looking_at(np.array(eye), np.array(eye) + np.array(forward))
    view = furniture.render(CAMERA, map_from_camera, ViewOptions(noise=SensorNoise(seed=noise_seed), **options))
    return observe(prior, view.observation, fit).report, view.observation.truth


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
