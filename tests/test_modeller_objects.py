"""modeller: furniture (tables, chairs, sofas, beds, shelving) and small objects (cups, mugs,
glasses, plates, bowls, bottles, boxes, jars, pill boxes, cutlery, remote controls).

Built models are checked against their measurements (bounds and features within 1 mm),
hollow vessels against their collision shapes, the pill box's hinge against its measured
edge, and every catalogue model against the validation gate (pybullet, check_urdf,
yourdfpy, the collision sweep and the Khronos glTF validator).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import trimesh
from spec_edits import read_spec, with_field, write_spec

from articulation.model import Box, Cylinder, MeshGeometry, Model
from homemodel.core.errors import SpecError
from homemodel.core.transforms import transform_points
from modeller import build_from_spec, build_model, load_spec, write_spec_schemas
from modeller.kinds import SPEC_TYPES

TOL_M = 1e-3
KINDS = [
    "table",
    "chair",
    "sofa",
    "bed",
    "shelving",
    "cup",
    "mug",
    "glass",
    "plate",
    "bowl",
    "bottle",
    "box",
    "jar",
    "pill_box",
    "spoon",
    "fork",
    "knife",
    "remote_control",
]


def _default_spec(kind: str):
    return SPEC_TYPES[kind].model_validate({"kind": kind})


def _visual(model: Model, name: str, link: str = "body") -> trimesh.Trimesh:
    return next(v.mesh for v in model.link(link).visuals if v.name == name)


def _collides(model: Model, point: np.ndarray, positions: dict[str, float] | None = None) -> bool:
    """Whether `point` (model frame) lies inside any collision shape of any link."""
    for link_name, world_from_link in model.world_from_links(positions).items():
        for shape in model.link(link_name).collisions:
            local = transform_points(np.linalg.inv(world_from_link @ shape.link_from_collision), point[None])[0]
            geometry = shape.geometry
            if isinstance(geometry, Box):
                inside = bool(np.all(np.abs(local) <= np.array(geometry.size_m) / 2 + 1e-9))
            elif isinstance(geometry, Cylinder):
                inside = math.hypot(local[0], local[1]) <= geometry.radius_m and abs(local[2]) <= geometry.length_m / 2
            else:
                assert isinstance(geometry, MeshGeometry)
                inside = bool(geometry.mesh.convex_hull.contains(local[None])[0])
            if inside:
                return True
    return False


def _ring(radius_m: float, z_m: float, count: int = 32) -> np.ndarray:
    angles = np.linspace(0, 2 * np.pi, count, endpoint=False)
    return np.column_stack([radius_m * np.cos(angles), radius_m * np.sin(angles), np.full(count, z_m)])


# ---------------------------------------------------------------------------- expected extents


def _extent(spec) -> tuple[list[float], list[float]]:  # noqa: C901 - one branch per kind
    """The model's bounds (lo, hi) as the measurements say, worked out from the spec alone."""
    k = spec.kind
    if k == "table":
        x, y = spec.top.size_xy_m
        return [-x / 2, -y / 2, 0], [x / 2, y / 2, spec.height_m]
    if k == "chair":
        tilt = math.radians(spec.backrest_tilt_deg)
        # The backrest's rear face leans back from the seat's rear top edge; its top front
        # corner is at height_m, its top rear corner lower by t sin(tilt).
        rear_top_z = spec.height_m - spec.backrest_thickness_m * math.sin(tilt)
        back_x = -spec.seat_depth_m / 2 - (rear_top_z - spec.seat_height_m) * math.tan(tilt)
        return [back_x, -spec.seat_width_m / 2, 0], [spec.seat_depth_m / 2, spec.seat_width_m / 2, spec.height_m]
    if k in ("sofa", "shelving"):
        return [-spec.depth_m / 2, -spec.width_m / 2, 0], [spec.depth_m / 2, spec.width_m / 2, spec.height_m]
    if k == "bed":
        top = max(spec.headboard_height_m, spec.footboard_height_m, spec.frame_height_m + spec.mattress_thickness_m)
        return [-spec.length_m / 2, -spec.width_m / 2, 0], [spec.length_m / 2, spec.width_m / 2, top]
    if k in ("cup", "mug"):
        r = spec.outer_diameter_m / 2
        reach = r + (spec.handle.span_m if spec.handle is not None else 0.0)
        return [-r, -r, 0], [reach, r, spec.height_m]
    if k == "glass":
        r = max(spec.top_diameter_m, spec.bottom_diameter_m) / 2
        return [-r, -r, 0], [r, r, spec.height_m]
    if k == "plate":
        r = spec.diameter_m / 2
        return [-r, -r, 0], [r, r, spec.height_or_default_m]
    if k in ("bowl", "bottle"):
        r = spec.diameter_m / 2
        return [-r, -r, 0], [r, r, spec.height_m]
    if k in ("box", "pill_box"):
        return [-spec.depth_m / 2, -spec.width_m / 2, 0], [spec.depth_m / 2, spec.width_m / 2, spec.height_m]
    if k == "jar":
        r = max(spec.diameter_m, spec.lid_diameter_or_default_m) / 2
        return [-r, -r, 0], [r, r, spec.height_m]
    if k == "spoon":
        half_w = max(spec.bowl_width_m, spec.handle_width_m) / 2
        return [-spec.length_m / 2, -half_w, 0], [spec.length_m / 2, half_w, spec.bowl_depth_m]
    if k == "fork":
        half_w, top = max(spec.head_width_m, spec.handle_width_m) / 2, max(spec.thickness_m, spec.handle_thickness_m)
        return [-spec.length_m / 2, -half_w, 0], [spec.length_m / 2, half_w, top]
    if k == "knife":
        half_w = max(spec.blade_width_m, spec.handle_width_m) / 2
        return [-spec.length_m / 2, -half_w, 0], [spec.length_m / 2, half_w, spec.handle_thickness_m]
    if k == "remote_control":
        top = spec.thickness_m + (spec.buttons.height_m if spec.buttons.rows else 0.0)
        return [-spec.length_m / 2, -spec.width_m / 2, 0], [spec.length_m / 2, spec.width_m / 2, top]
    raise AssertionError(f"no expected extent for {k}")


# ---------------------------------------------------------------------------- specs


def test_catalogue_holds_a_spec_of_every_kind(catalogue_dir: Path) -> None:
    for kind in KINDS:
        assert load_spec(catalogue_dir / f"{kind}.yaml").kind == kind


@pytest.mark.parametrize("kind", KINDS)
def test_every_field_has_a_working_default(kind: str) -> None:
    spec = _default_spec(kind)
    assert spec.kind == kind and spec.density_or_default_kg_m3 > 0


def test_schemas_are_written_with_field_descriptions(tmp_path: Path) -> None:
    paths = {p.name for p in write_spec_schemas(tmp_path)}
    assert {f"{kind}.schema.json" for kind in KINDS} <= paths
    chair = json.loads((tmp_path / "chair.schema.json").read_text())
    assert "floor to the seat's top surface" in chair["properties"]["seat_height_m"]["description"]
    pill_box = json.loads((tmp_path / "pill_box.schema.json").read_text())
    assert pill_box["properties"]["opening_limit_deg"]["maximum"] == 180


# One case per rule: (kind, dotted field, value, dotted field the error must name, words in the message).
REFUSALS = [
    ("table", "top.length_m", 1.2, "top.length_m", "a round top is measured by diameter_m"),
    ("table", "legs", {"size_m": 0.05}, "pedestal", "give legs or pedestal, not both"),
    ("table", "pedestal.column_diameter_m", 0.7, "pedestal.column_diameter_m", "on a foot only 0.6 m across"),
    ("table", "pedestal.foot_diameter_m", 1.2, "pedestal.foot_diameter_m", "sticks out under a top"),
    ("table", "pedestal.foot_thickness_m", 0.73, "pedestal.foot_thickness_m", "leave no column"),
    ("chair", "seat_thickness_m", 0.5, "seat_thickness_m", "at 0.45 m high"),
    ("chair", "height_m", 0.46, "height_m", "leaves no backrest"),
    ("chair", "backrest_tilt_deg", 45, "backrest_tilt_deg", "less than or equal to 30"),
    ("chair", "legs.inset_m", 0.2, "legs.inset_m", "do not fit under a seat"),
    ("sofa", "arms.width_m", 1.1, "arms.width_m", "fill a sofa 2.18 m wide"),
    ("sofa", "arms.height_m", 0.3, "arms.height_m", "must be above the seat"),
    ("sofa", "cushion_thickness_m", 0.4, "cushion_thickness_m", "leave no base"),
    ("sofa", "height_m", 0.4, "height_m", "is not above the seat"),
    ("sofa", "cushions", 0, "cushions", "greater than or equal to 1"),
    ("bed", "frame_thickness_m", 0.35, "frame_thickness_m", "reaches below the floor"),
    ("bed", "headboard_height_m", 0.2, "headboard_height_m", "below the frame's top"),
    ("bed", "footboard_height_m", 0.1, "footboard_height_m", "below the frame's top"),
    ("shelving", "shelf_heights_m.0", 0.01, "shelf_heights_m.0", "reaches below the floor"),
    ("shelving", "shelf_heights_m.5", 2.01, "shelf_heights_m.5", "cuts into the top board"),
    ("shelving", "shelf_heights_m.2", 0.41, "shelf_heights_m.2", "overlaps shelf 1"),
    ("shelving", "board_thickness_m", 0.41, "board_thickness_m", "fill a unit 0.8 m wide"),
    ("shelving", "bakc", True, "bakc", "Extra inputs are not permitted"),
    ("mug", "handle.span_m", 0.004, "handle.span_m", "leaves no hole"),
    ("mug", "handle.height_m", 0.1, "handle.height_m", "on a cup 0.105 m high"),
    ("glass", "wall_thickness_m", 0.03, "wall_thickness_m", "fills a glass 0.06 m across"),
    ("glass", "base_thickness_m", 0.12, "base_thickness_m", "fills a glass 0.12 m high"),
    ("plate", "well_diameter_m", 0.23, "well_diameter_m", "leaves no rim"),
    ("plate", "thickness_m", 0.05, "thickness_m", "is not under its rim"),
    ("plate", "style", "soup", "style", "'flat' or 'deep'"),
    ("bowl", "foot_diameter_m", 0.145, "foot_diameter_m", "as wide as the bowl's inside"),
    ("bowl", "bottom_thickness_m", 0.07, "bottom_thickness_m", "fills a bowl 0.065 m high"),
    ("bottle", "neck_diameter_m", 0.08, "neck_diameter_m", "on a body 0.076 m across"),
    ("bottle", "cap_diameter_m", 0.02, "cap_diameter_m", "must fit over the neck"),
    ("bottle", "shoulder_height_m", 0.25, "shoulder_height_m", "is not below the neck"),
    ("bottle", "neck_height_m", 0.28, "neck_height_m", "leaves no neck below the cap"),
    ("box", "width_m", -0.19, "width_m", "greater than 0"),
    ("box", "contents", "corn flakes", "contents", "should match pattern"),
    ("jar", "lid_diameter_m", 0.05, "lid_diameter_m", "does not cover the jar's opening"),
    ("jar", "height_m", 0.035, "height_m", "leaves no body"),
    ("jar", "knob_diameter_m", 0.2, "knob_diameter_m", "on a lid 0.108 m across"),
    ("jar", "category", "sugar container", "category", "should match pattern"),
    ("pill_box", "lid_thickness_m", 0.027, "lid_thickness_m", "leaves no room under it"),
    ("pill_box", "width_m", 0.02, "compartments", "7 compartments leave each"),
    ("pill_box", "wall_thickness_m", 0.03, "wall_thickness_m", "leave no room inside"),
    ("pill_box", "opening_limit_deg", 200, "opening_limit_deg", "less than or equal to 180"),
    ("spoon", "bowl_length_m", 0.2, "bowl_length_m", "leaves no handle"),
    ("spoon", "neck_width_m", 0.02, "neck_width_m", "wider than the handle"),
    ("spoon", "bowl_thickness_m", 0.02, "bowl_thickness_m", "fills a bowl 0.011 m deep"),
    ("fork", "tine_length_m", 0.07, "tine_length_m", "in a head 0.06 m long"),
    ("fork", "tines", 7, "tines", "less than or equal to 6"),
    ("knife", "blade_thickness_m", 0.02, "blade_thickness_m", "thicker than the handle"),
    ("knife", "blade_length_m", 0.3, "blade_length_m", "leaves no handle"),
    ("remote_control", "buttons.columns", 5, "buttons.columns", "across a body 0.048 m wide"),
    ("remote_control", "buttons.rows", 20, "buttons.rows", "from the front of a body 0.19 m long"),
    ("remote_control", "buttons.pitch_m", 0.005, "buttons.pitch_m", "overlap"),
    ("remote_control", "corner_radius_m", 0.03, "corner_radius_m", "do not fit"),
]


@pytest.mark.parametrize(("kind", "field", "value", "blamed", "words"), REFUSALS)
def test_impossible_spec_is_refused_naming_file_and_field(
    tmp_path: Path, catalogue_dir: Path, kind: str, field: str, value: object, blamed: str, words: str
) -> None:
    path = write_spec(tmp_path, with_field(read_spec(catalogue_dir / f"{kind}.yaml"), field, value))
    with pytest.raises(SpecError) as caught:
        load_spec(path)
    message = str(caught.value)
    assert message.startswith(f"{path}: {blamed}: "), message
    assert words in message, message
    assert "\n" not in message


def test_rectangular_table_refuses_a_diameter(tmp_path: Path) -> None:
    path = write_spec(tmp_path, {"kind": "table", "top": {"length_m": 1.0, "width_m": 0.6, "diameter_m": 0.9}})
    with pytest.raises(SpecError, match=r"top\.diameter_m: a rectangular top is measured by length_m and width_m"):
        load_spec(path)


# ---------------------------------------------------------------------------- built models


@pytest.mark.bpy
@pytest.mark.parametrize("kind", KINDS)
def test_catalogue_model_passes_the_validation_gate(catalogue, kind: str) -> None:
    report = catalogue[kind].report
    assert report.ok, report.format()
    assert any(check.name == "pybullet" for check in report.checks)


@pytest.mark.bpy
@pytest.mark.parametrize("kind", KINDS)
def test_built_size_matches_the_measurements(catalogue, kind: str) -> None:
    spec, model, _ = catalogue[kind]
    lo, hi = model.world_mesh().bounds
    expected_lo, expected_hi = _extent(spec)
    np.testing.assert_allclose(lo, expected_lo, atol=TOL_M)
    np.testing.assert_allclose(hi, expected_hi, atol=TOL_M)
    if kind not in ("table", "sofa", "bed", "shelving"):  # what a hand takes has somewhere to take it
        assert model.grasp_points
    for link in model.links:
        assert link.collisions and link.inertial.mass_kg > 0
    if spec.mass_kg is not None:
        assert sum(link.inertial.mass_kg for link in model.links) == pytest.approx(spec.mass_kg)


@pytest.mark.bpy
@pytest.mark.parametrize("kind", KINDS)
def test_defaults_alone_build_to_their_measurements(kind: str) -> None:
    spec = _default_spec(kind)
    model = build_from_spec(spec, kind)
    lo, hi = model.world_mesh().bounds
    expected_lo, expected_hi = _extent(spec)
    np.testing.assert_allclose(lo, expected_lo, atol=TOL_M)
    np.testing.assert_allclose(hi, expected_hi, atol=TOL_M)
    assert model.category == (spec.category if kind == "jar" else kind)


# ---------------------------------------------------------------------------- furniture


@pytest.mark.bpy
def test_pedestal_table_has_its_foot_and_column(catalogue) -> None:
    spec, model, _ = catalogue["table"]
    pedestal = spec.pedestal
    foot, column = _visual(model, "body.foot"), _visual(model, "body.column")
    np.testing.assert_allclose(
        foot.bounds[1] - foot.bounds[0], [pedestal.foot_diameter_m] * 2 + [pedestal.foot_thickness_m], atol=TOL_M
    )
    np.testing.assert_allclose(
        column.bounds[:, 2], [pedestal.foot_thickness_m, spec.height_m - spec.top.thickness_m], atol=TOL_M
    )
    assert column.bounds[1, 0] * 2 == pytest.approx(pedestal.column_diameter_m, abs=TOL_M)
    assert model.properties["surface_heights_m"] == "0.75" and model.properties["shape"] == "round"


@pytest.mark.bpy
@pytest.mark.parametrize("legs", [{"size_m": 0.05, "inset_m": 0.04}, {"diameter_m": 0.06, "inset_m": 0.02}])
def test_round_table_legs_stand_on_the_diagonals_inset_from_the_rim(tmp_path: Path, legs: dict) -> None:
    data = {"kind": "table", "top": {"shape": "round", "diameter_m": 0.9}, "height_m": 0.72, "legs": legs}
    model = build_model(write_spec(tmp_path, data, "round.yaml"))
    radius = 0.45
    legs_found = [v.mesh for v in model.link("body").visuals if v.name.startswith("body.leg_")]
    assert len(legs_found) == 4
    for mesh in legs_found:
        centre = mesh.bounds.mean(axis=0)
        direction = centre[:2] / np.linalg.norm(centre[:2])
        np.testing.assert_allclose(np.abs(direction), [math.sqrt(0.5)] * 2, atol=1e-6)  # on a diagonal
        outermost = float((mesh.vertices[:, :2] @ direction).max())
        assert outermost == pytest.approx(radius - legs["inset_m"], abs=TOL_M)
        assert mesh.bounds[1, 2] == pytest.approx(0.72 - 0.03, abs=TOL_M)
    top = _visual(model, "body")
    np.testing.assert_allclose(top.bounds[1], [radius, radius, 0.72], atol=TOL_M)


@pytest.mark.bpy
def test_chair_seat_legs_and_backrest_where_measured(catalogue) -> None:
    spec, model, _ = catalogue["chair"]
    seat = _visual(model, "body")
    assert seat.bounds[1, 2] == pytest.approx(spec.seat_height_m, abs=TOL_M)
    assert len([v for v in model.link("body").visuals if v.name.startswith("body.leg_")]) == 4
    backrest = _visual(model, "body.backrest")
    # Its lower rear edge on the seat's rear top edge, leaning back by the measured angle.
    low_rear = backrest.vertices[np.argmin(backrest.vertices[:, 2] + 1e-3 * backrest.vertices[:, 0])]
    np.testing.assert_allclose(low_rear[[0, 2]], [-spec.seat_depth_m / 2, spec.seat_height_m], atol=TOL_M)
    grasp = model.world_from_grasp_points()["backrest_top"]
    assert grasp[2, 3] == pytest.approx(
        spec.height_m - spec.backrest_thickness_m * math.sin(math.radians(spec.backrest_tilt_deg)) / 2, abs=TOL_M
    )
    assert model.affordances == ["sittable"] and model.properties["seat_height_m"] == "0.45"


@pytest.mark.bpy
def test_sofa_cushions_arms_and_back(catalogue) -> None:
    spec, model, _ = catalogue["sofa"]
    cushions = [v.mesh for v in model.link("body").visuals if v.name.startswith("body.cushion_")]
    assert len(cushions) == spec.cushions
    inner = spec.width_m - 2 * spec.arms.width_m
    for mesh in cushions:
        assert mesh.bounds[1, 2] == pytest.approx(spec.seat_height_m, abs=TOL_M)
        assert mesh.bounds[1, 1] - mesh.bounds[0, 1] == pytest.approx(inner / spec.cushions, abs=TOL_M)
        assert mesh.bounds[0, 0] == pytest.approx(-spec.depth_m / 2 + spec.back_thickness_m, abs=TOL_M)
    for side, sign in (("left", -1), ("right", 1)):
        arm = _visual(model, f"body.arm_{side}")
        assert arm.bounds[1, 2] == pytest.approx(spec.arms.height_m, abs=TOL_M)
        assert sign * arm.bounds.mean(axis=0)[1] > 0
    legs = [v.mesh for v in model.link("body").visuals if v.name.startswith("body.leg_")]
    assert len(legs) == 4 and all(m.bounds[1, 2] == pytest.approx(spec.leg_height_m, abs=TOL_M) for m in legs)
    assert set(model.affordances) == {"sittable", "supporting_surface"}
    assert model.properties["surface_heights_m"] == "0.45"


@pytest.mark.bpy
def test_bed_mattress_on_its_frame_between_the_boards(catalogue) -> None:
    spec, model, _ = catalogue["bed"]
    mattress = _visual(model, "body.mattress")
    assert mattress.bounds[0, 2] == pytest.approx(spec.frame_height_m, abs=TOL_M)
    assert mattress.bounds[1, 2] == pytest.approx(spec.frame_height_m + spec.mattress_thickness_m, abs=TOL_M)
    head, foot = _visual(model, "body"), _visual(model, "body.footboard")
    assert head.bounds[1, 2] == pytest.approx(spec.headboard_height_m, abs=TOL_M)
    assert foot.bounds[1, 2] == pytest.approx(spec.footboard_height_m, abs=TOL_M)
    # The mattress lies between the boards, inset from the frame's edges.
    assert mattress.bounds[0, 0] == pytest.approx(head.bounds[1, 0] + spec.mattress_inset_m, abs=TOL_M)
    assert mattress.bounds[1, 0] == pytest.approx(foot.bounds[0, 0] - spec.mattress_inset_m, abs=TOL_M)
    legs = [v.mesh for v in model.link("body").visuals if v.name.startswith("body.leg_")]
    frame = _visual(model, "body.frame")
    assert len(legs) == 4
    for leg in legs:  # under the frame's corners
        assert leg.bounds[1, 2] == pytest.approx(spec.frame_height_m - spec.frame_thickness_m, abs=TOL_M)
        assert frame.bounds[0, 0] - 1e-6 <= leg.bounds[0, 0] and leg.bounds[1, 0] <= frame.bounds[1, 0] + 1e-6
    assert model.properties["surface_heights_m"] == "0.5"


@pytest.mark.bpy
def test_bed_without_legs_or_footboard(tmp_path: Path, catalogue_dir: Path) -> None:
    bed = read_spec(catalogue_dir / "bed.yaml")
    data = with_field(with_field(bed, "frame_thickness_m", 0.3), "footboard_height_m", 0)
    model = build_model(write_spec(tmp_path, data, "divan.yaml"))
    names = [v.name for v in model.link("body").visuals]
    assert not any(n.startswith("body.leg_") for n in names) and "body.footboard" not in names
    assert _visual(model, "body.frame").bounds[0, 2] == pytest.approx(0.0, abs=1e-6)


@pytest.mark.bpy
def test_shelving_shelves_at_their_heights(catalogue) -> None:
    spec, model, _ = catalogue["shelving"]
    for i, height in enumerate(spec.shelf_heights_m):
        shelf = _visual(model, f"body.shelf_{i}")
        assert shelf.bounds[1, 2] == pytest.approx(height, abs=TOL_M)
        assert shelf.bounds[1, 2] - shelf.bounds[0, 2] == pytest.approx(spec.board_thickness_m, abs=TOL_M)
        # Between the side panels, in front of the back panel, flush with the front.
        np.testing.assert_allclose(
            shelf.bounds[:, 1],
            [-spec.width_m / 2 + spec.board_thickness_m, spec.width_m / 2 - spec.board_thickness_m],
            atol=TOL_M,
        )
        np.testing.assert_allclose(
            shelf.bounds[:, 0], [-spec.depth_m / 2 + spec.back_thickness_m, spec.depth_m / 2], atol=TOL_M
        )
    heights = [float(h) for h in model.properties["surface_heights_m"].split()]
    assert heights == pytest.approx(sorted([*spec.shelf_heights_m, spec.height_m]))


@pytest.mark.bpy
def test_furniture_registers_in_the_map_with_its_surfaces(catalogue) -> None:
    from semantic_map.nodes import ParkingPosition, Pose
    from semantic_map.registration import large_object_from_model

    model = catalogue["shelving"].model
    node = large_object_from_model(
        model,
        object_id="shelf_1",
        world_from_object=Pose(),
        parking_positions=[ParkingPosition(name="front", world_from_base=np.eye(4), default=True)],
        graspable=False,
        properties=None,
        model_ref=None,
        joint_positions=None,
    )
    assert node.type == "shelving" and node.affordances == ["supporting_surface"]
    assert node.properties["surface_heights_m"].split()[-1] == "2.02"


# ---------------------------------------------------------------------------- vessels


# (kind, cavity points: on the inner wall's radius less 0.5 mm, at these heights as fractions of the inside)
HOLLOW = ["cup", "mug", "glass", "bowl", "jar", "plate"]


def _inside_radius_and_span(spec) -> tuple[Callable[[float], float], float, float]:
    """The inner wall's radius as a function of height, and the inside's floor and top heights."""
    k = spec.kind
    if k in ("cup", "mug"):
        r = spec.outer_diameter_m / 2 - spec.wall_thickness_m
        return (lambda z: r), spec.bottom_thickness_m, spec.height_m
    if k == "glass":
        rb, rt, h = spec.bottom_diameter_m / 2, spec.top_diameter_m / 2, spec.height_m
        return (lambda z: rb + (rt - rb) * z / h - spec.wall_thickness_m), spec.base_thickness_m, h
    if k == "jar":
        r = spec.diameter_m / 2 - spec.wall_thickness_m
        return (lambda z: r), spec.bottom_thickness_m, spec.body_height_m
    if k == "bowl":
        # The inner quarter ellipse about (foot radius, height): r(z) solves it for z.
        foot, rim, h, b = (
            spec.foot_diameter_m / 2,
            spec.diameter_m / 2 - spec.wall_thickness_m,
            spec.height_m,
            spec.bottom_thickness_m,
        )
        return (lambda z: foot + (rim - foot) * math.sqrt(max(0.0, 1 - ((h - z) / (h - b)) ** 2))), b, h
    if k == "plate":
        well, r, h, t = spec.well_diameter_m / 2, spec.diameter_m / 2, spec.height_or_default_m, spec.thickness_m
        return (lambda z: well + (r - well) * (z - t) / (h - t)), t, h
    raise AssertionError(k)


@pytest.mark.bpy
@pytest.mark.parametrize("kind", HOLLOW)
def test_hollow_vessels_stay_hollow_for_a_simulator(catalogue, kind: str) -> None:
    spec, model, _ = catalogue[kind]
    radius_at, floor, top = _inside_radius_and_span(spec)
    for fraction in (0.1, 0.5, 0.9):
        z = floor + fraction * (top - floor)
        assert not _collides(model, np.array([0.0, 0.0, z])), f"axis at z={z:.3f} is inside a collision shape"
        for point in _ring(radius_at(z) - 5e-4, z):
            assert not _collides(model, point), f"cavity point {point.round(4)} is inside a collision shape"
    assert _collides(model, np.array([0.0, 0.0, floor / 2])), "the floor has no collision"


@pytest.mark.bpy
@pytest.mark.parametrize("kind", ["cup", "mug", "glass", "jar", "bowl"])
def test_vessel_walls_have_collisions_all_round(catalogue, kind: str) -> None:
    spec, model, _ = catalogue[kind]
    radius_at, floor, top = _inside_radius_and_span(spec)
    wall = spec.wall_thickness_m
    for z in (floor + 0.25 * (top - floor), (floor + top) / 2, top - 0.002):
        for point in _ring(radius_at(z) + wall / 2, z):
            assert _collides(model, point), f"wall point {point.round(4)} has no collision"


@pytest.mark.bpy
def test_glass_tapers_between_its_measured_diameters(catalogue) -> None:
    spec, model, _ = catalogue["glass"]
    body = _visual(model, "body")
    assert body.is_volume
    radii = np.linalg.norm(body.vertices[:, :2], axis=1)
    at_rim = np.abs(body.vertices[:, 2] - spec.height_m) < 1e-6
    at_base = np.abs(body.vertices[:, 2]) < 1e-6
    assert radii[at_rim].max() * 2 == pytest.approx(spec.top_diameter_m, abs=TOL_M)
    assert radii[at_rim].min() * 2 == pytest.approx(spec.top_diameter_m - 2 * spec.wall_thickness_m, abs=TOL_M)
    assert radii[at_base].max() * 2 == pytest.approx(spec.bottom_diameter_m, abs=TOL_M)
    inside_floor = body.vertices[(radii < radii[at_rim].min() - 1e-4) & (body.vertices[:, 2] > 1e-6), 2]
    assert inside_floor.min() == pytest.approx(spec.base_thickness_m, abs=TOL_M)


@pytest.mark.bpy
@pytest.mark.parametrize("style", ["flat", "deep"])
def test_plate_well_rim_and_style(tmp_path: Path, style: str) -> None:
    model = build_model(write_spec(tmp_path, {"kind": "plate", "style": style}, f"{style}.yaml"))
    spec = load_spec(tmp_path / f"{style}.yaml")
    body = _visual(model, "body")
    assert body.is_volume
    height = {"flat": 0.022, "deep": 0.045}[style]
    assert body.bounds[1, 2] == pytest.approx(height, abs=TOL_M)
    radii = np.linalg.norm(body.vertices[:, :2], axis=1)
    underside = radii[np.abs(body.vertices[:, 2]) < 1e-6]
    assert underside.max() * 2 == pytest.approx(spec.well_diameter_m, abs=TOL_M)  # it stands on its well
    well_top = body.vertices[radii < spec.well_diameter_m / 2 + 1e-6, 2].max()
    assert well_top == pytest.approx(spec.thickness_m, abs=TOL_M)
    assert model.affordances == (["supporting_surface"] if style == "flat" else ["container"])
    rim = model.world_from_grasp_points()["rim"]
    assert rim[0, 3] == pytest.approx(spec.diameter_m / 2, abs=TOL_M) and model.grasp_points[0].kind == "rim"


@pytest.mark.bpy
def test_bowl_foot_floor_and_rim(catalogue) -> None:
    spec, model, _ = catalogue["bowl"]
    body = _visual(model, "body")
    assert body.is_volume
    radii = np.linalg.norm(body.vertices[:, :2], axis=1)
    assert radii[np.abs(body.vertices[:, 2]) < 1e-6].max() * 2 == pytest.approx(spec.foot_diameter_m, abs=TOL_M)
    at_rim = np.abs(body.vertices[:, 2] - spec.height_m) < 1e-6
    assert radii[at_rim].min() * 2 == pytest.approx(spec.diameter_m - 2 * spec.wall_thickness_m, abs=TOL_M)
    floor = body.vertices[(radii < spec.foot_diameter_m / 2 + 1e-6) & (body.vertices[:, 2] > 1e-6), 2]
    assert floor.min() == pytest.approx(spec.bottom_thickness_m, abs=TOL_M)


@pytest.mark.bpy
def test_bottle_shoulder_neck_and_cap(catalogue) -> None:
    spec, model, _ = catalogue["bottle"]
    body = _visual(model, "body")
    assert body.is_volume
    radii = np.linalg.norm(body.vertices[:, :2], axis=1)
    z = body.vertices[:, 2]
    assert radii[z <= spec.shoulder_height_m + 1e-6].min() * 2 == pytest.approx(spec.diameter_m, abs=TOL_M)
    neck = z >= spec.neck_height_m - 1e-6
    assert radii[neck].max() * 2 == pytest.approx(spec.neck_diameter_m, abs=TOL_M)
    cap = _visual(model, "body.cap")
    np.testing.assert_allclose(cap.bounds[:, 2], [spec.height_m - spec.cap_height_m, spec.height_m], atol=TOL_M)
    assert (cap.bounds[1, 0] - cap.bounds[0, 0]) == pytest.approx(spec.cap_diameter_m, abs=TOL_M)
    assert {g.name: g.kind for g in model.grasp_points} == {"body": "body", "cap": "knob"}
    assert _collides(model, np.array([0.0, 0.0, spec.height_m / 2]))  # closed: the hull fills it


@pytest.mark.bpy
def test_jar_lid_lifts_off_with_its_knob(catalogue) -> None:
    spec, model, _ = catalogue["jar"]
    lift = model.joint("lid_lift")
    assert lift.type == "prismatic" and lift.parent == "body" and lift.child == "lid"
    assert lift.axis.tolist() == [0.0, 0.0, 1.0] and lift.limits.lower == 0.0 and lift.limits.upper >= 0.1
    assert lift.parent_from_joint[2, 3] == pytest.approx(spec.body_height_m, abs=TOL_M)
    lid = np.vstack(
        [transform_points(model.world_from_links()["lid"], v.mesh.vertices) for v in model.link("lid").visuals]
    )
    assert lid[:, 2].min() == pytest.approx(spec.body_height_m, abs=TOL_M)
    assert lid[:, 0].max() * 2 == pytest.approx(spec.lid_diameter_m, abs=TOL_M)
    knob = model.world_from_grasp_points()["lid_knob"]
    assert knob[2, 3] == pytest.approx(spec.height_m - spec.knob_height_m / 2, abs=TOL_M)
    assert model.category == "sugar_container" and model.properties["contents"] == "sugar"


@pytest.mark.bpy
def test_jar_registers_as_a_small_object(catalogue) -> None:
    from semantic_map.nodes import Pose
    from semantic_map.registration import small_object_from_model

    model = catalogue["jar"].model
    node = small_object_from_model(
        model,
        object_id="sugar",
        parent_id="table_1",
        relation="on",
        parent_from_object=Pose(xyz=(0.1, 0.2, 0.75)),
        default_positions=None,
        graspable=True,
        properties=None,
        model_ref=None,
    )
    assert node.type == "sugar_container" and node.properties == {"colour": "white", "contents": "sugar"}
    assert {g.name for g in node.grasp_points} == {"body", "lid_knob"}


# ---------------------------------------------------------------------------- pill box


@pytest.mark.bpy
def test_pill_box_hinge_on_the_back_top_edge_and_lid_opening_upward(catalogue) -> None:
    spec, model, _ = catalogue["pill_box"]
    hinge = model.joint("lid_hinge")
    body_h = spec.height_m - spec.lid_thickness_m
    assert hinge.type == "revolute" and hinge.parent == "body" and hinge.child == "lid"
    np.testing.assert_allclose(hinge.parent_from_joint[[0, 2], 3], [-spec.depth_m / 2, body_h], atol=TOL_M)
    np.testing.assert_allclose(np.abs(hinge.axis), [0, 1, 0])
    assert hinge.limits.lower == 0 and hinge.limits.upper == pytest.approx(math.radians(spec.opening_limit_deg))
    # Closed, the lid covers the body exactly.
    lid = np.vstack([v.mesh.vertices for v in model.link("lid").visuals])
    lid = transform_points(model.world_from_links()["lid"], lid)
    np.testing.assert_allclose(lid.min(0), [-spec.depth_m / 2, -spec.width_m / 2, body_h], atol=TOL_M)
    np.testing.assert_allclose(lid.max(0), [spec.depth_m / 2, spec.width_m / 2, spec.height_m], atol=TOL_M)
    # The front edge's grasp point turns about the hinge line: up and back as the lid opens.
    t = spec.lid_thickness_m
    for angle in (0.0, math.radians(60), hinge.limits.upper):
        edge = model.world_from_grasp_points({"lid_hinge": angle})["lid_front_edge"][:3, 3]
        expected = [
            -spec.depth_m / 2 + spec.depth_m * math.cos(angle) - t / 2 * math.sin(angle),
            0.0,
            body_h + spec.depth_m * math.sin(angle) + t / 2 * math.cos(angle),
        ]
        np.testing.assert_allclose(edge, expected, atol=TOL_M)
    assert set(model.affordances) == {"container", "openable"}


@pytest.mark.bpy
def test_pill_box_compartments_are_equal_and_empty(catalogue) -> None:
    spec, model, _ = catalogue["pill_box"]
    dividers = sorted(
        (v.mesh for v in model.link("body").visuals if v.name.startswith("body.divider_")), key=lambda m: m.bounds[0, 1]
    )
    assert len(dividers) == spec.compartments - 1
    t = spec.wall_thickness_m
    edges = [-spec.width_m / 2 + t, *(x for m in dividers for x in m.bounds[:, 1]), spec.width_m / 2 - t]
    widths = np.diff(edges)[::2]  # compartments lie between a wall or divider and the next
    np.testing.assert_allclose(widths, spec.compartment_width_m, atol=TOL_M)
    body_h = spec.height_m - spec.lid_thickness_m
    for left, right in zip(edges[::2], edges[1::2]):
        assert not _collides(model, np.array([0.0, (left + right) / 2, body_h / 2]))


# ---------------------------------------------------------------------------- boxes, cutlery, remote


@pytest.mark.bpy
def test_food_box_is_a_closed_cuboid_with_planar_faces(catalogue) -> None:
    spec, model, _ = catalogue["box"]
    body = _visual(model, "body")
    assert body.is_volume
    assert body.volume == pytest.approx(spec.width_m * spec.depth_m * spec.height_m, rel=1e-6)
    assert len(body.facets) == 6  # the six faces a photo can go on
    assert model.affordances == ["container"] and model.properties["contents"] == "cereal"


@pytest.mark.bpy
def test_spoon_rests_on_its_bowl_and_handle_end(catalogue) -> None:
    spec, model, _ = catalogue["spoon"]
    bowl, handle = _visual(model, "body.bowl"), _visual(model, "body")
    assert bowl.bounds[0, 2] == pytest.approx(0.0, abs=1e-6) and bowl.bounds[1, 2] == pytest.approx(
        spec.bowl_depth_m, abs=TOL_M
    )
    np.testing.assert_allclose(
        bowl.bounds[1, :2] - bowl.bounds[0, :2], [spec.bowl_length_m, spec.bowl_width_m], atol=TOL_M
    )
    end = handle.vertices[np.abs(handle.vertices[:, 0] + spec.length_m / 2) < 1e-6]
    assert end[:, 2].min() == pytest.approx(0.0, abs=1e-6)  # the handle's end on the table
    neck = handle.vertices[np.abs(handle.vertices[:, 0] - (spec.length_m / 2 - spec.bowl_length_m)) < 1e-6]
    assert neck[:, 2].max() == pytest.approx(spec.bowl_depth_m, abs=TOL_M)  # meeting the bowl's back rim
    assert neck[:, 1].max() * 2 == pytest.approx(spec.neck_width_m, abs=TOL_M)
    grasp = next(g for g in model.grasp_points if g.name == "handle")
    # Mid-handle, where the ramp's middle is half the rim's height up.
    expected = [-spec.bowl_length_m / 2, 0, spec.bowl_depth_m / 2]
    assert grasp.kind == "handle"
    np.testing.assert_allclose(grasp.link_from_grasp[:3, 3], expected, atol=TOL_M)


@pytest.mark.bpy
def test_fork_tines_and_knife_blade(catalogue) -> None:
    spec, model, _ = catalogue["fork"]
    tines = sorted(
        (v.mesh for v in model.link("body").visuals if v.name.startswith("body.tine_")), key=lambda m: m.bounds[0, 1]
    )
    assert len(tines) == spec.tines
    for mesh in tines:
        assert mesh.bounds[1, 0] == pytest.approx(spec.length_m / 2, abs=TOL_M)
        assert mesh.bounds[1, 0] - mesh.bounds[0, 0] == pytest.approx(spec.tine_length_m, abs=TOL_M)
    gaps = [b.bounds[0, 1] - a.bounds[1, 1] for a, b in zip(tines, tines[1:])]
    np.testing.assert_allclose(gaps, spec.head_width_m / (2 * spec.tines - 1), atol=TOL_M)
    spec, model, _ = catalogue["knife"]
    blade = _visual(model, "body.blade")
    np.testing.assert_allclose(
        blade.bounds[:, 0], [spec.length_m / 2 - spec.blade_length_m, spec.length_m / 2], atol=TOL_M
    )
    assert blade.bounds[1, 2] == pytest.approx(spec.blade_thickness_m, abs=TOL_M)
    tip = blade.vertices[np.argmax(blade.vertices[:, 0])]
    assert abs(tip[1]) < TOL_M  # a round tip, centred


@pytest.mark.bpy
def test_remote_control_buttons_in_their_grid(catalogue) -> None:
    spec, model, _ = catalogue["remote_control"]
    buttons = _visual(model, "body.buttons")
    parts = buttons.split(only_watertight=False)
    grid = spec.buttons
    assert len(parts) == grid.rows * grid.columns == int(model.properties["buttons"])
    centres = np.array([p.bounds.mean(axis=0) for p in parts])
    assert centres[:, 0].max() == pytest.approx(spec.length_m / 2 - grid.from_front_m, abs=TOL_M)
    assert np.ptp(centres[:, 1]) == pytest.approx((grid.columns - 1) * grid.pitch_m, abs=TOL_M)
    assert np.ptp(centres[:, 0]) == pytest.approx((grid.rows - 1) * grid.pitch_m, abs=TOL_M)
    for part in parts:
        assert part.bounds[0, 2] == pytest.approx(spec.thickness_m, abs=1e-6)
        assert part.bounds[1, 0] - part.bounds[0, 0] == pytest.approx(grid.diameter_m, abs=TOL_M)
    body = _visual(model, "body")
    corner = np.array([spec.length_m / 2, spec.width_m / 2])
    # The corners are rounded: nothing of the body within the radius' cut-off of the sharp corner.
    gap = spec.corner_radius_m * (math.sqrt(2) - 1)
    assert np.linalg.norm(body.vertices[:, :2] - corner, axis=1).min() == pytest.approx(gap, abs=1e-4)


@pytest.mark.bpy
def test_mug_is_a_cup_with_a_handle_by_default(catalogue) -> None:
    spec, model, _ = catalogue["mug"]
    assert model.category == "mug" and spec.handle.height_m is None
    grasps = model.world_from_grasp_points()
    np.testing.assert_allclose(
        grasps["handle"][:3, 3],
        [spec.outer_diameter_m / 2 + spec.handle.span_m - spec.handle.thickness_m / 2, 0, spec.height_m / 2],
        atol=TOL_M,
    )
    default = build_from_spec(_default_spec("mug"), "mug")
    assert {g.name for g in default.grasp_points} == {"body", "handle"}
