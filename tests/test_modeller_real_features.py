"""How real cabinets and appliances are built, measured by the README's guide and rebuilt.

The "real" furniture here is made of trimesh boxes placed by this test (never by the
builder): a face-frame base unit whose frame overhangs its sides, with a middle rail and a
middle stile a door hangs on, a raised bottom over a void, a thick shelf, rails across its
open top and a drawer with a second board and a box above and beside its front's middle;
and a microwave whose 65 mm door has 16 mm of it inside the cavity's recess. Each is
measured as an installer would (the tape read to the millimetre, the guide's
`open_at_90` and `free_corner` simulated by turning the real door's corners about its real
axis), rebuilt from the spec, and compared: hinge lines, door and drawer corners at their
opening limits, VoxelIOU with everything open, and the gate.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import trimesh
from spec_edits import with_field, write_spec

from homemodel.core.errors import SpecError
from modeller.spec_loading import load_spec
from modeller.specs.cabinet_geometry import hinge_offsets_m, hinge_tape_warnings

REPO = Path(__file__).resolve().parents[1]
TAPE_STEP_M = 0.001  # read to the millimetre


def _box(lo, hi) -> trimesh.Trimesh:
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    frame = np.eye(4)
    frame[:3, 3] = (lo + hi) / 2
    return trimesh.creation.box(extents=hi - lo, transform=frame)


def _read(value_m: float) -> float:
    return round(round(value_m / TAPE_STEP_M) * TAPE_STEP_M, 6)


def _turned(point_fs: np.ndarray, axis_fs: np.ndarray, angle_rad: float) -> np.ndarray:
    """A point (f forward of the front plane, s in from the hinge-side outer face) of the
    door turned outward about the axis: its free side comes forward."""
    df, ds = np.asarray(point_fs, dtype=float) - axis_fs
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return axis_fs + np.array([df * c + ds * s, ds * c - df * s])


def _tape(axis_fs, *, face_f: float, inner_f: float, edge_s: float, width_m: float, way: str) -> dict:
    """The guide's readings of a door whose axis is at `axis_fs`, read to the millimetre."""
    axis_fs = np.asarray(axis_fs, dtype=float)
    if way == "open_at_90":
        edge = _turned((face_f, edge_s), axis_fs, math.pi / 2)
        inner = _turned((inner_f, edge_s), axis_fs, math.pi / 2)
        return {"open_at_90": {"inner_face_out_m": _read(-inner[1]), "edge_forward_m": _read(edge[0])}}
    corners = [_turned((face_f, edge_s + width_m), axis_fs, math.radians(a)) for a in (45, 90)]
    return {"free_corner": [{"forward_m": _read(f), "out_m": _read(-s)} for f, s in corners]}


def _rotation_z(angle_rad: float, axis_xy) -> np.ndarray:
    return trimesh.transformations.rotation_matrix(angle_rad, (0, 0, 1), (*axis_xy, 0))


# ---------------------------------------------------------------------------- a face-frame base unit

W, D, H, PLINTH, T, GAP, DOOR = 0.9, 0.56, 0.87, 0.1, 0.018, 0.002, 0.018
FRAME_W, FRAME_T, OVERHANG = 0.04, 0.019, 0.01
STILE = (0.43, 0.47)  # from the left side's outer face
RAIL_BOTTOM = 0.66
RAISE, SHELF_TOP, SHELF_T = 0.045, 0.42, 0.028
FACE = D / 2 + GAP + DOOR  # the doors' outer face, x
# The doors: (left, width, true axis behind the face and in from the edge, opened to degrees).
# An overlay door on a frame that stands out past the side swings clear of it only with its
# axis less than ~15 mm behind its face (face-frame hinges); door 1 hangs on the stile.
DOORS = [(0.015, 0.433, 0.0123, 0.0041, 95.0), (0.452, 0.433, 0.0034, 0.0017, 100.0)]
DOOR_BOTTOM, DOOR_HEIGHT = 0.12, 0.53
DRAWER = {"left": 0.015, "width": 0.87, "bottom": 0.69, "height": 0.15, "travel": 0.35}
BOX = {"above_front": 0.03, "width": 0.8, "offset": 0.01, "height": 0.09, "depth": 0.45, "board": 0.018, "wall": 0.015}


def _y(from_left_m: float) -> float:
    return -W / 2 + from_left_m


def _real_unit() -> tuple[dict[str, list[trimesh.Trimesh]], dict[int, np.ndarray]]:
    """The unit's parts by what moves them ("body", "door_0", "door_1", "drawer"), closed,
    and each door's true axis (x, y)."""
    top = H
    body = [
        _box((-D / 2, _y(0), PLINTH), (D / 2 - FRAME_T, _y(T), top)),  # sides end behind the frame
        _box((-D / 2, _y(W - T), PLINTH), (D / 2 - FRAME_T, _y(W), top)),
        _box((-D / 2, _y(T), PLINTH), (-D / 2 + T, _y(W - T), top)),  # back
        _box((-D / 2 + T, _y(T), PLINTH + RAISE), (D / 2 - FRAME_T, _y(W - T), PLINTH + RAISE + T)),  # raised bottom
        _box((-D / 2 + T, _y(T), SHELF_TOP - SHELF_T), (D / 2 - FRAME_T - 0.02, _y(W - T), SHELF_TOP)),
        _box((D / 2 - 0.1, _y(T), top - T), (D / 2 - FRAME_T, _y(W - T), top)),  # front top rail
        _box((-D / 2 + T, _y(T), top - T), (-D / 2 + T + 0.1, _y(W - T), top)),  # back cleat
        # plinth: front set back 50 mm, sides and back
        _box((D / 2 - 0.05 - T, _y(0), 0), (D / 2 - 0.05, _y(W), PLINTH)),
        _box((-D / 2, _y(0), 0), (-D / 2 + T, _y(W), PLINTH)),
        _box((-D / 2, _y(0), 0), (D / 2 - 0.05, _y(T), PLINTH)),
        _box((-D / 2, _y(W - T), 0), (D / 2 - 0.05, _y(W), PLINTH)),
    ]
    x0, x1 = D / 2 - FRAME_T, D / 2
    body += [
        _box((x0, _y(-OVERHANG), PLINTH), (x1, _y(FRAME_W - OVERHANG), top)),
        _box((x0, _y(W - FRAME_W + OVERHANG), PLINTH), (x1, _y(W + OVERHANG), top)),
        _box((x0, _y(FRAME_W - OVERHANG), PLINTH), (x1, _y(W - FRAME_W + OVERHANG), PLINTH + FRAME_W)),
        _box((x0, _y(FRAME_W - OVERHANG), top - FRAME_W), (x1, _y(W - FRAME_W + OVERHANG), top)),
        _box((x0, _y(FRAME_W - OVERHANG), RAIL_BOTTOM), (x1, _y(W - FRAME_W + OVERHANG), RAIL_BOTTOM + FRAME_W)),
        _box((x0, _y(STILE[0]), PLINTH + FRAME_W), (x1, _y(STILE[1]), RAIL_BOTTOM)),
    ]
    parts: dict[str, list[trimesh.Trimesh]] = {"body": body}
    axes = {}
    for k, (left, width, behind, inward, _) in enumerate(DOORS):
        parts[f"door_{k}"] = [
            _box((FACE - DOOR, _y(left), DOOR_BOTTOM), (FACE, _y(left + width), DOOR_BOTTOM + DOOR_HEIGHT))
        ]
        axes[k] = np.array([FACE - behind, _y(left + inward)])
    front_in = D / 2 + GAP
    middle = DRAWER["left"] + DRAWER["width"] / 2 + BOX["offset"]
    by0, by1 = _y(middle - BOX["width"] / 2), _y(middle + BOX["width"] / 2)
    bz0 = DRAWER["bottom"] + BOX["above_front"]
    bz1, wall = bz0 + BOX["height"], BOX["wall"]
    box_front = front_in - BOX["board"]
    box_back = box_front - BOX["depth"]
    parts["drawer"] = [
        _box((front_in, _y(DRAWER["left"]), DRAWER["bottom"]),
             (front_in + DOOR, _y(DRAWER["left"] + DRAWER["width"]), DRAWER["bottom"] + DRAWER["height"])),
        _box((box_front, by0, bz0), (front_in, by1, 0.82)),  # the second board, inside the opening
        _box((box_back, by0, bz0), (box_front, by1, bz0 + wall)),  # floor
        _box((box_back, by0, bz0), (box_front, by0 + wall, bz1)),
        _box((box_back, by1 - wall, bz0), (box_front, by1, bz1)),
        _box((box_back, by0, bz0), (box_back + wall, by1, bz1)),
    ]
    return parts, axes


def _unit_spec(tape_way: str = "open_at_90") -> dict:
    """The spec an installer writes from the tape and the guide."""
    doors = []
    for k, (left, width, behind, inward, limit) in enumerate(DOORS):
        # Door 0 hangs on the left side (its outer face at 0); door 1 on the middle stile,
        # read from the stile's face on the far side from the door.
        hung_on = 0.0 if k == 0 else STILE[0]
        edge_s = left - hung_on
        axis = (FACE - D / 2 - behind, edge_s + inward)
        tape = _tape(axis, face_f=FACE - D / 2, inner_f=GAP, edge_s=edge_s, width_m=width, way=tape_way)
        doors.append({"hinge": "left", "left_m": left, "width_m": width, "bottom_m": DOOR_BOTTOM,
                      "height_m": DOOR_HEIGHT, "opening_limit_deg": limit, "handle": {"type": "none"},
                      "hinge_measured": tape})
    drawer = {"left_m": DRAWER["left"], "width_m": DRAWER["width"], "bottom_m": DRAWER["bottom"],
              "height_m": DRAWER["height"], "depth_m": BOX["depth"], "travel_m": DRAWER["travel"],
              "inner_board_m": BOX["board"], "box_bottom_m": BOX["above_front"], "box_width_m": BOX["width"],
              "box_offset_m": BOX["offset"], "box_height_m": BOX["height"], "handle": {"type": "none"}}
    return {
        "kind": "cupboard", "width_m": W, "depth_m": D, "height_m": H, "wall_thickness_m": T,
        "door_thickness_m": DOOR, "door_gap_m": GAP, "plinth_height_m": PLINTH, "plinth_recess_m": 0.05,
        "top_panel": False, "top_rails": [{"from_front_m": 0.0, "depth_m": 0.1},
                                          {"from_front_m": D - T - 0.1, "depth_m": 0.1}],
        "bottom_raise_m": RAISE, "shelf_thickness_m": SHELF_T,
        "shelves": [{"height_m": SHELF_TOP, "depth_m": round(D - T - FRAME_T - 0.02, 3)}],
        "face_frame": {"width_m": FRAME_W, "thickness_m": FRAME_T, "overhang_m": OVERHANG,
                       "rails": [{"bottom_m": RAIL_BOTTOM}],
                       "stiles": [{"left_m": STILE[0], "width_m": STILE[1] - STILE[0], "top_m": RAIL_BOTTOM}]},
        "doors": doors, "drawers": [drawer], "mass_kg": 40,
    }


def _open_pose(parts: dict, axes: dict) -> trimesh.Trimesh:
    """The real unit with its doors at their limits and the drawer pulled out."""
    moved = list(parts["body"])
    for k, (*_, limit) in enumerate(DOORS):
        turn = _rotation_z(-math.radians(limit), axes[k])  # hinged left: opening turns about -z
        moved += [part.copy().apply_transform(turn) for part in parts[f"door_{k}"]]
    shift = trimesh.transformations.translation_matrix((DRAWER["travel"], 0, 0))
    moved += [part.copy().apply_transform(shift) for part in parts["drawer"]]
    return trimesh.util.concatenate(moved)


def _corners(mesh: trimesh.Trimesh) -> np.ndarray:
    """The 8 corners of an axis-aligned box part (the real doors closed)."""
    return trimesh.bounds.corners(mesh.bounds)


@pytest.fixture(scope="module")
def rebuilt_unit(tmp_path_factory) -> dict:
    from modeller import build_model

    folder = tmp_path_factory.mktemp("face_frame_unit")
    spec_path = write_spec(folder, _unit_spec())
    return {"spec_path": spec_path, "spec": load_spec(spec_path), "model": build_model(spec_path), "folder": folder}


@pytest.mark.bpy
def test_a_face_frame_unit_measured_by_the_guide_rebuilds_its_hinge_lines(rebuilt_unit: dict) -> None:
    _, axes = _real_unit()
    model = rebuilt_unit["model"]
    for k in range(len(DOORS)):
        joint = model.joint(f"door_{k}_hinge")
        origin = joint.parent_from_joint[:2, 3]
        direction = joint.parent_from_joint[:3, :3] @ joint.axis
        assert np.linalg.norm(origin - axes[k]) < 0.005, (k, origin, axes[k])  # 5 mm asked
        assert np.linalg.norm(origin - axes[k]) < 0.0015  # read to the millimetre: within 1.5
        assert math.degrees(math.acos(abs(direction[2]) / np.linalg.norm(direction))) < 1.0


@pytest.mark.bpy
def test_door_and_drawer_corners_at_their_limits_match_the_real_ones(rebuilt_unit: dict) -> None:
    parts, axes = _real_unit()
    model = rebuilt_unit["model"]
    limits = {f"door_{k}_hinge": math.radians(limit) for k, (*_, limit) in enumerate(DOORS)}
    limits["drawer_0_slide"] = DRAWER["travel"]
    world = model.world_from_links(limits)
    for k, (*_, limit) in enumerate(DOORS):
        real = trimesh.transform_points(_corners(parts[f"door_{k}"][0]), _rotation_z(-math.radians(limit), axes[k]))
        # The rebuilt door's slab, turned: its mesh's own corners in the model frame.
        visual = next(v for v in model.link(f"door_{k}").visuals)
        built = trimesh.transform_points(visual.mesh.vertices, world[f"door_{k}"] @ visual.link_from_visual)
        gaps = [np.min(np.linalg.norm(built - corner, axis=1)) for corner in real]
        assert max(gaps) < 0.005, (k, gaps)
    shift = np.array([DRAWER["travel"], 0, 0])
    real_drawer = trimesh.util.concatenate(parts["drawer"]).bounds + shift
    built_drawer = trimesh.util.concatenate(
        [v.mesh.copy().apply_transform(world["drawer_0"] @ v.link_from_visual) for v in model.link("drawer_0").visuals]
    )
    for real_corner, built_corner in zip(trimesh.bounds.corners(real_drawer), trimesh.bounds.corners(built_drawer.bounds)):
        assert np.linalg.norm(real_corner - built_corner) < 0.005
    # The box itself (behind the second board): its floor's corners, where the runners carry it.
    box_visual = next(v for v in model.link("drawer_0").visuals if v.name.endswith("box") or "box" in v.name)
    box = box_visual.mesh.copy().apply_transform(world["drawer_0"] @ box_visual.link_from_visual)
    real_box = trimesh.util.concatenate(parts["drawer"][2:]).bounds + shift
    assert np.abs(box.bounds - real_box).max() < 0.005, (box.bounds, real_box)


@pytest.mark.bpy
def test_the_rebuilt_unit_matches_the_real_one_open_and_passes_the_gate(rebuilt_unit: dict) -> None:
    from homemodel.evaluation.voxels import voxel_iou
    from homemodel.exchange.model_files import export_model
    from homemodel.model_folder.gate.validate import validate_path

    parts, axes = _real_unit()
    model = rebuilt_unit["model"]
    limits = {f"door_{k}_hinge": math.radians(limit) for k, (*_, limit) in enumerate(DOORS)}
    limits["drawer_0_slide"] = DRAWER["travel"]
    iou = voxel_iou(model.world_mesh(limits), _open_pose(parts, axes), voxel_size_m=0.006)
    assert iou >= 0.85, iou  # 0.89 measured
    export_model(model, rebuilt_unit["folder"] / "model")
    report = validate_path(rebuilt_unit["folder"] / "model")
    assert report.ok, report.format()


# ---------------------------------------------------------------------------- a microwave with a thick door

MW = {"width": 0.5, "depth": 0.4, "height": 0.3, "wall": 0.012, "divider": 0.38, "gap": 0.003}
MW_DOOR = {"left": 0.003, "width": 0.372, "bottom": 0.003, "height": 0.294, "thick": 0.065, "inside": 0.016}
MW_AXIS = (0.0307, 0.0118)  # behind the door's outer face, in from its hinge-side edge


def _microwave_spec(thickness_m: float, in_opening_m: float, ways: tuple[str, ...]) -> dict:
    face_f = MW_DOOR["thick"] - MW_DOOR["inside"]  # the real door's face, forward of the front plane
    edge_s = MW_DOOR["left"]
    axis = (face_f - MW_AXIS[0], edge_s + MW_AXIS[1])
    tape: dict = {}
    for way in ways:
        tape |= _tape(axis, face_f=face_f, inner_f=-MW_DOOR["inside"], edge_s=edge_s, width_m=MW_DOOR["width"], way=way)
    door = {"hinge": "left", "left_m": MW_DOOR["left"], "width_m": MW_DOOR["width"], "bottom_m": MW_DOOR["bottom"],
            "height_m": MW_DOOR["height"], "thickness_m": thickness_m, "in_opening_m": in_opening_m,
            "opening_limit_deg": 100, "handle": {"type": "none"}, "hinge_measured": tape}
    if in_opening_m == 0:  # the old way: a door as thick as it stands out, all in front
        door["thickness_m"] = round(face_f - MW["gap"], 3)
    return {"kind": "microwave", "width_m": MW["width"], "depth_m": MW["depth"], "height_m": MW["height"],
            "wall_thickness_m": MW["wall"], "door_gap_m": MW["gap"], "turntable_diameter_m": None,
            "panels": [{"left_m": MW["divider"], "width_m": MW["width"] - MW["divider"], "bottom_m": 0,
                        "height_m": MW["height"]}],
            "dividers": [{"left_m": MW["divider"]}], "knobs": [], "doors": [door]}


def _true_microwave_axis_m() -> np.ndarray:
    face_x = MW["depth"] / 2 + MW_DOOR["thick"] - MW_DOOR["inside"]
    return np.array([face_x - MW_AXIS[0], -MW["width"] / 2 + MW_DOOR["left"] + MW_AXIS[1]])


@pytest.mark.parametrize("way", ["open_at_90", "free_corner"])
def test_a_thick_door_partly_in_the_recess_measured_with_its_thickness_has_its_hinge_line(
    tmp_path: Path, way: str
) -> None:
    from modeller.specs.cabinet_geometry import door_hinge_point_m

    spec = load_spec(write_spec(tmp_path, _microwave_spec(MW_DOOR["thick"], MW_DOOR["inside"], (way,))))
    point = door_hinge_point_m(spec, spec.doors[0])
    # Read to the millimetre: 0.4 mm square, 2.1 mm from the free corner at 45 and 90 degrees.
    assert np.linalg.norm(point[:2] - _true_microwave_axis_m()) < (0.001 if way == "open_at_90" else 0.0025)
    assert hinge_tape_warnings(spec) == []


def test_open_at_90_with_the_door_thickness_wrong_is_off_and_free_corner_says_so(tmp_path: Path) -> None:
    from modeller.specs.cabinet_geometry import door_hinge_point_m

    # The spec's door as thick as it stands out (46 mm), all of it in front: open_at_90 is
    # solved with the wrong inner face and misses the line by about 16 / sqrt(2) ... 16 * sqrt(2) / 2.
    wrong = load_spec(write_spec(tmp_path, _microwave_spec(MW_DOOR["thick"], 0.0, ("open_at_90",)), "wrong.yaml"))
    off = np.linalg.norm(door_hinge_point_m(wrong, wrong.doors[0])[:2] - _true_microwave_axis_m())
    assert off > 0.01, off
    # Both readings: free_corner needs no thickness, places the line, and the solver warns
    # with the thickness that makes the two agree.
    both = load_spec(write_spec(tmp_path, _microwave_spec(MW_DOOR["thick"], 0.0, ("open_at_90", "free_corner")), "both.yaml"))
    assert np.linalg.norm(door_hinge_point_m(both, both.doors[0])[:2] - _true_microwave_axis_m()) < 0.0025
    assert 0.01 < off < 0.016  # 13.4 mm: the microwave was 11.5 mm off
    (warning,) = hinge_tape_warnings(both)
    said = float(warning.split("agree for a door ")[1].split(" mm")[0])
    # The real door is 65 mm from its outer to its inner face; the free corner read to the
    # millimetre says 62 mm.
    assert said == pytest.approx(MW_DOOR["thick"] * 1000, abs=5)
    assert "the spec says 46 mm" in warning and "free_corner's line is used" in warning


@pytest.mark.bpy
def test_the_rebuilt_microwave_opens_like_the_real_one_and_passes_the_gate(tmp_path: Path) -> None:
    from homemodel.evaluation.voxels import voxel_iou
    from homemodel.exchange.model_files import export_model
    from homemodel.model_folder.gate.validate import validate_path
    from modeller import build, build_model

    w, d, h, t = MW["width"], MW["depth"], MW["height"], MW["wall"]
    y = lambda left: -w / 2 + left  # noqa: E731
    body = [
        _box((-d / 2, y(0), 0), (d / 2, y(t), h)),
        _box((-d / 2, y(w - t), 0), (d / 2, y(w), h)),
        _box((-d / 2, y(t), 0), (d / 2, y(w - t), t)),
        _box((-d / 2, y(t), h - t), (d / 2, y(w - t), h)),
        _box((-d / 2, y(t), t), (-d / 2 + t, y(w - t), h - t)),
        _box((-d / 2 + t, y(MW["divider"]), t), (d / 2, y(MW["divider"] + t), h - t)),
        _box((d / 2 - t, y(MW["divider"] + t), t), (d / 2, y(w - t), h - t)),
    ]
    face = d / 2 + MW_DOOR["thick"] - MW_DOOR["inside"]
    g = MW["gap"]
    door = [
        _box((d / 2 + g, y(MW_DOOR["left"]), MW_DOOR["bottom"]),
             (face, y(MW_DOOR["left"] + MW_DOOR["width"]), MW_DOOR["bottom"] + MW_DOOR["height"])),
        _box((d / 2 - MW_DOOR["inside"], y(t + g), t + g),
             (d / 2 + g, y(MW_DOOR["left"] + MW_DOOR["width"]), h - t - g)),
    ]
    turn = _rotation_z(-math.radians(100), _true_microwave_axis_m())
    real_open = trimesh.util.concatenate(body + [p.copy().apply_transform(turn) for p in door])
    spec_path = write_spec(tmp_path, _microwave_spec(MW_DOOR["thick"], MW_DOOR["inside"], ("open_at_90",)))
    model = build_model(spec_path)
    iou = voxel_iou(model.world_mesh({"door_0_hinge": math.radians(100)}), real_open, voxel_size_m=0.005)
    assert iou >= 0.85, iou
    export_model(model, tmp_path / "model")
    report = validate_path(tmp_path / "model")
    assert report.ok, report.format()
    # Readings that disagree with the thickness: the build says so in its summary.
    both = write_spec(tmp_path, _microwave_spec(MW_DOOR["thick"], 0.0, ("open_at_90", "free_corner")), "both.yaml")
    built = build(both, tmp_path / "both")
    assert len(built.warnings) == 1 and built.summary.gate.warnings == built.warnings


# ---------------------------------------------------------------------------- the new fields' rules


def test_a_button_in_a_pocket_may_sit_below_the_face_and_press_in_further_than_it_stands_out(tmp_path: Path) -> None:
    path = REPO / "examples" / "catalogue" / "microwave_thick_door.yaml"
    spec = load_spec(path)
    button = spec.buttons[0]
    assert button.projection_m < 0 < button.travel_m and button.shape == "rectangle"
    data = yaml_data(path)
    data["buttons"][0].pop("pocket")
    with pytest.raises(SpecError, match=r"buttons\.0\.projection_m: .*needs a pocket"):
        load_spec(write_spec(tmp_path, data, "no_pocket.yaml"))
    data = yaml_data(path)
    data["buttons"][0]["travel_m"] = 0.016
    with pytest.raises(SpecError, match=r"buttons\.0\.travel_m: .*goes through its pocket's floor"):
        load_spec(write_spec(tmp_path, data, "too_far.yaml"))
    data = yaml_data(path)
    data["panels"][0]["thickness_m"] = 0.012
    with pytest.raises(SpecError, match=r"buttons\.0\.pocket\.depth_m: .*goes through a panel 0\.012 m thick"):
        load_spec(write_spec(tmp_path, data, "thin_panel.yaml"))


def test_the_new_fields_refuse_what_cannot_be(tmp_path: Path) -> None:
    path = REPO / "examples" / "catalogue" / "base_unit_face_frame_stile.yaml"
    cases = [
        (("drawers", 0, "box_offset_m"), 0.2, r"drawers\.0\.box_offset_m: drawer 0's box spans .* outside its opening"),
        (("face_frame", "overhang_m"), 0.05, r"face_frame\.overhang_m: stiles 0\.04 m wide cannot stand 0\.05 m out"),
        (("face_frame", "stiles", 0, "left_m"), 0.88, r"face_frame\.stiles\.0\.left_m: spans"),
        (("top_panel",), True, r"top_rails: rails go across an open top"),
        (("drawers", 0, "box_bottom_m"), 0.0, r"drawers\.0\.box_bottom_m: drawer 0's box starts at 0\.690 m, below its opening at 0\.700 m"),
        (("drawers", 0, "box_bottom_m"), 0.01, None),
    ]
    for where, value, message in cases:
        data = yaml_data(path)
        node = data
        for part in where[:-1]:
            node = node[part]
        node[where[-1]] = value
        spec_path = write_spec(tmp_path, data, "case.yaml")
        if message is None:
            load_spec(spec_path)
        else:
            with pytest.raises(SpecError, match=message):
                load_spec(spec_path)


def test_a_door_hung_on_a_middle_stile_is_measured_from_the_stile(tmp_path: Path) -> None:
    spec = load_spec(write_spec(tmp_path, _unit_spec()))
    behind, inward = hinge_offsets_m(spec, spec.doors[1])
    assert (behind, inward) == pytest.approx(DOORS[1][2:4], abs=0.0015)


def yaml_data(path: Path) -> dict:
    from spec_edits import read_spec

    return read_spec(path)


# ---------------------------------------------------------------------------- the catalogue's examples, built


def _box_bounds(model, link: str, name: str) -> np.ndarray:
    """(2, 3) low and high corners of a box collision, in the link's frame."""
    collision = next(c for c in model.link(link).collisions if c.name == name)
    half = np.asarray(collision.geometry.size_m) / 2
    centre = collision.link_from_collision[:3, 3]
    return np.stack([centre - half, centre + half])


@pytest.mark.bpy
def test_the_face_frame_example_has_its_members_bottom_shelf_and_top_rails_where_measured() -> None:
    from modeller import build_model

    path = REPO / "examples" / "catalogue" / "base_unit_face_frame_stile.yaml"
    model, w, d = build_model(path), 0.9, 0.56
    y = lambda left: -w / 2 + left  # noqa: E731
    expected = {
        "frame_left": [(d / 2 - 0.019, y(-0.01), 0.1), (d / 2, y(0.03), 0.87)],  # 10 mm out past the side
        "frame_right": [(d / 2 - 0.019, y(0.87), 0.1), (d / 2, y(0.91), 0.87)],
        "frame_rail_0": [(d / 2 - 0.019, y(0.03), 0.66), (d / 2, y(0.87), 0.70)],
        "frame_stile_0": [(d / 2 - 0.019, y(0.43), 0.14), (d / 2, y(0.47), 0.66)],
        "carcass_bottom": [(-d / 2, y(0.018), 0.145), (d / 2, y(0.882), 0.163)],  # 45 mm over a void
        "shelf_0": [(-d / 2 + 0.018, y(0.018), 0.392), (d / 2, y(0.882), 0.42)],  # 28 mm thick
        "top_rail_0": [(d / 2 - 0.1, y(0.018), 0.852), (d / 2, y(0.882), 0.87)],
        "top_rail_1": [(d / 2 - 0.54, y(0.018), 0.852), (d / 2 - 0.44, y(0.882), 0.87)],
    }
    for name, corners in expected.items():
        assert np.allclose(_box_bounds(model, "body", name), corners, atol=1e-9), name
    # Nothing of the carcass under the raised bottom but the sides, the back and the plinth.
    names = [c.name for c in model.link("body").collisions]
    assert names.count("carcass_bottom") == 1 and "carcass_top" not in names
    # The drawer: the second board inside the opening, the box behind it 30 mm above the front's
    # bottom edge, 0.8 m wide and 10 mm right of the front's middle (drawer frame: origin on
    # the front plane at the front's middle, its bottom edge).
    board = _box_bounds(model, "drawer_0", "drawer_0_inner_board")  # 26 mm inside the opening
    assert np.allclose(board[:, 0], [-0.026 - 0.018, -0.026], atol=1e-9)
    floor = _box_bounds(model, "drawer_0", "drawer_0_box_bottom")
    assert np.allclose([floor[0, 0], floor[1, 0]], [-0.044 - 0.45, -0.044], atol=1e-9)
    assert np.allclose([floor[0, 1], floor[1, 1]], [0.01 - 0.4, 0.01 + 0.4], atol=1e-9)
    assert floor[0, 2] == pytest.approx(0.03, abs=1e-9)
    # The right door hangs on the stile: its hinge line on the stile (the default edge hinge).
    hinge = model.joint("door_1_hinge").parent_from_joint[:3, 3]
    assert y(0.43) <= hinge[1] <= y(0.47)


@pytest.mark.bpy
def test_the_thick_door_microwave_has_its_plug_pockets_buttons_knob_and_plate() -> None:
    from modeller import build_model

    path = REPO / "examples" / "catalogue" / "microwave_thick_door.yaml"
    model, w, d = build_model(path), 0.5, 0.4
    y = lambda left: -w / 2 + left  # noqa: E731
    world = model.world_from_links()
    # The door: 65 mm from its face (49 mm out) to its inner part's face (16 mm in).
    door_points = np.concatenate(
        [trimesh.transform_points(v.mesh.vertices, world["door_0"] @ v.link_from_visual) for v in model.link("door_0").visuals]
    )
    assert door_points[:, 0].max() == pytest.approx(d / 2 + 0.049 + 0.0005, abs=1e-6)  # the glass 0.5 mm proud
    assert door_points[:, 0].min() == pytest.approx(d / 2 - 0.016, abs=1e-6)
    # The inner part stays 3 mm clear of the cavity's walls and divider.
    plug = _box_bounds(model, "door_0", "door_0_inner") + world["door_0"][:3, 3]
    assert plug[0, 1] == pytest.approx(y(0.012 + 0.003)) and plug[1, 1] == pytest.approx(y(0.375))
    # The button: pressed in 8 mm, its face 1 mm below the panel's (20 mm thick) in a 16 mm pocket.
    press = model.joint("button_0_press")
    assert press.type == "prismatic" and press.limits.upper == pytest.approx(0.008)
    button = _box_bounds(model, "button_0", "button_0")
    assert button[1, 0] == pytest.approx(-0.001) and button[0, 0] == pytest.approx(-0.016 + 0.008)
    assert np.allclose(button[:, 1:], [[-0.041, -0.031], [0.041, 0.031]])
    # Its pocket: the panel's collision round it is the pocket's floor, 16 mm down, 4 mm clear.
    panel = [c for c in model.link("body").collisions if c.name.startswith("panel_0_")]
    at_button = [
        _box_bounds(model, "body", c.name) for c in panel
        if abs(c.link_from_collision[1, 3] - y(0.44)) < 1e-6 and abs(c.link_from_collision[2, 3] - 0.07) < 1e-6
    ]
    (floor,) = at_button
    assert floor[1, 0] == pytest.approx(d / 2 - 0.016) and floor[0, 0] == pytest.approx(d / 2 - 0.02)
    assert floor[1, 1] - floor[0, 1] == pytest.approx(0.082 + 0.008)
    # The knob turns without stops, keeping its named states; the plate is 17 mm right of the cavity's middle.
    turn = model.joint("knob_0_turn")
    assert turn.type == "continuous" and turn.limits is None and [s.name for s in turn.states][:2] == ["off", "1 min"]
    spin = model.joint("turntable_spin").parent_from_joint[:3, 3]
    assert spin[1] == pytest.approx(y((0.012 + 0.38) / 2 + 0.017))


@pytest.mark.bpy
@pytest.mark.parametrize(("meeting_gap_m", "passes"), [(0.0, False), (0.002, True)])
def test_the_gate_refuses_inset_doors_without_clearance(tmp_path: Path, meeting_gap_m: float, passes: bool) -> None:
    """The catalogue's inset unit (2 mm all round) with its two doors meeting without a gap:
    each door's free corner cuts its neighbour in its first degrees (the last round passed it)."""
    from spec_edits import read_spec, with_field

    from homemodel.exchange.model_files import export_model
    from homemodel.model_folder.gate.validate import validate_path
    from modeller import build_model

    data = read_spec(REPO / "examples" / "catalogue" / "base_unit_inset.yaml")
    # Doors 0.02..0.3 - g/2 and 0.3 + g/2..0.58 (the opening is 0.018..0.582, 2 mm clear).
    width = round(0.28 - meeting_gap_m / 2, 4)
    data = with_field(with_field(data, "doors.0.width_m", width), "doors.1.width_m", width)
    data = with_field(data, "doors.1.left_m", round(0.58 - width, 4))
    export_model(build_model(write_spec(tmp_path, data)), tmp_path / "model")
    collisions = next(c for c in validate_path(tmp_path / "model").checks if c.name == "collisions")
    assert collisions.passed == passes, collisions.detail
    if not passes:
        assert "'door_0' and 'door_1'" in collisions.detail and "deg from rest" in collisions.detail


def test_the_face_frame_unit_measured_at_the_free_corner_has_its_hinge_lines_too(tmp_path: Path) -> None:
    """The same doors read the guide's other way: the free corner at 45 and 90 degrees."""
    from modeller.specs.cabinet_geometry import door_hinge_point_m

    _, axes = _real_unit()
    spec = load_spec(write_spec(tmp_path, _unit_spec("free_corner")))
    for k, door in enumerate(spec.doors):
        assert np.linalg.norm(door_hinge_point_m(spec, door)[:2] - axes[k]) < 0.005  # 0.9 and 0.8 mm measured


# ---------------------------------------------------------------------------- a chest whose top overhangs

CHEST_W, CHEST_D, CARCASS_H, SLAB_T = 0.8, 0.45, 0.84, 0.022
SLAB_OUT = {"front_m": 0.025, "sides_m": 0.015, "back_m": 0.004}  # past the carcass' faces


def _real_chest() -> tuple[trimesh.Trimesh, trimesh.Trimesh]:
    """The chest's carcass under its top slab, and its top drawer's front (closed)."""
    half_w, half_d, out = CHEST_W / 2, CHEST_D / 2, SLAB_OUT
    carcass = [
        _box((-half_d, -half_w, 0.0), (half_d, -half_w + T, CARCASS_H)),
        _box((-half_d, half_w - T, 0.0), (half_d, half_w, CARCASS_H)),
        _box((-half_d, -half_w, 0.0), (-half_d + T, half_w, CARCASS_H)),
        _box((-half_d, -half_w, 0.0), (half_d, half_w, T)),
    ]
    slab = _box((-half_d - out["back_m"], -half_w - out["sides_m"], CARCASS_H),
                (half_d + out["front_m"], half_w + out["sides_m"], CARCASS_H + SLAB_T))
    front = _box((half_d + GAP, -half_w + 0.002, 0.45), (half_d + GAP + DOOR, half_w - 0.002, CARCASS_H - 0.003))
    return trimesh.util.concatenate([*carcass, slab]), front


def _chest_spec(body: trimesh.Trimesh, front: trimesh.Trimesh) -> dict:
    """The installer's readings: the outer size and the slab's overhangs by a straight edge laid
    along the carcass' front, each side and the back, to the slab's edge."""
    (fx0, fy0, fz0), (_, fy1, fz1) = front.bounds
    drawer = {"left_m": _read(fy0 + CHEST_W / 2), "width_m": _read(fy1 - fy0), "bottom_m": _read(fz0),
              "height_m": _read(fz1 - fz0), "depth_m": 0.4, "travel_m": 0.35, "handle": {"type": "none"}}
    return {"kind": "cupboard", "width_m": CHEST_W, "depth_m": CHEST_D, "height_m": _read(body.bounds[1, 2]),
            "door_gap_m": _read(fx0 - CHEST_D / 2), "top_thickness_m": SLAB_T,
            "top_overhang": {side: _read(value) for side, value in SLAB_OUT.items()}, "doors": [], "drawers": [drawer]}


@pytest.mark.bpy
def test_a_top_slab_overhanging_the_carcass_is_built_as_far_out_as_the_real_one(tmp_path: Path) -> None:
    from modeller import build_model

    real_body, real_front = _real_chest()
    model = build_model(write_spec(tmp_path, _chest_spec(real_body, real_front)))
    world = model.world_from_links()
    body = np.concatenate(
        [trimesh.transform_points(v.mesh.vertices, world["body"] @ v.link_from_visual) for v in model.link("body").visuals]
    )
    # The body's extent is the slab's: out past the front, each side and the back by the tape.
    assert np.allclose([body.min(0), body.max(0)], real_body.bounds, atol=TAPE_STEP_M)
    # Its collision too, and the drawer's front closes under the slab, not into it.
    slab = real_body.bounds.copy()
    slab[0, 2] = CARCASS_H
    assert np.allclose(_box_bounds(model, "body", "carcass_top"), slab, atol=TAPE_STEP_M)
    # The sides and back end under the slab, as the real ones do, not through it.
    walls = [_box_bounds(model, "body", c.name) for c in model.link("body").collisions if c.name != "carcass_top"]
    assert max(wall[1, 2] for wall in walls) == pytest.approx(CARCASS_H, abs=TAPE_STEP_M)
    drawer = np.concatenate(
        [trimesh.transform_points(v.mesh.vertices, world["drawer_0"] @ v.link_from_visual) for v in model.link("drawer_0").visuals]
    )
    assert drawer[:, 2].max() == pytest.approx(real_front.bounds[1, 2], abs=TAPE_STEP_M)
    assert drawer[:, 2].max() < CARCASS_H


def test_an_overhanging_top_refuses_an_open_top_and_fronts_reaching_into_it(tmp_path: Path) -> None:
    real_body, real_front = _real_chest()
    data = _chest_spec(real_body, real_front)
    load_spec(write_spec(tmp_path, data))
    cases = [
        ("top_panel", False, r"top_overhang: an open top \(top_panel: false\) has no top to overhang"),
        ("drawers.0.height_m", 0.4, r"top_overhang\.front_m: a top 0\.025 m over the front would cut drawer 0, "
                                    r"which reaches 0\.850 m up, past the top's underside at 0\.840 m"),
        ("top_overhang.sides_m", -0.01, r"top_overhang\.sides_m: Input should be greater than or equal to 0"),
    ]
    for dotted, value, message in cases:
        with pytest.raises(SpecError, match=message):
            load_spec(write_spec(tmp_path, with_field(data, dotted, value), "case.yaml"))
