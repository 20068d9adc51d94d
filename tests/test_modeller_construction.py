"""How real furniture is built: open tops, back panels, face frames, drawer boxes on runners,
panels set back or out, handleless fronts, push buttons, a raised turning microwave plate,
worktops with cut-outs and runs of units under them (examples/catalogue, examples/kitchen_run)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from spec_edits import read_spec, with_field, write_spec

from homemodel.core.errors import SpecError
from modeller.spec_loading import load_spec
from modeller.specs.cabinet_geometry import drawer_box_bounds_m

REPO = Path(__file__).resolve().parents[1]
CATALOGUE = REPO / "examples" / "catalogue"
NEW_EXAMPLES = ["base_unit_inset", "cupboard_face_frame", "wall_cabinet_handleless", "microwave_release_button", "worktop"]


def _collision(model, link: str, name: str):
    return next(c for c in model.link(link).collisions if c.name == name)


@pytest.mark.bpy
@pytest.mark.parametrize("name", NEW_EXAMPLES)
def test_new_catalogue_examples_pass_the_gate(catalogue, name: str) -> None:
    report = catalogue[name].report
    assert report.ok, report.format()


@pytest.mark.bpy
def test_base_unit_has_no_top_and_its_back_panel_set_in(catalogue) -> None:
    spec, model, _ = catalogue["base_unit_inset"]
    names = {c.name for c in model.link("body").collisions}
    assert "carcass_top" not in names and "carcass_back" not in names and "carcass_bottom" in names
    back = _collision(model, "body", "back_panel")
    x = back.link_from_collision[0, 3]
    # Its back face 20 mm in from the sides' back edges, 8 mm thick (EN 1116 carcass, 3..8 mm backs).
    assert x - back.geometry.size_m[0] / 2 == pytest.approx(-spec.depth_m / 2 + 0.02)
    assert back.geometry.size_m[0] == pytest.approx(0.008)
    # Nothing of the body is above its sides' top edges, and the shelf stops behind the inset doors.
    assert model.world_mesh({}).bounds[1][2] == pytest.approx(spec.height_m, abs=1e-4)
    shelf = _collision(model, "body", "shelf_0")
    assert shelf.link_from_collision[0, 3] + shelf.geometry.size_m[0] / 2 <= spec.depth_m / 2 - 0.018 - 0.002 + 1e-9


@pytest.mark.bpy
def test_inset_doors_close_flush_with_the_carcass_front(catalogue) -> None:
    spec, model, _ = catalogue["base_unit_inset"]
    for k in range(2):
        lo, hi = np.min(_door_points(model, f"door_{k}"), 0), np.max(_door_points(model, f"door_{k}"), 0)
        assert hi[0] == pytest.approx(spec.depth_m / 2, abs=1e-6)
        assert lo[0] == pytest.approx(spec.depth_m / 2 - spec.door_thickness_m, abs=1e-6)


def _door_points(model, link: str) -> np.ndarray:
    world = model.world_from_links({})[link]
    visual = next(v for v in model.link(link).visuals if v.name == link)
    return (world @ visual.link_from_visual @ np.c_[visual.mesh.vertices, np.ones(len(visual.mesh.vertices))].T).T[:, :3]


@pytest.mark.bpy
def test_face_frame_round_the_opening_and_the_drawer_box_on_its_runners(catalogue) -> None:
    spec, model, _ = catalogue["cupboard_face_frame"]
    # Each panel its own thickness: 16 mm sides, 19 mm top and bottom, a 4 mm back.
    assert _collision(model, "body", "carcass_left").geometry.size_m[1] == pytest.approx(0.016)
    for board in ("carcass_top", "carcass_bottom"):
        assert _collision(model, "body", board).geometry.size_m[2] == pytest.approx(0.019)
    assert _collision(model, "body", "back_panel").geometry.size_m[0] == pytest.approx(0.004)
    assert spec.inner_floor_m == pytest.approx(0.1 + 0.019)
    stile = _collision(model, "body", "frame_left")
    assert stile.geometry.size_m[:2] == pytest.approx((0.019, 0.038))
    assert stile.link_from_collision[0, 3] + 0.019 / 2 == pytest.approx(spec.depth_m / 2)
    drawer = spec.drawers[0]
    y0, y1, z0, z1 = drawer_box_bounds_m(spec, drawer)
    # Inside the frame's stiles with 12.5 mm for the runners each side; 120 mm high sides.
    assert y0 == pytest.approx(-spec.width_m / 2 + 0.038 + 0.0125)
    assert y1 == pytest.approx(spec.width_m / 2 - 0.038 - 0.0125)
    assert z1 - z0 == pytest.approx(0.12)
    box = next(v for v in model.link("drawer_0").visuals if v.name == "drawer_0.box")
    assert np.ptp(box.mesh.vertices, axis=0) == pytest.approx((drawer.depth_m, y1 - y0, 0.12), abs=1e-6)


@pytest.mark.bpy
def test_handleless_doors_have_a_push_point_and_no_handle(catalogue) -> None:
    _, model, _ = catalogue["wall_cabinet_handleless"]
    assert not any(link.name.endswith("_handle") for link in model.links)
    pushes = {g.name: g for g in model.grasp_points if g.kind == "push"}
    assert set(pushes) == {"door_0_push", "door_1_push"}
    assert pushes["door_0_push"].link == "door_0"


@pytest.mark.bpy
def test_microwave_release_button_presses_in_and_the_raised_plate_turns(catalogue) -> None:
    spec, model, _ = catalogue["microwave_release_button"]
    press = model.joint("button_0_press")
    assert press.type == "prismatic" and np.allclose(press.axis, (-1, 0, 0))
    assert press.limits.upper == pytest.approx(0.005)
    assert any(g.kind == "button" and g.link == "button_0" for g in model.grasp_points)
    spin = model.joint("turntable_spin")
    assert spin.type == "continuous" and np.allclose(spin.axis, (0, 0, 1))
    assert spin.parent_from_joint[2, 3] == pytest.approx(spec.inner_floor_m + 0.012)
    turned = model.world_from_links({"turntable_spin": 1.0})["turntable"]
    assert np.allclose(turned[:3, 3], spin.parent_from_joint[:3, 3])  # it turns about its centre
    assert "turntable" not in {c.name for c in model.link("body").collisions}
    assert "turntable_coupler" in {c.name for c in model.link("body").collisions}


@pytest.mark.bpy
def test_worktop_slab_has_its_cutouts_and_the_sink_its_basin(catalogue) -> None:
    spec, model, _ = catalogue["worktop"]
    slab = [c for c in model.link("body").collisions if c.name.startswith("slab_")]
    area = sum(c.geometry.size_m[0] * c.geometry.size_m[1] for c in slab)
    holes = sum(c.width_m * c.depth_m for c in spec.cutouts)
    assert area == pytest.approx(spec.width_m * spec.depth_m - holes)
    # A point in the middle of each cut-out is in no slab box; the slab's top is the surface.
    for cut in spec.cutouts:
        x0, x1, y0, y1 = spec.cutout_box_m(cut)
        centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
        for c in slab:
            half = np.array(c.geometry.size_m[:2]) / 2
            assert np.any(np.abs(centre - c.link_from_collision[:2, 3]) >= half)
    lo, hi = model.world_mesh().bounds
    assert hi[2] == pytest.approx(0.9) and lo[2] == pytest.approx(0.9 - 0.18)
    assert model.properties["surface_heights_m"] == "0.9"


@pytest.mark.bpy
def test_run_of_units_stands_side_by_side_under_its_worktop(tmp_path: Path) -> None:
    from homemodel.app.home.build import build_home
    from homemodel.exchange.map_xml import load_map

    result = build_home(REPO / "examples" / "kitchen_run", tmp_path / "out")
    assert result.ok
    smap = load_map(tmp_path / "out" / "map.xml")
    xyz = {i: smap.node(i).world_from_object.xyz for i in ("sink_unit", "drawer_unit", "worktop_1")}
    # The wall is x = 0, the run starts at y = 1.0: 0.6 m then 0.5 m units, backs to the wall.
    assert xyz["sink_unit"] == pytest.approx((0.28, 1.3, 0.0))
    assert xyz["drawer_unit"] == pytest.approx((0.29, 1.85, 0.0))
    assert xyz["worktop_1"] == pytest.approx((0.3, 1.55, 0.0))


def test_run_refuses_a_unit_taller_than_the_worktop_underside(tmp_path: Path) -> None:
    from homemodel.app.home.build import build_home

    folder = tmp_path / "run"
    folder.mkdir()
    for name in ("sink_unit", "drawer_unit", "worktop"):
        (folder / f"{name}.yaml").write_text((REPO / "examples" / "kitchen_run" / f"{name}.yaml").read_text())
    (folder / "home.yaml").write_text((REPO / "examples" / "kitchen_run" / "home.yaml").read_text())
    write_spec(folder, with_field(read_spec(folder / "worktop.yaml"), "height_m", 0.89), "worktop.yaml")
    with pytest.raises(SpecError, match=r"rooms\.0\.runs\.0\.units\.0: the unit's top at 0\.870 m is above"):
        build_home(folder, tmp_path / "out")
    (folder / "drawer_unit.yaml").write_text((REPO / "examples" / "kitchen" / "table.yaml").read_text())
    with pytest.raises(SpecError, match=r"rooms\.0\.runs\.0\.units\.1\.spec: a table is not a unit"):
        build_home(folder, tmp_path / "out")


# One case per new rule: (example, dotted field, value, dotted field the error must name, words).
REFUSALS = [
    ("cupboard_face_frame", "doors.0.opening_limit_deg", 120, "doors.0.opening_limit_deg", "does not open to 120"),
    ("cupboard_face_frame", "doors.0.concealed.cup_diameter_m", 0.5, "doors.0.concealed.cup_diameter_m", "cup reaches"),
    ("wall_cabinet_handleless", "doors.0.hinge_line", {"behind_face_m": 0.02, "in_from_edge_m": 0.0}, "doors.0.hinge_measured", "not both"),
    ("wall_cabinet_handleless", "doors.0.hinge_measured", {}, "doors.0.hinge_measured", "give open_at_90 or free_corner"),
    ("base_unit_inset", "doors.1.bottom_m", 0.1, "doors.1.bottom_m", "the opening is"),
    ("microwave_release_button", "buttons.0.left_m", 0.2, "buttons.0.left_m", "off every panel"),
    ("microwave_release_button", "buttons.0.travel_m", 0.008, "buttons.0.travel_m", "cannot press in"),
    ("microwave_release_button", "turntable_raise_m", 0.25, "turntable_raise_m", "cavity's top"),
    ("worktop", "cutouts.1.left_m", 1.3, "cutouts.1.left_m", "runs off the slab"),
    ("worktop", "cutouts.1.left_m", 0.5, "cutouts.1", "meets cut-out 0"),
]


@pytest.mark.parametrize(("example", "field", "value", "blamed", "words"), REFUSALS)
def test_impossible_construction_is_refused_naming_the_field(
    tmp_path: Path, example: str, field: str, value: object, blamed: str, words: str
) -> None:
    path = write_spec(tmp_path, with_field(read_spec(CATALOGUE / f"{example}.yaml"), field, value))
    with pytest.raises(SpecError) as refused:
        load_spec(path)
    message = str(refused.value)
    assert f"{path.name}: {blamed}:" in message and words in message, message


def test_a_panel_standing_out_into_a_closed_door_is_refused(tmp_path: Path) -> None:
    data = read_spec(CATALOGUE / "oven.yaml")
    data = {**data, "panels": [{"left_m": 0.0, "width_m": 0.6, "bottom_m": 0.2, "height_m": 0.5, "forward_m": 0.01}]}
    data.pop("knobs", None)
    with pytest.raises(SpecError, match=r"panels\.0\.forward_m: panel stands 0\.01 m out, into door 0"):
        load_spec(write_spec(tmp_path, data))


@pytest.mark.bpy
def test_inset_drawer_front_closes_flush_and_slides_clear(tmp_path: Path) -> None:
    from homemodel.exchange.model_files import export_model
    from homemodel.model_folder.gate.validate import validate_path
    from modeller import build_model

    data = read_spec(CATALOGUE / "base_unit_inset.yaml")
    door = {**data["doors"][0], "width_m": 0.56, "height_m": 0.55, "handle": {"type": "knob", "height_m": 0.5}}
    drawer = {"mounting": "inset", "left_m": 0.02, "width_m": 0.56, "bottom_m": 0.674, "height_m": 0.194,
              "depth_m": 0.45, "travel_m": 0.4, "runner_clearance_m": 0.0125, "box_height_m": 0.12}
    path = write_spec(tmp_path, {**data, "doors": [door], "drawers": [drawer]})
    spec = load_spec(path)
    model = build_model(path)
    front = _door_points(model, "drawer_0")
    assert front[:, 0].max() == pytest.approx(spec.depth_m / 2, abs=1e-6)
    assert front[:, 0].min() == pytest.approx(spec.depth_m / 2 - spec.door_thickness_m, abs=1e-6)
    export_model(model, tmp_path / "model")
    report = validate_path(tmp_path / "model")
    assert report.ok, report.format()


@pytest.mark.bpy
def test_inset_door_in_a_face_frame_clears_the_frame(tmp_path: Path) -> None:
    from homemodel.exchange.model_files import export_model
    from homemodel.model_folder.gate.validate import validate_path
    from modeller import build_model

    # A 38 mm frame round a single inset door 2 mm clear of it all round, on butt hinges.
    data = read_spec(CATALOGUE / "base_unit_inset.yaml")
    data["face_frame"] = {"width_m": 0.038, "thickness_m": 0.019}
    door = {"hinge": "left", "mounting": "inset", "left_m": 0.04, "width_m": 0.52, "bottom_m": 0.14,
            "height_m": 0.69, "opening_limit_deg": 110, "handle": {"type": "none"}}
    data["doors"] = [door]
    path = write_spec(tmp_path, data)
    assert load_spec(path).face_frame.width_m == 0.038
    export_model(build_model(path), tmp_path / "model")
    report = validate_path(tmp_path / "model")
    assert report.ok, report.format()
    # The same door moved 4 mm left, into the frame's stile, is refused.
    with pytest.raises(SpecError, match=r"doors\.0\.left_m: inset door spans 0\.036"):
        load_spec(write_spec(tmp_path, with_field(data, "doors.0.left_m", 0.036), "wide.yaml"))


@pytest.mark.bpy
def test_worktop_defaults_build_to_their_size() -> None:
    from modeller import build_from_spec
    from modeller.kinds import SPEC_TYPES

    spec = SPEC_TYPES["worktop"].model_validate({"kind": "worktop"})
    lo, hi = build_from_spec(spec, "worktop").world_mesh().bounds
    half = np.array([spec.depth_m / 2, spec.width_m / 2])
    np.testing.assert_allclose(lo, (*-half, spec.height_m - spec.thickness_m), atol=1e-6)
    np.testing.assert_allclose(hi, (*half, spec.height_m), atol=1e-6)


@pytest.mark.bpy
def test_grip_channel_fronts_are_grasped_over_their_top_edge(tmp_path: Path) -> None:
    from modeller import build_model

    data = read_spec(CATALOGUE / "cupboard_face_frame.yaml")
    data = with_field(data, "drawers.0.handle", {"type": "channel"})
    data = with_field(data, "doors.0.handle", {"type": "channel", "from_free_edge_m": 0.05})
    model = build_model(write_spec(tmp_path, data))
    spec = load_spec(write_spec(tmp_path, data))
    assert not any(link.name.endswith("_handle") for link in model.links)
    grips = model.world_from_grasp_points({})
    drawer, door = spec.drawers[0], spec.doors[0]
    front_x = spec.depth_m / 2 + spec.door_gap_m + spec.door_thickness_m
    # On the outer face's top edge, the hand coming down (x of the grasp frame is -z).
    assert grips["drawer_0_grip"][:3, 3] == pytest.approx((front_x, 0.0, drawer.top_m))
    assert grips["drawer_0_grip"][:3, 0] == pytest.approx((0, 0, -1))
    assert grips["door_0_grip"][:3, 3] == pytest.approx((front_x, -spec.width_m / 2 + door.left_m + 0.05, door.top_m))
    with pytest.raises(SpecError, match=r"doors\.0\.handle\.type: a grip channel is over a side-hinged door"):
        load_spec(write_spec(tmp_path, with_field(read_spec(CATALOGUE / "oven.yaml"), "doors.0.handle", {"type": "channel"})))
