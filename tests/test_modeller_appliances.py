"""modeller: cabinets and appliances (cupboards, wall cabinets, wardrobes, fridges, ovens,
dishwashers, washing machines, microwaves) built to their specs, checked against the
measurements and through the whole validation gate, and their impossible specs refused."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from spec_edits import read_spec, with_field, write_spec

from homemodel.core.errors import SpecError
from homemodel.core.transforms import transform_points
from homemodel.exchange.model_files import write_model_files
from homemodel.model_folder.gate.validate import validate_path
from modeller import build_model, load_spec, write_spec_schemas

NAMES = [
    "cupboard",
    "wall_cabinet",
    "wardrobe",
    "fridge",
    "fridge_two_doors",
    "oven",
    "dishwasher",
    "washing_machine",
    "microwave",
]
KINDS = ["cupboard", "wall_cabinet", "wardrobe", "fridge", "oven", "dishwasher", "washing_machine", "microwave"]
TOL_M = 1e-3


def _vertices(model, link: str, positions: dict | None = None, *, skip: tuple[str, ...] = ()) -> np.ndarray:
    world_from_link = model.world_from_links(positions)[link]
    return np.vstack(
        [
            transform_points(world_from_link @ v.link_from_visual, v.mesh.vertices)
            for v in model.link(link).visuals
            if not v.name.startswith(skip)
        ]
    )


def _visual(model, link: str, name: str):
    return next(v.mesh for v in model.link(link).visuals if v.name == name)


# ---------------------------------------------------------------------------- every kind


@pytest.mark.bpy
@pytest.mark.parametrize("name", NAMES)
def test_catalogue_model_passes_every_gate_check(catalogue, name: str) -> None:
    _, model, report = catalogue[name]
    assert report.ok, report.format()
    names = [c.name for c in report.checks]
    assert "collisions" in names and "pybullet" in names and "glTF validator" in names
    assert model.name == name


@pytest.mark.bpy
@pytest.mark.parametrize("name", NAMES)
def test_body_has_the_measured_outer_size(catalogue, name: str) -> None:
    spec, model, _ = catalogue[name]
    # Burners and knobs stand on the hob and the panel; the body's box is what was measured.
    vertices = _vertices(model, "body", skip=("body.burner_",))
    np.testing.assert_allclose(vertices.min(0), [-spec.depth_m / 2, -spec.width_m / 2, spec.base_m], atol=TOL_M)
    np.testing.assert_allclose(vertices.max(0), [spec.depth_m / 2, spec.width_m / 2, spec.top_m], atol=TOL_M)
    carcass = _visual(model, "body", "body")
    assert carcass.is_volume  # walls of measured thickness, open at the front


@pytest.mark.bpy
@pytest.mark.parametrize("name", NAMES)
def test_doors_turn_about_their_measured_hinge_lines_and_open_outward(catalogue, name: str) -> None:
    spec, model, _ = catalogue[name]
    front_x = spec.depth_m / 2 + spec.door_gap_m + spec.door_thickness_m
    for i, door in enumerate(spec.doors):
        link = f"door_{i}"
        closed = _vertices(model, link, skip=(f"{link}_handle", f"{link}.shelf_"))
        y0, y1 = -spec.width_m / 2 + door.left_m, -spec.width_m / 2 + door.right_m
        np.testing.assert_allclose(closed.min(0)[1:], [y0, door.bottom_m], atol=TOL_M)
        np.testing.assert_allclose(
            closed.max(0), [front_x + 0.0005 * (door.window is not None), y1, door.top_m], atol=TOL_M
        )
        hinge = model.joint(f"{link}_hinge")
        assert hinge.type == "revolute" and hinge.parent == "body"
        # The axis lies on the hinge-side edge of the door's outer face.
        expected_point = {
            "left": (front_x, y0, door.bottom_m),
            "right": (front_x, y1, door.bottom_m),
            "bottom": (front_x, y0, door.bottom_m),
            "top": (front_x, y0, door.top_m),
        }[door.hinge]
        np.testing.assert_allclose(hinge.parent_from_joint[:3, 3], expected_point, atol=TOL_M)
        expected_axis = {"left": (0, 0, -1), "right": (0, 0, 1), "bottom": (0, 1, 0), "top": (0, -1, 0)}[door.hinge]
        np.testing.assert_allclose(hinge.axis, expected_axis)
        assert hinge.limits.upper == pytest.approx(math.radians(door.opening_limit_deg))
        # Opening moves every point of the door outward or along the front, never into the body.
        for angle in np.linspace(0, hinge.limits.upper, 6)[1:]:
            opened = _vertices(model, link, {hinge.name: angle}, skip=(f"{link}.shelf_",))
            assert opened[:, 0].min() >= spec.depth_m / 2 + spec.door_gap_m - 1e-9
        half_open = _vertices(model, link, {hinge.name: math.radians(60)}, skip=(f"{link}_handle", f"{link}.shelf_"))
        # Its outer face's free edge leads: the hinge line's x plus the door's size times sin 60.
        size = door.width_m if door.side_hinged else door.height_m
        assert half_open[:, 0].max() == pytest.approx(front_x + size * math.sin(math.radians(60)), abs=TOL_M)


@pytest.mark.bpy
@pytest.mark.parametrize("name", NAMES)
def test_every_handle_and_knob_has_a_grasp_point_where_measured(catalogue, name: str) -> None:
    spec, model, _ = catalogue[name]
    grasps = {g.name: g for g in model.grasp_points}
    fronts = [f"door_{i}" for i in range(len(spec.doors))] + [f"drawer_{i}" for i in range(len(spec.drawers))]
    expected = {f"{f}_handle" for f in fronts} | {f"knob_{i}" for i in range(len(spec.knobs))}
    assert set(grasps) == expected
    world = model.world_from_grasp_points()
    front_x = spec.depth_m / 2 + spec.door_gap_m + spec.door_thickness_m
    for group, items in (("door", spec.doors), ("drawer", spec.drawers)):
        for i, front in enumerate(items):
            handle = front.handle
            across, up = front.handle_offset_m()
            y, z = -spec.width_m / 2 + front.left_m + across, front.bottom_m + up
            out = {
                "bar": handle.standoff_m,
                "knob": handle.knob_projection_m * 0.725,
                "recessed": -handle.recess_depth_m / 2,
            }
            grasp = grasps[f"{group}_{i}_handle"]
            assert grasp.kind == ("knob" if handle.type == "knob" else "handle")
            np.testing.assert_allclose(world[grasp.name][:3, 3], [front_x + out[handle.type], y, z], atol=TOL_M)
            np.testing.assert_allclose(world[grasp.name][:3, 0], [-1, 0, 0], atol=1e-9)
            assert model.joint(f"{group}_{i}_handle_mount").type == "fixed"
    for i, knob in enumerate(spec.knobs):
        assert grasps[f"knob_{i}"].kind == "knob"
        np.testing.assert_allclose(
            world[f"knob_{i}"][:3, 3],
            [spec.depth_m / 2 + knob.projection_m / 2, -spec.width_m / 2 + knob.left_m, knob.height_m],
            atol=TOL_M,
        )


@pytest.mark.bpy
@pytest.mark.parametrize("name", NAMES)
def test_drawers_slide_out_by_their_travel_from_inside_the_body(catalogue, name: str) -> None:
    spec, model, _ = catalogue[name]
    for i, drawer in enumerate(spec.drawers):
        slide = model.joint(f"drawer_{i}_slide")
        assert slide.type == "prismatic" and slide.limits.upper == pytest.approx(drawer.travel_m)
        closed = _vertices(model, f"drawer_{i}")
        opened = _vertices(model, f"drawer_{i}", {slide.name: drawer.travel_m})
        np.testing.assert_allclose(opened - closed, np.tile([drawer.travel_m, 0, 0], (len(closed), 1)), atol=1e-9)
        assert closed[:, 0].min() >= -spec.depth_m / 2 + spec.wall_thickness_m - 1e-9
        assert closed[:, 0].max() <= spec.depth_m / 2 + spec.door_gap_m + spec.door_thickness_m + TOL_M


@pytest.mark.bpy
@pytest.mark.parametrize("kind", KINDS)
def test_a_kind_alone_builds_its_standard_layout_and_validates(tmp_path: Path, kind: str) -> None:
    path = tmp_path / f"{kind}.yaml"
    path.write_text(f"kind: {kind}\n")
    model = build_model(path)
    assert model.category == kind and model.movable_joints
    write_model_files(model, tmp_path / "out")
    report = validate_path(tmp_path / "out")
    assert report.ok, report.format()


# ---------------------------------------------------------------------------- kinds' own parts


@pytest.mark.bpy
def test_cupboard_knob_handles_recessed_pockets_divider_and_shelf(catalogue) -> None:
    spec, model, _ = catalogue["cupboard"]
    assert model.category == "cupboard" and set(model.affordances) == {"container", "openable", "supporting_surface"}
    knob = np.vstack(
        [transform_points(v.link_from_visual, v.mesh.vertices) for v in model.link("door_0_handle").visuals]
    )
    handle = spec.doors[0].handle
    assert knob[:, 0].max() - knob[:, 0].min() == pytest.approx(handle.knob_projection_m, abs=TOL_M)
    assert knob[:, 1].max() - knob[:, 1].min() == pytest.approx(handle.knob_diameter_m, abs=TOL_M)
    # The pocket is cut out of the drawer front: its volume is the slab's less the pocket's.
    pocket = spec.drawers[1].handle
    front = _visual(model, "drawer_1", "drawer_1")
    slab = spec.door_thickness_m * spec.drawers[1].width_m * spec.drawers[1].height_m
    assert front.is_volume
    assert front.volume == pytest.approx(
        slab - pocket.length_m * pocket.recess_width_m * pocket.recess_depth_m, rel=1e-4
    )
    # The shelf stops at the divider, and the drawers' boxes stay right of it.
    shelf = _visual(model, "body", "body.shelf_0")
    divider_y = -spec.width_m / 2 + spec.dividers[0].left_m
    assert shelf.bounds[1, 1] == pytest.approx(divider_y, abs=TOL_M)
    for i in range(3):
        assert _vertices(model, f"drawer_{i}", skip=(f"drawer_{i}_handle",))[:, 1].min() > divider_y


@pytest.mark.bpy
def test_oven_knobs_have_named_states_and_a_marker_that_turns_clockwise(catalogue) -> None:
    spec, model, _ = catalogue["oven"]
    for i, knob in enumerate(spec.knobs):
        joint = model.joint(f"knob_{i}_turn")
        step = math.radians(knob.step_deg)
        assert [s.name for s in joint.states] == knob.states
        np.testing.assert_allclose([s.position for s in joint.states], step * np.arange(len(knob.states)))
        assert (joint.limits.lower, joint.limits.upper) == (0.0, pytest.approx(step * (len(knob.states) - 1)))
        centre = np.array([spec.depth_m / 2, -spec.width_m / 2 + knob.left_m, knob.height_m])
        for state in joint.states:
            marker = np.vstack(
                [
                    transform_points(
                        model.world_from_links({joint.name: state.position})[f"knob_{i}"] @ v.link_from_visual,
                        v.mesh.vertices,
                    )
                    for v in model.link(f"knob_{i}").visuals
                    if v.name.endswith(".marker")
                ]
            )
            dy, dz = (marker.mean(0) - centre)[1:]
            # Seen from in front (looking along -x) the viewer's right is +y: clockwise from
            # 12 o'clock the marker moves towards +y.
            seen_angle = math.atan2(dy, dz)
            assert math.remainder(seen_angle - state.position, 2 * math.pi) == pytest.approx(0, abs=1e-6)
            assert marker[:, 0].max() > spec.depth_m / 2 + knob.projection_m  # proud of the knob's face


@pytest.mark.bpy
def test_oven_hob_door_opening_down_and_affordances(catalogue) -> None:
    spec, model, _ = catalogue["oven"]
    hob = _visual(model, "body", "body.hob")
    assert hob.bounds[1, 2] == pytest.approx(spec.height_m, abs=TOL_M)
    burners = [v.mesh for v in model.link("body").visuals if v.name.startswith("body.burner_")]
    assert sorted(round(b.extents[0], 3) for b in burners) == sorted(b.diameter_m for b in spec.hob.burners)
    door = spec.doors[0]
    opened = _vertices(model, "door_0", {"door_0_hinge": math.pi / 2}, skip=("door_0_handle", "door_0.window"))
    # Open flat, the door lies on the hinge line's height, reaching out by its height.
    assert opened[:, 2].min() == pytest.approx(door.bottom_m, abs=TOL_M)
    assert opened[:, 2].max() == pytest.approx(door.bottom_m + spec.door_thickness_m, abs=TOL_M)
    assert opened[:, 0].max() == pytest.approx(
        spec.depth_m / 2 + spec.door_gap_m + spec.door_thickness_m + door.height_m, abs=TOL_M
    )
    window = _visual(model, "door_0", "door_0.window")
    assert window.extents[1] == pytest.approx(door.width_m - 2 * door.window.margin_m, abs=TOL_M)
    assert set(model.affordances) == {"container", "openable", "supporting_surface"}


@pytest.mark.bpy
def test_fridge_door_shelves_inside_when_closed_and_freezer_drawer(catalogue) -> None:
    spec, model, _ = catalogue["fridge"]
    door = spec.doors[0]
    assert door.hinge == "right" and len(door.shelves) == 3 and len(spec.drawers) == 1
    t = spec.wall_thickness_m
    for k, shelf in enumerate(door.shelves):
        bin_vertices = np.vstack(
            [
                transform_points(model.world_from_links()["door_0"] @ v.link_from_visual, v.mesh.vertices)
                for v in model.link("door_0").visuals
                if v.name == f"door_0.shelf_{k}"
            ]
        )
        lo, hi = bin_vertices.min(0), bin_vertices.max(0)
        assert lo[0] == pytest.approx(spec.depth_m / 2 + spec.door_gap_m - shelf.depth_m, abs=TOL_M)
        assert lo[1] > -spec.width_m / 2 + t and hi[1] < spec.width_m / 2 - t
        assert lo[2] == pytest.approx(door.bottom_m + shelf.height_m, abs=TOL_M)
    # The glass shelves are set back behind the door shelves.
    for shelf in spec.shelves[1:]:
        mesh = _visual(model, "body", f"body.shelf_{spec.shelves.index(shelf)}")
        assert mesh.bounds[1, 0] < spec.depth_m / 2 + spec.door_gap_m - max(s.depth_m for s in door.shelves)


@pytest.mark.bpy
def test_two_door_fridge_doors_meet_in_the_middle(catalogue) -> None:
    spec, model, _ = catalogue["fridge_two_doors"]
    left, right = spec.doors
    assert (left.hinge, right.hinge) == ("left", "right")
    assert right.left_m - left.right_m == pytest.approx(2 * spec.door_gap_m, abs=1e-6)
    np.testing.assert_allclose(model.joint("door_0_hinge").axis, [0, 0, -1])
    np.testing.assert_allclose(model.joint("door_1_hinge").axis, [0, 0, 1])


@pytest.mark.bpy
def test_washing_machine_round_door_porthole_and_drum(catalogue) -> None:
    spec, model, _ = catalogue["washing_machine"]
    door = spec.doors[0]
    assert door.shape == "round" and door.hinge == "left"
    disc = _visual(model, "door_0", "door_0")
    assert disc.extents[1] == pytest.approx(door.width_m, abs=TOL_M)
    assert disc.volume == pytest.approx(math.pi * (door.width_m / 2) ** 2 * spec.door_thickness_m, rel=0.01)
    panel = spec.holed_panel()
    holed = _visual(model, "body", f"body.panel_{spec.panels.index(panel)}")
    t = spec.wall_thickness_m
    y0, y1 = max(panel.left_m, t), min(panel.right_m, spec.width_m - t)
    z0, z1 = max(panel.bottom_m, spec.inner_floor_m), min(panel.top_m, spec.inner_top_m)
    slab = t * (y1 - y0) * (z1 - z0)
    assert holed.volume == pytest.approx(slab - math.pi * (panel.hole.diameter_m / 2) ** 2 * t, rel=0.01)
    drum = _visual(model, "body", "body.drum")
    x_back, x_front, y, z, r = spec.drum_bounds_m()
    np.testing.assert_allclose(drum.bounds, [[x_back, y - r, z - r], [x_front, y + r, z + r]], atol=TOL_M)
    # The door's centre is on the hole's axis.
    centre = model.world_from_links()["door_0"] @ np.array([0, door.width_m / 2, door.height_m / 2, 1])
    np.testing.assert_allclose(
        centre[1:3], [-spec.width_m / 2 + panel.hole.centre_left_m, panel.hole.centre_height_m], atol=TOL_M
    )
    assert model.joint("knob_0_turn").states[0].name == "off"


@pytest.mark.bpy
def test_wall_cabinet_hangs_and_its_flap_opens_up(catalogue) -> None:
    spec, model, _ = catalogue["wall_cabinet"]
    assert _vertices(model, "body")[:, 2].min() == pytest.approx(spec.mount_height_m, abs=TOL_M)
    flap = spec.doors[1]
    assert flap.hinge == "top"
    opened = _vertices(model, "door_1", {"door_1_hinge": math.pi / 2}, skip=("door_1_handle",))
    assert opened[:, 2].max() == pytest.approx(flap.top_m, abs=TOL_M)
    assert opened[:, 2].min() == pytest.approx(flap.top_m - spec.door_thickness_m, abs=TOL_M)
    assert model.world_from_grasp_points({"door_1_hinge": math.pi / 2})["door_1_handle"][2, 3] > flap.top_m - 0.05


@pytest.mark.bpy
def test_wardrobe_rail_dishwasher_racks_microwave_plate(catalogue) -> None:
    spec, model, _ = catalogue["wardrobe"]
    rail = _visual(model, "body", "body.rail_0")
    left, right, x = spec.rail_span_m(spec.rails[0])
    np.testing.assert_allclose(rail.bounds[:, 1], [-spec.width_m / 2 + left, -spec.width_m / 2 + right], atol=TOL_M)
    assert rail.bounds.mean(0)[[0, 2]] == pytest.approx([x, spec.rails[0].height_m], abs=TOL_M)

    spec, model, _ = catalogue["dishwasher"]
    for i, rack in enumerate(spec.racks):
        mesh = _visual(model, "body", f"body.rack_{i}")
        np.testing.assert_allclose(mesh.bounds.T.reshape(-1), spec.rack_bounds_m(rack), atol=TOL_M)
    assert spec.doors[0].hinge == "bottom"

    spec, model, _ = catalogue["microwave"]
    plate = _visual(model, "body", "body.turntable")
    left, right = spec.cavity_span_m()
    assert plate.extents[0] == pytest.approx(spec.turntable_diameter_m, abs=TOL_M)
    assert -spec.width_m / 2 + left <= plate.bounds[0, 1] and plate.bounds[1, 1] <= -spec.width_m / 2 + right
    assert plate.bounds[0, 2] == pytest.approx(spec.inner_floor_m, abs=TOL_M)


# ---------------------------------------------------------------------------- refusals

# (example, dotted field, value, dotted field the error must name, words in the message)
REFUSALS = [
    ("cupboard", "shelves.0.width_m", 1.0, "shelves.0.width_m", "cuts through divider 0"),
    ("cupboard", "drawers.1.handle.recess_depth_m", 0.02, "drawers.1.handle.recess_depth_m", "goes through"),
    ("cupboard", "doors.0.handle.type", "lever", "doors.0.handle.type", "'bar', 'knob', 'recessed', 'none' or 'channel'"),
    ("cupboard", "dividers.0.left_m", 1.19, "dividers.0.left_m", "not between the side walls"),
    ("cupboard", "doors.1.left_m", 0.3, "doors.1", "door 1 overlaps door 0"),
    ("wall_cabinet", "plinth_height_m", 0.1, "plinth_height_m", "has no plinth"),
    ("wall_cabinet", "doors.0.bottom_m", 1.2, "doors.0.bottom_m", "below the wall cabinet"),
    ("wall_cabinet", "doors.1.handle.height_m", 0.1, "doors.1.handle.height_m", "placed by from_left_m"),
    ("wardrobe", "rails.0.width_m", 1.2, "rails.0.width_m", "runs through divider 0"),
    ("wardrobe", "rails.0.height_m", 1.84, "rails.0.height_m", "runs through shelf 0"),
    ("fridge_two_doors", "doors.0.shelves.0.margin_m", 0.0, "doors.0.shelves.0.margin_m", "side walls"),
    ("fridge_two_doors", "doors.0.shelves.1.height_m", 1.75, "doors.0.shelves.1.height_m", "up a 1.774 m high door"),
    ("fridge", "freezer_fraction", 0.9, "freezer_fraction", "less than 0.8"),
    ("oven", "knobs.0.left_m", 0.7, "knobs.0.left_m", "off every panel"),
    ("oven", "knobs.0.height_m", 0.5, "knobs.0.left_m", "off every panel"),
    ("oven", "knobs.1.left_m", 0.1, "knobs.1.left_m", "knob 1 overlaps knob 0"),
    ("oven", "knobs.0.states", ["off", "1", "off"], "knobs.0.states", "repeat"),
    ("oven", "knobs.0.step_deg", 60, "knobs.0.step_deg", "more than once round"),
    ("oven", "hob.burners.0.from_left_m", 0.05, "hob.burners.0.from_left_m", "overhangs"),
    ("oven", "drawers.0.depth_m", 0.59, "drawers.0.depth_m", "deep inside"),
    ("oven", "drawers.0.travel_m", 0.5, "drawers.0.travel_m", "only 0.45 m deep"),
    ("oven", "doors.0.handle.height_m", 0.3, "doors.0.handle.height_m", "placed by from_left_m"),
    ("oven", "doors.0.window.margin_m", 0.4, "doors.0.window.margin_m", "leaves no glass"),
    ("oven", "doors.0.handle.from_free_edge_m", 0.7, "doors.0.handle.from_free_edge_m", "bar handle spans"),
    ("dishwasher", "racks", [{"bottom_m": 0.2}, {"bottom_m": 0.3}], "racks.1.bottom_m", "rack 1 overlaps rack 0"),
    ("dishwasher", "racks", [{"bottom_m": 0.75}], "racks.0.bottom_m", "not inside the body"),
    ("washing_machine", "drum.depth_m", 0.6, "drum.depth_m", "goes through the back wall"),
    ("washing_machine", "drum.diameter_m", 0.3, "drum.diameter_m", "smaller than its"),
    ("microwave", "turntable_diameter_m", 0.4, "turntable_diameter_m", "does not fit"),
    ("microwave", "width_m", 0.1, "(top level)", "standard microwave layout does not fit this size"),
]


@pytest.mark.parametrize(("example", "field", "value", "blamed", "words"), REFUSALS)
def test_impossible_spec_is_refused_naming_file_and_field(
    tmp_path: Path, catalogue_dir: Path, example: str, field: str, value: object, blamed: str, words: str
) -> None:
    data = read_spec(catalogue_dir / f"{example}.yaml")
    path = write_spec(tmp_path, with_field(data, field, value), f"{example}.yaml")
    with pytest.raises(SpecError) as caught:
        load_spec(path)
    message = str(caught.value)
    assert message.startswith(f"{path}: {blamed}: "), message
    assert words in message, message
    assert "\n" not in message


@pytest.mark.parametrize(
    ("spec", "blamed", "words"),
    [
        (
            {
                "kind": "washing_machine",
                "doors": [
                    {"hinge": "left", "shape": "round", "left_m": 0.1, "width_m": 0.4, "height_m": 0.3, "bottom_m": 0.1}
                ],
            },
            "doors.0.height_m",
            "a round door is 0.4 m wide",
        ),
        (
            {
                "kind": "fridge",
                "doors": [
                    {
                        "hinge": "bottom",
                        "left_m": 0,
                        "width_m": 0.6,
                        "height_m": 1.0,
                        "bottom_m": 0.6,
                        "shelves": [{"height_m": 0.2}],
                    }
                ],
            },
            "doors.0.shelves.0",
            "need a side-hinged door",
        ),
        (
            {
                "kind": "fridge",
                "freezer_fraction": 0,
                "shelves": [{"height_m": 0.8}],
                "doors": [
                    {
                        "hinge": "right",
                        "left_m": 0.003,
                        "width_m": 0.594,
                        "bottom_m": 0.003,
                        "height_m": 1.794,
                        "shelves": [{"height_m": 0.75}],
                    }
                ],
            },
            "doors.0.shelves.0.depth_m",
            "runs into shelf 0 when the door is closed",
        ),
        (
            {
                "kind": "microwave",
                "panels": [
                    {
                        "left_m": 0.38,
                        "width_m": 0.12,
                        "bottom_m": 0,
                        "height_m": 0.3,
                        "hole": {"centre_left_m": 0.44, "centre_height_m": 0.15, "diameter_m": 0.2},
                    }
                ],
            },
            "panels.0.hole",
            "not inside its panel",
        ),
        (
            {
                "kind": "cupboard",
                "drawers": [
                    {"left_m": 0, "width_m": 0.8, "bottom_m": 0.5, "height_m": 0.2, "depth_m": 0.3, "travel_m": 0.2}
                ],
            },
            "drawers.0",
            "drawer 0 overlaps door 0",
        ),
    ],
)
def test_inconsistent_layouts_are_refused(tmp_path: Path, spec: dict, blamed: str, words: str) -> None:
    path = tmp_path / "spec.yaml"
    path.write_text(json.dumps(spec))
    with pytest.raises(SpecError) as caught:
        load_spec(path)
    assert str(caught.value).startswith(f"{path}: {blamed}: "), str(caught.value)
    assert words in str(caught.value)


def test_schemas_describe_every_field(tmp_path: Path) -> None:
    write_spec_schemas(tmp_path)
    oven = json.loads((tmp_path / "oven.schema.json").read_text())
    assert {"hob", "knobs", "doors", "panels", "drawers"} <= set(oven["properties"])
    door = oven["$defs"]["DoorSpec"]["properties"]
    assert set(door["hinge"]["enum"]) == {"left", "right", "top", "bottom"}
    for kind in KINDS:
        assert (tmp_path / f"{kind}.schema.json").is_file()
    knob = oven["$defs"]["ControlKnob"]["properties"]
    assert "above the floor" in knob["height_m"]["description"]
