"""modeller: spec checking, and models built in Blender checked against their measurements."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np
import pytest
from spec_edits import read_spec, with_field, write_spec

from homemodel.core.errors import SpecError
from homemodel.core.transforms import transform_points
from modeller import build_model, load_spec, write_spec_schemas

TOL_M = 1e-3


def _world_vertices(model, link: str, positions: dict[str, float] | None = None) -> np.ndarray:
    world_from_link = model.world_from_links(positions)[link]
    return np.vstack(
        [transform_points(world_from_link @ v.link_from_visual, v.mesh.vertices) for v in model.link(link).visuals]
    )


# ---------------------------------------------------------------------------- specs


@pytest.mark.parametrize("name", ["cupboard", "table", "red_cup", "blue_cup"])
def test_examples_are_valid_specs(kitchen_dir: Path, name: str) -> None:
    path = kitchen_dir / f"{name}.yaml"
    assert load_spec(path).kind == read_spec(path)["kind"]


# One case per rule: (example, dotted field, value, dotted field the error must name, words in the message).
REFUSALS = [
    ("cupboard", "doors.0.width_m", 0.9, "doors.0.width_m", "door is 0.9 m wide but the cupboard is 0.8 m"),
    ("cupboard", "doors.1.left_m", 0.5, "doors.1.left_m", "from the left edge"),
    ("cupboard", "doors.0.height_m", 1.2, "doors.0.height_m", "high but the cupboard is 0.9 m"),
    ("cupboard", "doors.0.bottom_m", 0.5, "doors.0.bottom_m", "reaches"),
    ("cupboard", "doors.1.left_m", 0.3, "doors.1", "door 1 overlaps door 0"),
    ("cupboard", "drawers.0.bottom_m", 0.7, "drawers.0", "drawer 0 overlaps door"),
    ("cupboard", "drawers.0.depth_m", 0.44, "drawers.0.depth_m", "deep inside"),
    ("cupboard", "drawers.0.travel_m", 0.42, "drawers.0.travel_m", "only 0.4 m deep"),
    ("cupboard", "doors.0.handle.height_m", 0.6, "doors.0.handle.height_m", "bar handle spans"),
    ("cupboard", "doors.0.handle.from_free_edge_m", 0.5, "doors.0.handle.from_free_edge_m", "bar handle spans"),
    ("cupboard", "drawers.0.handle.from_left_m", 0.05, "drawers.0.handle.from_left_m", "bar handle spans"),
    ("cupboard", "doors.0.handle.standoff_m", 0.005, "doors.0.handle.standoff_m", "inside the front"),
    ("cupboard", "doors.0.handle.length_m", 0.02, "doors.0.handle.length_m", "too short"),
    ("cupboard", "width_m", -0.8, "width_m", "greater than 0"),
    ("cupboard", "doors.0.height_m", 0, "doors.0.height_m", "greater than 0"),
    ("cupboard", "wall_thickness_m", 0.45, "wall_thickness_m", "leave no room"),
    ("cupboard", "plinth_height_m", 0.88, "plinth_height_m", "leave no room"),
    ("cupboard", "shelves.0.height_m", 0.95, "shelves.0.height_m", "above the body's inside top"),
    ("cupboard", "shelves.0.height_m", 0.11, "shelves.0.height_m", "below the body's inside floor"),
    ("cupboard", "shelves.0.height_m", 0.8, "shelves.0.height_m", "cuts through drawer 0's box"),
    ("cupboard", "doors.0.opening_limit_deg", 200, "doors.0.opening_limit_deg", "less than or equal to 180"),
    ("cupboard", "doors.0.hinge", "middle", "doors.0.hinge", "'left', 'right', 'top' or 'bottom'"),
    ("cupboard", "widht_m", 0.8, "widht_m", "Extra inputs are not permitted"),
    ("cupboard", "colour", "mauve", "colour", "unknown colour 'mauve'"),
    ("cupboard", "density_kg_m3", 600, "mass_kg", "not both"),
    ("table", "top.thickness_m", 0.8, "top.thickness_m", "on a table 0.75 m high"),
    ("table", "legs.inset_m", 0.38, "legs.inset_m", "do not fit"),
    ("table", "legs.diameter_m", 0.05, "legs.diameter_m", "not both"),
    ("red_cup", "wall_thickness_m", 0.041, "wall_thickness_m", "fills a cup 0.082 m across"),
    ("red_cup", "bottom_thickness_m", 0.1, "bottom_thickness_m", "fills a cup 0.095 m high"),
    ("red_cup", "handle.height_m", 0.08, "handle.height_m", "on a cup 0.095 m high"),
    ("red_cup", "handle.span_m", 0.006, "handle.span_m", "leaves no hole"),
]


@pytest.mark.parametrize(("example", "field", "value", "blamed", "words"), REFUSALS)
def test_impossible_spec_is_refused_naming_file_and_field(
    tmp_path: Path, kitchen_dir: Path, example: str, field: str, value: object, blamed: str, words: str
) -> None:
    path = write_spec(tmp_path, with_field(read_spec(kitchen_dir / f"{example}.yaml"), field, value))
    with pytest.raises(SpecError) as caught:
        load_spec(path)
    message = str(caught.value)
    assert message.startswith(f"{path}: {blamed}: "), message
    assert words in message
    assert "\n" not in message


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("kind: cupboard\nwidth_m: [0.8\n", "invalid YAML at line"),
        ("- 1\n- 2\n", "expected a mapping"),
        ("width_m: 0.8\n", "kind: missing"),
        ("kind: spaceship\n", "kind: unknown kind 'spaceship'"),
    ],
)
def test_unreadable_spec_is_one_line(tmp_path: Path, text: str, words: str) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(SpecError, match=words) as caught:
        load_spec(path)
    assert str(caught.value).startswith(f"{path}: ") and "\n" not in str(caught.value)


def test_missing_spec_file(tmp_path: Path) -> None:
    with pytest.raises(SpecError, match="no such file"):
        load_spec(tmp_path / "nothing.yaml")


def test_spec_schemas_are_written(tmp_path: Path) -> None:
    paths = write_spec_schemas(tmp_path / "schemas")
    assert {"cup.schema.json", "cupboard.schema.json", "table.schema.json", "oven.schema.json"} <= {
        p.name for p in paths
    }
    schema = json.loads((tmp_path / "schemas" / "cupboard.schema.json").read_text())
    assert {"width_m", "doors", "drawers", "shelves"} <= set(schema["properties"])


# ---------------------------------------------------------------------------- cupboard


@pytest.fixture(scope="module")
def cupboard(kitchen_dir: Path):
    return load_spec(kitchen_dir / "cupboard.yaml"), build_model(kitchen_dir / "cupboard.yaml")


@pytest.mark.bpy
def test_cupboard_body_has_the_measured_size(cupboard) -> None:
    spec, model = cupboard
    lo, hi = _world_vertices(model, "body").min(0), _world_vertices(model, "body").max(0)
    expected_lo = [-spec.depth_m / 2, -spec.width_m / 2, 0.0]
    expected_hi = [spec.depth_m / 2, spec.width_m / 2, spec.height_m]
    np.testing.assert_allclose(lo, expected_lo, atol=TOL_M)
    np.testing.assert_allclose(hi, expected_hi, atol=TOL_M)
    # Walls: the carcass is open at the front and hollow behind it, walls as thick as measured.
    carcass = next(v.mesh for v in model.link("body").visuals if v.name == "body")
    assert carcass.is_volume
    t = spec.wall_thickness_m
    inner = (spec.depth_m - t) * (spec.width_m - 2 * t) * (spec.height_m - spec.plinth_height_m - 2 * t)
    outer = spec.depth_m * spec.width_m * (spec.height_m - spec.plinth_height_m)
    assert carcass.volume == pytest.approx(outer - inner, rel=1e-4)
    # Each shelf's top surface at its measured height.
    for i, shelf in enumerate(spec.shelves):
        mesh = next(v.mesh for v in model.link("body").visuals if v.name == f"body.shelf_{i}")
        assert mesh.bounds[1, 2] == pytest.approx(shelf.height_m, abs=TOL_M)


@pytest.mark.bpy
def test_cupboard_doors_and_hinges_where_measured(cupboard) -> None:
    spec, model = cupboard
    front_x = spec.depth_m / 2 + spec.door_gap_m + spec.door_thickness_m
    for i, door in enumerate(spec.doors):
        vertices = _world_vertices(model, f"door_{i}")
        left_y = -spec.width_m / 2 + door.left_m  # seen from in front, the left is -y
        np.testing.assert_allclose(vertices[:, 1].min(), left_y, atol=TOL_M)
        np.testing.assert_allclose(vertices[:, 1].max(), left_y + door.width_m, atol=TOL_M)
        np.testing.assert_allclose(vertices[:, 2].min(), door.bottom_m, atol=TOL_M)
        np.testing.assert_allclose(vertices[:, 2].max(), door.bottom_m + door.height_m, atol=TOL_M)
        np.testing.assert_allclose(vertices[:, 0].max(), front_x, atol=TOL_M)

        hinge = model.joint(f"door_{i}_hinge")
        assert hinge.type == "revolute" and hinge.parent == "body"
        hinge_y = left_y if door.hinge == "left" else left_y + door.width_m
        np.testing.assert_allclose(hinge.parent_from_joint[:2, 3], [front_x, hinge_y], atol=TOL_M)
        np.testing.assert_allclose(np.abs(hinge.axis), [0, 0, 1])
        assert hinge.limits.lower == 0.0
        assert hinge.limits.upper == pytest.approx(math.radians(door.opening_limit_deg))


@pytest.mark.bpy
def test_cupboard_doors_open_outward_and_never_into_the_body(cupboard) -> None:
    spec, model = cupboard
    assert {d.hinge for d in spec.doors} == {"left", "right"}
    for i, door in enumerate(spec.doors):
        joint = f"door_{i}_hinge"
        closed = _world_vertices(model, f"door_{i}")
        free_y = closed[:, 1].max() if door.hinge == "left" else closed[:, 1].min()
        free_edge = np.abs(closed[:, 1] - free_y) < 1e-6
        at_60 = _world_vertices(model, f"door_{i}", {joint: math.radians(60)})
        assert at_60[free_edge, 0].min() > spec.depth_m / 2 + 0.5 * door.width_m
        # Past the hinge line the door swings outside the body's side, never into it.
        for angle in np.linspace(0, model.joint(joint).limits.upper, 7):
            vertices = _world_vertices(model, f"door_{i}", {joint: angle})
            assert vertices[:, 0].min() >= spec.depth_m / 2 + spec.door_gap_m - 1e-9


@pytest.mark.bpy
def test_cupboard_drawer_slides_out_by_its_travel(cupboard) -> None:
    spec, model = cupboard
    drawer = spec.drawers[0]
    slide = model.joint("drawer_0_slide")
    assert slide.type == "prismatic" and slide.limits.upper == pytest.approx(drawer.travel_m)
    closed = _world_vertices(model, "drawer_0")
    opened = _world_vertices(model, "drawer_0", {"drawer_0_slide": drawer.travel_m})
    np.testing.assert_allclose(opened - closed, np.tile([drawer.travel_m, 0, 0], (len(closed), 1)), atol=1e-9)
    # Closed, the box sits inside the body, in front of the back wall.
    assert closed[:, 0].min() >= -spec.depth_m / 2 + spec.wall_thickness_m - 1e-9
    handle_closed = model.world_from_grasp_points()["drawer_0_handle"][:3, 3]
    handle_open = model.world_from_grasp_points({"drawer_0_slide": drawer.travel_m})["drawer_0_handle"][:3, 3]
    np.testing.assert_allclose(handle_open - handle_closed, [drawer.travel_m, 0, 0], atol=1e-9)


@pytest.mark.bpy
def test_cupboard_handle_grasp_points_at_the_measured_places(cupboard) -> None:
    spec, model = cupboard
    front_x = spec.depth_m / 2 + spec.door_gap_m + spec.door_thickness_m
    grasps = model.world_from_grasp_points()
    assert {g.kind for g in model.grasp_points} == {"handle"}
    for i, door in enumerate(spec.doors):
        left_y = -spec.width_m / 2 + door.left_m
        free_y = left_y + door.width_m if door.hinge == "left" else left_y
        towards_hinge = -1.0 if door.hinge == "left" else 1.0
        expected = [
            front_x + door.handle.standoff_m,
            free_y + towards_hinge * door.handle.from_free_edge_m,
            door.bottom_m + door.handle.height_m,
        ]
        frame = grasps[f"door_{i}_handle"]
        np.testing.assert_allclose(frame[:3, 3], expected, atol=TOL_M)
        np.testing.assert_allclose(frame[:3, 0], [-1, 0, 0], atol=1e-9)  # approach towards the door
        np.testing.assert_allclose(frame[:3, 2], [0, 0, 1], atol=1e-9)  # along the vertical bar
        bar = _world_vertices(model, f"door_{i}_handle")
        assert bar[:, 2].max() - bar[:, 2].min() == pytest.approx(door.handle.length_m, abs=TOL_M)
        assert bar[:, 0].min() == pytest.approx(front_x, abs=TOL_M)  # posts reach the door
        assert model.joint(f"door_{i}_handle_mount").type == "fixed"
    drawer = spec.drawers[0]
    expected = [
        front_x + drawer.handle.standoff_m,
        -spec.width_m / 2 + drawer.left_m + drawer.width_m / 2,
        drawer.bottom_m + drawer.height_m / 2,
    ]
    np.testing.assert_allclose(grasps["drawer_0_handle"][:3, 3], expected, atol=TOL_M)
    np.testing.assert_allclose(grasps["drawer_0_handle"][:3, 2], [0, 1, 0], atol=1e-9)


@pytest.mark.bpy
def test_cupboard_links_have_materials_collisions_and_mass(cupboard) -> None:
    spec, model = cupboard
    assert model.category == "cupboard" and set(model.affordances) == {"container", "openable", "supporting_surface"}
    materials = {id(v.material): v.material for link in model.links for v in link.visuals}
    assert sorted(m.name for m in materials.values()) == ["silver", "white"]
    for link in model.links:
        assert link.visuals and link.collisions and link.inertial.mass_kg > 0
    assert sum(link.inertial.mass_kg for link in model.links) == pytest.approx(spec.mass_kg)
    # Closed doors and drawer fronts keep the gap to the body's panels.
    for link in ("door_0", "door_1"):
        for shape in model.link(link).collisions:
            x = (model.joint(f"{link}_hinge").parent_from_joint @ shape.link_from_collision)[0, 3]
            assert x - shape.geometry.size_m[0] / 2 >= spec.depth_m / 2 + spec.door_gap_m - 1e-9
    for shape in model.link("body").collisions:
        assert shape.link_from_collision[0, 3] + shape.geometry.size_m[0] / 2 <= spec.depth_m / 2 + 1e-9


# ---------------------------------------------------------------------------- table and cup


@pytest.mark.bpy
@pytest.mark.parametrize("legs", [{"size_m": 0.05, "inset_m": 0.04}, {"diameter_m": 0.06, "inset_m": 0.02}])
def test_table_has_the_measured_size(tmp_path: Path, kitchen_dir: Path, legs: dict) -> None:
    data = with_field(read_spec(kitchen_dir / "table.yaml"), "legs", legs)
    model = build_model(write_spec(tmp_path, data, "table.yaml"))
    top = data["top"]
    assert [link.name for link in model.links] == ["body"] and model.joints == []
    assert model.affordances == ["supporting_surface"] and model.category == "table"
    vertices = _world_vertices(model, "body")
    np.testing.assert_allclose(vertices.min(0), [-top["width_m"] / 2, -top["length_m"] / 2, 0], atol=TOL_M)
    np.testing.assert_allclose(vertices.max(0), [top["width_m"] / 2, top["length_m"] / 2, data["height_m"]], atol=TOL_M)
    section = legs.get("size_m", legs.get("diameter_m"))
    leg_meshes = [v.mesh for v in model.link("body").visuals if v.name.startswith("body.leg_")]
    assert len(leg_meshes) == 4
    for mesh in leg_meshes:
        lo, hi = mesh.bounds
        np.testing.assert_allclose(hi - lo, [section, section, data["height_m"] - top["thickness_m"]], atol=TOL_M)
        # Each leg's outer faces `inset_m` in from the top's edges.
        np.testing.assert_allclose(
            np.abs(lo + hi)[:2] / 2 + section / 2,
            [top["width_m"] / 2 - legs["inset_m"], top["length_m"] / 2 - legs["inset_m"]],
            atol=TOL_M,
        )
    assert len(model.link("body").collisions) == 5


@pytest.mark.bpy
def test_cup_has_the_measured_size_and_a_handle(kitchen_dir: Path) -> None:
    spec = load_spec(kitchen_dir / "red_cup.yaml")
    model = build_model(kitchen_dir / "red_cup.yaml")
    assert model.name == "red_cup" and model.category == "cup"
    assert model.affordances == ["container"] and model.properties == {"colour": "red"}
    body = next(v.mesh for v in model.link("body").visuals if v.name == "body")
    radius = spec.outer_diameter_m / 2
    np.testing.assert_allclose(body.bounds, [[-radius, -radius, 0], [radius, radius, spec.height_m]], atol=TOL_M)
    assert body.is_volume
    radii = np.linalg.norm(body.vertices[:, :2], axis=1)
    rim = np.abs(body.vertices[:, 2] - spec.height_m) < 1e-6
    assert 2 * radii[rim].min() == pytest.approx(spec.outer_diameter_m - 2 * spec.wall_thickness_m, abs=TOL_M)
    floor = (radii < radius - spec.wall_thickness_m / 2) & (body.vertices[:, 2] < spec.height_m / 2)
    assert body.vertices[floor, 2].min() == pytest.approx(spec.bottom_thickness_m, abs=TOL_M)  # closed bottom

    handle = next(v.mesh for v in model.link("body").visuals if v.name == "body.handle")
    assert handle.is_volume
    assert handle.bounds[1, 0] == pytest.approx(radius + spec.handle.span_m, abs=TOL_M)
    assert handle.bounds[0, 0] > radius - spec.wall_thickness_m  # buried in the wall, not poking inside
    assert handle.bounds[1, 1] - handle.bounds[0, 1] == pytest.approx(spec.handle.thickness_m, abs=TOL_M)
    grasps = {g.name: g for g in model.grasp_points}
    assert grasps["handle"].kind == "handle" and grasps["body"].kind == "body"
    np.testing.assert_allclose(
        grasps["handle"].link_from_grasp[:3, 3],
        [radius + spec.handle.span_m - spec.handle.thickness_m / 2, 0, spec.handle.height_m],
        atol=TOL_M,
    )
    assert model.link("body").inertial.mass_kg == pytest.approx(spec.mass_kg)


@pytest.mark.bpy
def test_cup_with_numeric_colour_and_no_handle(tmp_path: Path, kitchen_dir: Path) -> None:
    data = read_spec(kitchen_dir / "blue_cup.yaml")
    del data["handle"]
    data["colour"] = [0.2, 0.4, 0.6]
    model = build_model(write_spec(tmp_path, data, "plain.yaml"))
    assert model.properties == {} and [g.kind for g in model.grasp_points] == ["body"]
    assert [v.name for v in model.link("body").visuals] == ["body"]
    assert model.link("body").visuals[0].material.rgba == pytest.approx((0.2, 0.4, 0.6, 1.0))


# ---------------------------------------------------------------------------- Blender file and examples


@pytest.mark.bpy
def test_blend_file_is_written_and_reopens(tmp_path: Path, kitchen_dir: Path) -> None:
    blend = tmp_path / "out" / "cupboard.blend"
    model = build_model(kitchen_dir / "cupboard.yaml", blend_path=blend)
    assert blend.is_file() and [p.name for p in blend.parent.iterdir()] == ["cupboard.blend"]

    import bpy

    bpy.ops.wm.open_mainfile(filepath=str(blend))
    objects = bpy.data.objects
    for joint in model.joints:
        child = objects[joint.child]
        assert child.parent.name == joint.parent
        np.testing.assert_allclose(np.array(child.matrix_world), model.world_from_links()[joint.child], atol=1e-6)
    assert objects["body.shelf_0"].parent.name == "body"
    assert objects["body.shelf_0"]["homemodel_link"] == "body"
    assert objects["body"].modifiers["wall thickness"].thickness == pytest.approx(0.018)
    assert {m.name for m in bpy.data.materials} == {"white", "silver"}


@pytest.mark.bpy
@pytest.mark.parametrize("name", ["cupboard", "table", "red_cup", "blue_cup"])
def test_examples_build_quickly(kitchen_dir: Path, name: str) -> None:
    build_model(kitchen_dir / "table.yaml")  # bpy imported and warm
    start = time.perf_counter()
    model = build_model(kitchen_dir / f"{name}.yaml")
    assert time.perf_counter() - start < 2.0
    assert model.name == name
    for link in model.links:
        assert link.inertial is not None and link.inertial.mass_kg > 0


@pytest.mark.bpy
def test_a_build_gives_the_same_files_whatever_this_process_built_or_rendered_before(tmp_path: Path, kitchen_dir: Path) -> None:
    """Between builds the scene is emptied without Blender's factory reset (75 ms a build):
    the datablocks a build added are removed. A cup built first, after a cupboard, after a
    render block (which sets the scene's own settings) and after opening a .blend file gives
    the same files."""
    import bpy

    from homemodel.geometry.cycles_scene import empty_scene, reset_to_empty_scene
    from modeller import build

    def files(folder: Path) -> dict[str, bytes]:  # the .blend and summary.json hold times and paths
        return {p.relative_to(folder).as_posix(): p.read_bytes() for p in folder.rglob("*") if p.is_file() and p.suffix not in (".blend", ".json")}

    cup = kitchen_dir / "red_cup.yaml"
    build(cup, tmp_path / "first")
    build(kitchen_dir / "cupboard.yaml", tmp_path / "cupboard")
    reset_to_empty_scene()
    assert [kind for kind in ("objects", "meshes", "materials", "images", "collections") if len(getattr(bpy.data, kind))] == []
    build(cup, tmp_path / "after_cupboard")
    with empty_scene():
        bpy.context.scene.render.engine = "CYCLES"
        bpy.context.scene.unit_settings.scale_length = 0.5
    reset_to_empty_scene()
    assert bpy.context.scene.unit_settings.scale_length == 1.0
    build(cup, tmp_path / "after_render")
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "cupboard" / "model.blend"))
    build(cup, tmp_path / "after_open")
    assert not bpy.data.filepath and "body.shelf_0" not in bpy.data.objects  # the cupboard's
    first = files(tmp_path / "first")
    assert "model.urdf" in first and "model.glb" in first
    for later in ("after_cupboard", "after_render", "after_open"):
        assert files(tmp_path / later) == first, later
