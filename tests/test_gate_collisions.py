"""The gate's collision check: pybullet sweeps every joint; no part may pass through another."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import trimesh

from homemodel.exchange.model_files import write_model_files
from homemodel.model_folder.gate.collisions import MESH_PENETRATION_TOLERANCE_M, CollisionOptions, collisions_check
from homemodel.model_folder.gate.real_meshes import RealMeshes
from homemodel.model_folder.gate.validate import validate_path

INERTIAL = '<inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>'

# A cupboard body seen from above: a side wall at y = -0.30..-0.28 and a back wall at
# x = -0.25..-0.23; the front plane at x = 0.25. A door 0.5 m wide (y -0.28..0.22 when
# closed) turns about a vertical hinge; its origin is the hinge, the door in its frame at
# y >= 0 (hinged on its left, seen from in front).
CUPBOARD = """<?xml version="1.0"?>
<robot name="cupboard">
  <link name="body">{inertial}
    <collision name="side"><origin xyz="0 -0.29 0.4"/><geometry><box size="0.5 0.02 0.8"/></geometry></collision>
    <collision name="back"><origin xyz="-0.24 0 0.4"/><geometry><box size="0.02 0.6 0.8"/></geometry></collision>
  </link>
  <link name="door">{inertial}
    <collision><origin xyz="-0.01 0.25 0.35"/><geometry><box size="0.02 0.5 0.7"/></geometry></collision>
  </link>
  <link name="handle">{inertial}
    <collision><origin xyz="0 0 0"/><geometry><box size="0.06 0.02 0.16"/></geometry></collision>
  </link>
  <joint name="door_hinge" type="revolute">
    <parent link="body"/><child link="door"/>
    <origin xyz="{hinge_x} -0.28 0.05"/><axis xyz="0 0 {axis_z}"/>
    <limit lower="0" upper="{upper}" effort="10" velocity="1"/>
  </joint>
  <joint name="handle_mount" type="fixed">
    <parent link="door"/><child link="handle"/><origin xyz="0.0 0.45 0.35"/>
  </joint>
  {extra}
</robot>
"""


def _write(folder: Path, *, hinge_x: float = 0.27, axis_z: float = -1, upper: float = 1.7, extra: str = "") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    urdf = folder / "model.urdf"
    urdf.write_text(CUPBOARD.format(inertial=INERTIAL, hinge_x=hinge_x, axis_z=axis_z, upper=upper, extra=extra))
    return urdf


def _depths_mm(detail: str) -> list[float]:
    return [float(m) for m in re.findall(r"pass ([0-9.]+) mm into each other", detail)]


def _points_m(detail: str) -> list[np.ndarray]:
    return [np.array(m, dtype=float) for m in re.findall(r"at \(([-0-9.]+), ([-0-9.]+), ([-0-9.]+)\) m", detail)]


def test_door_swinging_outward_passes(tmp_path: Path) -> None:
    # The hinge on the door's outer face (x = 0.27) and the door turning out: it never enters the body.
    check = collisions_check(_write(tmp_path))
    assert check.passed, check.detail
    assert check.name == "collisions"
    # The handle is welded to the door; body-door, body-handle: 2 pairs at rest, at the limits,
    # the quarters of the range and 12 small turns from rest.
    assert check.detail.startswith("2 link pairs at 17 joint configurations")
    assert "WARNING" not in check.detail


def test_door_turning_the_wrong_way_swings_through_the_side_wall(tmp_path: Path) -> None:
    # Axis +z: the free edge swings inward; at 1.7 rad the door runs from the hinge
    # (0.27, -0.28) back to (-0.23, -0.34), through the side wall.
    check = collisions_check(_write(tmp_path, axis_z=1))
    assert not check.passed
    assert "door_hinge at upper (1.7)" in check.detail
    assert "'body' and 'door'" in check.detail
    assert max(_depths_mm(check.detail)) > 10


def test_a_drawer_pushed_into_the_back_wall_fails_by_its_depth(tmp_path: Path) -> None:
    # A drawer box x -0.2..0.2 sliding back (-x) by 0.06 m: its back at -0.26 lies 30 mm past
    # the back wall's inner face (-0.23), the shortest way out.
    drawer = (
        f'<link name="drawer">{INERTIAL}<collision><geometry><box size="0.4 0.2 0.1"/></geometry></collision></link>'
        '<joint name="drawer_slide" type="prismatic"><parent link="body"/><child link="drawer"/>'
        '<origin xyz="0 0 0.4"/><axis xyz="-1 0 0"/><limit lower="0" upper="0.06" effort="1" velocity="1"/></joint>'
    )
    check = collisions_check(_write(tmp_path, extra=drawer))
    assert not check.passed
    problems = check.detail.split("; ")
    alone = [p for p in problems if p.startswith("drawer_slide at upper (0.06)")]
    assert len(alone) == 1 and "'body' and 'drawer'" in alone[0]
    assert _depths_mm(alone[0]) == [pytest.approx(30.0, abs=0.1)]
    # Three quarters of the way (45 mm back) it is 15 mm in; a quarter of the way, not in at all.
    assert any(p.startswith("drawer_slide at 0.045 (75% of its range)") and "15.0 mm" in p for p in problems)
    assert not any(p.startswith("drawer_slide at 0.015") for p in problems)


def test_overlap_at_rest_is_reported_once_and_welded_links_are_not_compared(tmp_path: Path) -> None:
    # A shelf link inside the back wall (x -0.25..-0.22 in a wall -0.25..-0.23) overlaps it
    # at rest, by the 20 mm it must move to get out; the handle overlaps its own door by
    # 10 mm, which is allowed: they are welded.
    shelf = (
        f'<link name="shelf">{INERTIAL}<collision><origin xyz="-0.235 0 0.4"/>'
        '<geometry><box size="0.03 0.3 0.02"/></geometry></collision></link>'
        '<joint name="shelf_slide" type="prismatic"><parent link="body"/><child link="shelf"/>'
        '<origin xyz="0 0 0"/><axis xyz="1 0 0"/><limit lower="0" upper="0.001" effort="1" velocity="1"/></joint>'
    )
    check = collisions_check(_write(tmp_path, extra=shelf))
    assert not check.passed
    lines = check.detail.split("; ")
    at_rest = [line for line in lines if line.startswith("at rest")]
    assert len(at_rest) == 1 and at_rest[0].startswith("at rest: 'body' and 'shelf' pass 20.0 mm into each other at (")
    # Where: inside the overlap of shelf and wall, x -0.25..-0.23, y -0.15..0.15, z 0.39..0.41.
    (point,) = _points_m(at_rest[0])
    assert np.all(point >= np.array([-0.25, -0.15, 0.39]) - 1e-3) and np.all(point <= np.array([-0.23, 0.15, 0.41]) + 1e-3)
    # Moving the shelf 1 mm out makes it no deeper, so it is not reported again.
    assert not any(line.startswith("shelf_slide") for line in lines)
    assert "handle" not in check.detail


def test_touching_parts_and_mesh_margins_are_not_penetrations(tmp_path: Path) -> None:
    # Two mesh cubes face to face: pybullet inflates each convex mesh by its margin and
    # reports -2 mm, which is not an overlap.
    (tmp_path / "cube.obj").write_text(trimesh.exchange.obj.export_obj(trimesh.creation.box((0.2, 0.2, 0.2))))
    urdf = tmp_path / "model.urdf"
    urdf.write_text(
        f"""<robot name="cubes">
  <link name="a">{INERTIAL}<collision><geometry><mesh filename="cube.obj"/></geometry></collision></link>
  <link name="b">{INERTIAL}<collision><geometry><mesh filename="cube.obj"/></geometry></collision></link>
  <joint name="slide" type="prismatic"><parent link="a"/><child link="b"/><origin xyz="0 0.2 0"/>
    <axis xyz="0 1 0"/><limit lower="-0.0005" upper="0.1" effort="1" velocity="1"/></joint>
</robot>"""
    )
    check = collisions_check(urdf)
    assert check.passed, check.detail
    # At the lower limit the cubes overlap by 0.5 mm: under the tolerance for meshes (a hull's
    # depth is an upper bound), but measured.
    deepest = float(re.search(r"deepest contact ([0-9.]+) mm", check.detail).group(1))
    assert deepest == pytest.approx(0.5, abs=0.05) and deepest < MESH_PENETRATION_TOLERANCE_M * 1000


def test_continuous_joints_are_turned_round(tmp_path: Path) -> None:
    # A bar on a continuous joint sticking out sideways: turned half round it hits a post.
    urdf = tmp_path / "model.urdf"
    urdf.write_text(
        f"""<robot name="spinner">
  <link name="base">{INERTIAL}<collision><origin xyz="0 -0.3 0"/><geometry><box size="0.05 0.05 0.05"/></geometry></collision></link>
  <link name="bar">{INERTIAL}<collision><origin xyz="0.2 0 0"/><geometry><box size="0.4 0.02 0.02"/></geometry></collision></link>
  <joint name="spin" type="continuous"><parent link="base"/><child link="bar"/><axis xyz="0 0 1"/></joint>
</robot>"""
    )
    check = collisions_check(urdf)
    assert not check.passed and "spin at -1.57 rad" in check.detail


def test_the_gate_runs_the_check_and_skips_it_on_a_broken_tree(tmp_path: Path) -> None:
    report = validate_path(_write(tmp_path / "good"))
    names = [c.name for c in report.checks]
    assert names[-2:] == ["collisions", "physics"] and report.checks[-2].passed
    broken = _write(tmp_path / "broken", extra='<link name="orphan"/>')
    report = validate_path(broken)
    check = {c.name: c for c in report.checks}["collisions"]
    assert not check.passed and check.detail.startswith("not run: pybullet crashes")


@pytest.mark.bpy
def test_a_modelled_cupboard_passes_and_its_door_mirrored_into_the_body_fails(
    tmp_path: Path, kitchen_dir: Path
) -> None:
    from modeller import build_model

    model = build_model(kitchen_dir / "cupboard.yaml")
    write_model_files(model, tmp_path / "good")
    report = validate_path(tmp_path / "good")
    assert report.ok, report.format()

    # The left door turning the wrong way swings back through the side wall; at its upper
    # limit it lies outside the wall again, so it is caught on the way.
    hinge = model.joint("door_0_hinge")
    hinge.axis = -hinge.axis
    write_model_files(model, tmp_path / "bad")
    check = {c.name: c for c in validate_path(tmp_path / "bad").checks}["collisions"]
    assert not check.passed
    assert "door_0_hinge at 0.8727 (50% of its range)" in check.detail
    assert "'body' and 'door_0'" in check.detail
    assert np.max(_depths_mm(check.detail)) > 5


# A microwave seen as an imported model: its body one concave mesh (a 0.4 x 0.5 x 0.3 m box
# with a cavity open at the front, x = +0.2), a turntable plate in the cavity on a vertical
# continuous joint, a door on a vertical hinge at the front's left edge.
MICROWAVE = """<?xml version="1.0"?>
<robot name="microwave">
  <link name="body">{inertial}
    <collision><geometry><mesh filename="meshes/frame.obj"/></geometry></collision>
  </link>
  <link name="turntable">{inertial}
    <collision><origin xyz="0 0 0.003"/><geometry><cylinder radius="{radius}" length="0.006"/></geometry></collision>
  </link>
  <link name="door">{inertial}
    <collision><origin xyz="-0.01 0.25 0"/><geometry><box size="0.02 0.5 0.3"/></geometry></collision>
  </link>
  <joint name="turntable_turn" type="continuous">
    <parent link="body"/><child link="turntable"/><origin xyz="0.03 0 -0.128"/><axis xyz="0 0 1"/>
  </joint>
  <joint name="door_hinge" type="revolute">
    <parent link="body"/><child link="door"/><origin xyz="0.221 -0.25 0"/><axis xyz="0 0 -1"/>
    <limit lower="0" upper="1.6" effort="10" velocity="1"/>
  </joint>
</robot>
"""


def _microwave(folder: Path, radius: float) -> Path:
    (folder / "meshes").mkdir(parents=True, exist_ok=True)
    outer = trimesh.creation.box((0.4, 0.5, 0.3))
    cavity = trimesh.creation.box((0.4, 0.44, 0.26))
    cavity.apply_translation((0.03, 0, 0))
    frame = outer.difference(cavity)
    assert frame.is_watertight and frame.convex_hull.volume > 3 * frame.volume  # far from convex
    frame.export(folder / "meshes" / "frame.obj")
    urdf = folder / "model.urdf"
    urdf.write_text(MICROWAVE.format(inertial=INERTIAL, radius=radius))
    return urdf


def test_parts_inside_a_concave_mesh_are_not_reported_but_real_intrusions_are(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """pybullet's hull of the frame fills the cavity: the turntable and the closed door lie
    in it. Only contacts the real triangles confirm (FCL) count."""
    good = _microwave(tmp_path / "good", radius=0.15)
    check = collisions_check(good)
    assert check.passed, check.detail
    with monkeypatch.context() as patched:  # believing the hulls, as the sweep did before
        patched.setattr(RealMeshes, "touch", lambda *args: True)
        hulls = collisions_check(good)
    assert not hulls.passed and "'body' and 'turntable'" in hulls.detail and max(_depths_mm(hulls.detail)) > 10
    # A plate wider than the cavity (0.44 m) cuts into the side walls, whatever its angle.
    wide = collisions_check(_microwave(tmp_path / "wide", radius=0.25))
    assert not wide.passed and "'body' and 'turntable'" in wide.detail


# ---------------------------------------------------------------------------- rubbing against breaking

# Seen from above: a side panel at y -0.018..0 reaching back from the front plane x = 0, and an
# overlay door 18 mm thick closed 2 mm in front of it (x 0.002..0.020, y -0.016..0.384, 0.7 m
# high), on a vertical axis at (axis_x, axis_y) turning its free edge forward.
RUBBING = """<?xml version="1.0"?>
<robot name="rubbing">
  <link name="body">{inertial}
    <collision name="side"><origin xyz="-0.15 -0.009 0.4"/><geometry><box size="0.3 0.018 0.8"/></geometry></collision>
  </link>
  <link name="door">{inertial}
    <collision><origin xyz="{door_x} {door_y} 0.35"/><geometry><box size="0.018 0.4 0.7"/></geometry></collision>
  </link>
  <joint name="door_hinge" type="revolute">
    <parent link="body"/><child link="door"/><origin xyz="{axis_x} {axis_y} 0.05"/><axis xyz="0 0 -1"/>
    <limit lower="0" upper="{upper}" effort="10" velocity="1"/>
  </joint>
</robot>
"""


def _rect(x0: float, x1: float, y0: float, y1: float) -> np.ndarray:
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])


def _overlap_m(a: np.ndarray, b: np.ndarray) -> float:
    """How far two convex quadrilaterals overlap (separating axes; <= 0: apart)."""
    depth = np.inf
    for poly in (a, b):
        for k in range(4):
            edge = poly[(k + 1) % 4] - poly[k]
            normal = np.array([-edge[1], edge[0]]) / np.linalg.norm(edge)
            on_a, on_b = a @ normal, b @ normal
            depth = min(depth, min(on_a.max(), on_b.max()) - max(on_a.min(), on_b.min()))
    return float(depth)


def _door_in_side_m(axis: tuple[float, float], angle_rad: float, door: np.ndarray, side: np.ndarray) -> float:
    """The test's own depth: the door's section turned outward (about -z) by `angle_rad`."""
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    rel = door - np.asarray(axis)
    turned = np.stack([rel[:, 0] * c + rel[:, 1] * s, -rel[:, 0] * s + rel[:, 1] * c], axis=1) + axis
    return _overlap_m(turned, side)


def _rubbing_door(folder: Path, axis: tuple[float, float], upper: float = math.radians(100)) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    urdf = folder / "model.urdf"
    door_x, door_y = 0.011 - axis[0], 0.184 - axis[1]
    urdf.write_text(
        RUBBING.format(inertial=INERTIAL, axis_x=axis[0], axis_y=axis[1], door_x=door_x, door_y=door_y, upper=upper)
    )
    return urdf


def test_a_hinge_line_rubbing_its_frame_by_a_millimetre_is_a_warning_with_its_depth(tmp_path: Path) -> None:
    axis = (-0.004, -0.012)  # 4 mm behind the front plane: the door's edge grazes the side's front
    door, side = _rect(0.002, 0.020, -0.016, 0.384), _rect(-0.3, 0.0, -0.018, 0.0)
    dense = max(_door_in_side_m(axis, a, door, side) for a in np.radians(np.linspace(0, 100, 801)))
    assert 0.001 < dense < 0.0015  # the truth by the test's own sweep: 1.2 mm
    check = collisions_check(_rubbing_door(tmp_path, axis))
    assert check.passed, check.detail
    (warning,) = [part for part in check.detail.split("; WARNING ")[1:]]
    assert warning.startswith("rubs within 3 mm at a hinge line: door_hinge at ")
    assert "'body' and 'door'" in warning
    (depth_mm,) = _depths_mm(warning)
    angle = float(re.search(r"door_hinge at ([0-9.]+)", warning).group(1))
    # The depth reported is the depth at the angle it names, and near the sweep's deepest.
    assert depth_mm == pytest.approx(_door_in_side_m(axis, angle, door, side) * 1000, abs=0.05)
    assert dense * 1000 - 0.3 < depth_mm <= dense * 1000 + 0.05
    # Where it lies: on the side's front edge, within a few millimetres of the hinge line.
    (point,) = _points_m(warning)
    assert abs(point[0]) < 0.004 and -0.02 < point[1] < 0.002
    off_line_mm = float(re.search(r"([0-9]+) mm from its hinge line", warning).group(1))
    assert off_line_mm == pytest.approx(np.hypot(point[0] - axis[0], point[1] - axis[1]) * 1000, abs=1)
    # A tolerance stated tighter than the rub makes it a failure.
    strict = collisions_check(_rubbing_door(tmp_path / "strict", axis), CollisionOptions(hinge_rub_tolerance_m=0.001))
    assert not strict.passed and "from its hinge line" in strict.detail


def test_a_hinge_line_deeper_than_the_tolerance_fails(tmp_path: Path) -> None:
    axis = (-0.006, -0.004)  # 6 mm behind the front, 12 mm in from the edge: the edge cuts the side
    door, side = _rect(0.002, 0.020, -0.016, 0.384), _rect(-0.3, 0.0, -0.018, 0.0)
    assert max(_door_in_side_m(axis, a, door, side) for a in np.radians(np.linspace(0, 100, 801))) > 0.008
    check = collisions_check(_rubbing_door(tmp_path, axis))
    assert not check.passed
    assert max(_depths_mm(check.detail)) > 7.5 and "WARNING" not in check.detail


# An inset door between two side panels (y -0.018..0 and w..w + 0.018), its outer face flush
# with their fronts (x = 0), 18 mm thick, hinged on its outer edge at (0, 0).
INSET = """<?xml version="1.0"?>
<robot name="inset">
  <link name="body">{inertial}
    <collision name="left"><origin xyz="-0.15 -0.009 0.4"/><geometry><box size="0.3 0.018 0.8"/></geometry></collision>
    <collision name="right"><origin xyz="-0.15 {right_y} 0.4"/><geometry><box size="0.3 0.018 0.8"/></geometry></collision>
  </link>
  <link name="door">{inertial}
    <collision><origin xyz="-0.009 {door_y} 0.35"/><geometry><box size="0.018 {door_w} 0.7"/></geometry></collision>
  </link>
  <joint name="door_hinge" type="revolute">
    <parent link="body"/><child link="door"/><origin xyz="0 0 0.05"/><axis xyz="0 0 -1"/>
    <limit lower="0" upper="1.9" effort="10" velocity="1"/>
  </joint>
</robot>
"""


@pytest.mark.parametrize(("clearance_m", "passes"), [(0.0, False), (0.002, True)])
def test_an_inset_door_without_clearance_cuts_its_frame_with_its_free_corner(
    tmp_path: Path, clearance_m: float, passes: bool
) -> None:
    # The free edge's inner corner swings out to sqrt(w^2 + t^2), t^2 / 2w = 0.4 mm past a
    # 0.4 m door's width, in the first 5 degrees: without clearance it cuts the far side.
    width, gap = 0.4, clearance_m
    urdf = tmp_path / "model.urdf"
    urdf.write_text(
        INSET.format(inertial=INERTIAL, right_y=width + gap + 0.009, door_y=width / 2, door_w=width)
    )
    door, far_side = _rect(-0.018, 0.0, 0.0, width), _rect(-0.3, 0.0, width + gap, width + gap + 0.018)
    truth = max(_door_in_side_m((0.0, 0.0), a, door, far_side) for a in np.radians(np.linspace(0, 20, 2001)))
    check = collisions_check(urdf)
    assert check.passed == passes, check.detail
    if passes:
        assert truth <= 0
        return
    assert truth == pytest.approx(0.018**2 / (2 * width), abs=2e-5)
    assert "deg from rest" in check.detail and "'body' and 'door'" in check.detail
    # pybullet's depth is the corner's along the contact normal it picks (the door's end face),
    # w (1 - cos a) at the angle sampled, not the shortest way out, so it is smaller.
    assert 0.15 < max(_depths_mm(check.detail)) <= truth * 1000 + 0.02
    # Far from the hinge line: at the free edge, 0.4 m away.
    assert all(point[1] > width - 0.01 for point in _points_m(check.detail))


def test_collision_options_refuse_negative_tolerances() -> None:
    with pytest.raises(ValueError, match="hinge_rub_tolerance_m=-0.001"):
        CollisionOptions(hinge_rub_tolerance_m=-0.001).check()


# The inset door on a cup hinge's axis, 4 mm behind its face and 4 mm in from its edge: its
# outer hinge-side corner swings out by (sqrt(2) - 1) x 4 = 1.66 mm, into the side if the
# reveal there is smaller.
INSET_CUP = """<?xml version="1.0"?>
<robot name="inset_cup">
  <link name="body">{inertial}
    <collision name="left"><origin xyz="-0.15 -0.009 0.4"/><geometry><box size="0.3 0.018 0.8"/></geometry></collision>
    <collision name="right"><origin xyz="-0.15 0.411 0.4"/><geometry><box size="0.3 0.018 0.8"/></geometry></collision>
  </link>
  <link name="door">{inertial}
    <collision><origin xyz="-0.005 {door_y} 0.35"/><geometry><box size="0.018 {door_w} 0.7"/></geometry></collision>
  </link>
  <joint name="door_hinge" type="revolute">
    <parent link="body"/><child link="door"/><origin xyz="-0.004 {axis_y} 0.05"/><axis xyz="0 0 -1"/>
    <limit lower="0" upper="1.9" effort="10" velocity="1"/>
  </joint>
</robot>
"""


@pytest.mark.parametrize(("reveal_m", "verdict"), [(0.0, "fails"), (0.001, "rubs"), (0.002, "clear")])
def test_an_inset_door_touching_its_side_when_shut_fails_and_one_with_a_reveal_rubs_or_clears(
    tmp_path: Path, reveal_m: float, verdict: str
) -> None:
    width = 0.4 - reveal_m - 0.002  # 2 mm clear on the free side
    axis_y = reveal_m + 0.004
    urdf = tmp_path / "model.urdf"
    urdf.write_text(INSET_CUP.format(inertial=INERTIAL, axis_y=axis_y, door_y=reveal_m + width / 2 - axis_y, door_w=width))
    check = collisions_check(urdf)
    assert check.passed == (verdict != "fails"), check.detail
    assert ("WARNING" in check.detail) == (verdict == "rubs"), check.detail
    if verdict == "fails":
        assert "touching it at rest (no clearance)" in check.detail
        assert max(_depths_mm(check.detail)) == pytest.approx(1.66, abs=0.25)
    if verdict == "rubs":
        (depth,) = _depths_mm(check.detail.split("WARNING")[1])
        assert depth == pytest.approx(0.66, abs=0.25)
