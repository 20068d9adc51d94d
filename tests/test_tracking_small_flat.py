"""`tracking.find_small_objects` on a flat object: a rimmed plate on the demo kitchen's table.

A flat object's top lies parallel to its support, so ICP slides it along the support and any
flat thing fits it (the independent check of issue 26: a plate written 48-111 mm off on a
worktop, and 'found' on the floor of an open drawer's box). The map's plate is the model
`homemodel build` makes of a flat plate's spec (a foot, a well 5 mm up, a rim 25 mm up, 0.268
m across); the home's own plate is shaped like the check's (a deeper well, 0.262 m across), so
the model does not fit it exactly. Views: the table from 1.6 m, 320x240, Kinect-like noise."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import trimesh

from homemodel.geometry.camera import Camera
from tracking import observe
from tracking.sensor_noise import SensorNoise
from tracking.simulate_view import BoxOccluder, SmallObjectMove, ViewOptions, ViewSimulator, write_view

CAMERA = Camera(width=320, height=240, fx=262.5, fy=262.5, cx=159.5, cy=119.5)
PLATE_XY = (0.0, 0.05)  # in the table's frame, clear of its cups, bowl and sugar container
MODEL_PROFILE = [(0.0, 0.0), (0.08, 0.0), (0.134, 0.02), (0.134, 0.025), (0.08, 0.005), (0.0, 0.005)]
REAL_PROFILE = [(0.0, 0.0), (0.07, 0.0), (0.075, 0.008), (0.131, 0.022), (0.131, 0.025), (0.072, 0.011), (0.0, 0.005)]


def _plate_urdf(folder: Path, profile: list[tuple[float, float]]) -> Path:
    (folder / "meshes").mkdir(parents=True)
    trimesh.creation.revolve(np.array(profile), sections=64).export(folder / "meshes" / "body.obj")
    (folder / "model.urdf").write_text(
        '<?xml version="1.0" encoding="utf-8"?>\n<robot name="plate"><link name="body"><visual name="body">'
        '<geometry><mesh filename="meshes/body.obj"/></geometry>'
        '<material name="cream"><color rgba="0.95 0.9 0.75 1"/></material></visual></link></robot>\n')
    return folder / "model.urdf"


def _with_plate(kitchen_map: Path, out: Path, model: Path) -> Path:
    """The kitchen's map with a plate on its table at PLATE_XY, seen through `model`."""
    text = kitchen_map.read_text().replace('model="models/', f'model="{kitchen_map.parent}/models/')
    xyz = f"{PLATE_XY[0]} {PLATE_XY[1]} 0.75"
    plate = (f'<smallObject id="plate" type="plate" parent="table_1" relation="on" graspable="true" model="{model}" '
             f'xyz="{xyz}" rpy="0 0 0"><defaultPosition name="registered" xyz="{xyz}" rpy="0 0 0"/></smallObject>\n')
    out.write_text(re.sub(r'(<smallObject id="red_cup")', plate + r"\1", text, count=1))
    return out


@pytest.fixture(scope="module")
def plate_maps(kitchen_map: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, ViewSimulator]:
    """The map (the built plate model) and the simulator of the home (its own plate)."""
    folder = tmp_path_factory.mktemp("plate")
    map_path = _with_plate(kitchen_map, folder / "map.xml", _plate_urdf(folder / "model", MODEL_PROFILE))
    home = _with_plate(kitchen_map, folder / "home.xml", _plate_urdf(folder / "real", REAL_PROFILE))
    return map_path, ViewSimulator.load(home)


def _plate(plate_maps: tuple[Path, ViewSimulator], folder: Path, move: SmallObjectMove,
           occluders: list[BoxOccluder] = ()):  # noqa: ANN202
    map_path, simulator = plate_maps
    map_from_camera = simulator.camera_looking_at("table_1", distance_m=1.6, height_m=1.4, bearing_deg=180.0)
    options = ViewOptions(moves=[move], occluders=list(occluders), noise=SensorNoise(seed=3))
    write_view(simulator.render(CAMERA, map_from_camera, options), folder)
    report = observe(map_path, folder).report
    plate = next(s for o in report.objects for s in o.small_objects if s.id == "plate")
    return plate, np.array(json.loads((folder / "truth.json").read_text())["objects"]["plate"]["map_from_object"])


def test_a_plate_moved_on_the_table_is_found_where_it_is(plate_maps, tmp_path: Path) -> None:
    """Moved 3.6 cm: its ICP alone slid it 23 mm off (inlier 0.77); the misfit's descent puts it within the issue's 1 cm."""
    move = SmallObjectMove(object_id="plate", x_m=PLATE_XY[0] + 0.03, y_m=PLATE_XY[1] - 0.02, yaw_rad=0.0)
    plate, truth = _plate(plate_maps, tmp_path / "obs", move)
    assert plate.status == "found" and plate.parent == "table_1"
    assert np.linalg.norm(plate.map_from_object[:2, 3] - truth[:2, 3]) < 0.01


def test_a_board_where_the_plate_was_is_not_the_plate(plate_maps, tmp_path: Path) -> None:
    """The plate gone (out of view) and a 2 cm board lying where the map has it: the plate model
    explains 0.70 of its pixels there, but a flat slab explains them better than the plate's
    rim and well do; it is not written found."""
    map_path, simulator = plate_maps
    on_table = np.eye(4)
    on_table[:3, 3] = (*PLATE_XY, 0.75 + 0.01)
    board = BoxOccluder(size_m=(0.32, 0.24, 0.02), map_from_box=simulator.scene.map_from_objects()["table_1"] @ on_table)
    away = SmallObjectMove(object_id="plate", x_m=10.0, y_m=0.0, yaw_rad=0.0)
    plate, _ = _plate(plate_maps, tmp_path / "obs", away, [board])
    assert plate.status != "found", plate
