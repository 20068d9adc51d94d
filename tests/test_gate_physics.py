"""The gate's physics check (a model left alone stays put) and the gate's cost on long chains."""

from __future__ import annotations

import math
import resource
import time
from collections.abc import Callable
from pathlib import Path

from homemodel.core.c_stdio_capture import captured_c_output
from homemodel.model_folder.gate.physics import MAX_DRIFT_M, physics_check, physics_problems
from homemodel.model_folder.gate.validate import PYBULLET_MAX_JOINTS, ValidationReport, validate_path

INERTIAL = '<inertial><origin xyz="{com}"/><mass value="{kg}"/><inertia ixx="{i}" ixy="0" ixz="0" iyy="{i}" iyz="0" izz="{i}"/></inertial>'

# An oven body with a 6 kg door hinged along its bottom edge (axis +y, opening down), its
# centre of mass 0.3 m above the hinge.
OVEN = """<?xml version="1.0"?>
<robot name="oven">
  <link name="body">{body_inertial}
    <collision><origin xyz="0 0 0.4"/><geometry><box size="0.6 0.6 0.8"/></geometry></collision>
  </link>
  <link name="door">{door_inertial}
    <collision><origin xyz="-0.02 0 0.3"/><geometry><box size="0.04 0.6 0.6"/></geometry></collision>
  </link>
  <joint name="door_hinge" type="revolute">
    <parent link="body"/><child link="door"/>
    <origin xyz="0.34 0 0.1"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="1.5708" effort="30" velocity="1"/>
    {dynamics}
  </joint>
</robot>
"""


def _oven(folder: Path, dynamics: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    urdf = folder / "model.urdf"
    urdf.write_text(
        OVEN.format(
            body_inertial=INERTIAL.format(com="0 0 0.4", kg=40, i=2.0),
            door_inertial=INERTIAL.format(com="-0.02 0 0.3", kg=6, i=0.2),
            dynamics=dynamics,
        )
    )
    return urdf


def test_a_bottom_hinged_door_without_friction_falls_and_fails(tmp_path: Path) -> None:
    check = physics_check(_oven(tmp_path, ""))
    assert not check.passed
    assert "door_hinge moved" in check.detail and "from 45.0 deg in 1 s, left alone" in check.detail


def test_friction_that_holds_the_door_passes_and_reports_the_drift(tmp_path: Path) -> None:
    # At 45 degrees gravity turns the door with 6 kg x 9.81 x 0.3 m x sin 45 = 12.5 N·m.
    held = physics_check(_oven(tmp_path / "held", '<dynamics damping="5" friction="15"/>'))
    assert held.passed, held.detail
    assert "door_hinge moved 0.00 deg from 45.0 deg" in held.detail
    weak = physics_check(_oven(tmp_path / "weak", '<dynamics damping="5" friction="10"/>'))
    assert not weak.passed and "door_hinge moved" in weak.detail


# A small object: a 0.2 kg block 4 x 4 x 10 cm, its base at z = 0; `{collision}` decides
# whether it stands on its base or balances on a point under an off-centre centre of mass.
SMALL = """<?xml version="1.0"?>
<robot name="block">
  <link name="body">{inertial}
    <collision><origin xyz="{xyz}"/><geometry>{geometry}</geometry></collision>
  </link>
</robot>
"""


def _small(folder: Path, *, xyz: str, geometry: str, com: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    urdf = folder / "model.urdf"
    urdf.write_text(SMALL.format(inertial=INERTIAL.format(com=com, kg=0.2, i=2e-4), xyz=xyz, geometry=geometry))
    return urdf


def test_a_small_object_standing_on_its_base_stays_and_one_on_a_point_topples(tmp_path: Path) -> None:
    standing = _small(tmp_path / "standing", xyz="0 0 0.05", geometry='<box size="0.04 0.04 0.1"/>', com="0 0 0.05")
    with captured_c_output():
        problems, summary, drifts, resting = physics_problems(standing)
    assert not problems and drifts == [] and resting is not None and resting < MAX_DRIFT_M / 5
    assert "set free on a floor, moved" in summary
    point = _small(tmp_path / "point", xyz="0 0 0.005", geometry='<sphere radius="0.005"/>', com="0.03 0 0.05")
    check = physics_check(point)
    assert not check.passed and "set free on a floor, it moved" in check.detail
    # In another frame (a completed shape in its camera's, 0.6 m ahead): not set down at all.
    elsewhere = _small(tmp_path / "elsewhere", xyz="0 0 0.6", geometry='<sphere radius="0.005"/>', com="0.03 0 0.65")
    with captured_c_output():
        problems, summary, _, resting = physics_problems(elsewhere)
    assert resting is None and not problems and "floor" not in summary


def _chain(path: Path, joints: int) -> Path:
    """A chain of `joints` revolute joints 0.1 m apart, small spheres on each link, each
    joint held by friction; about 660 bytes a link."""
    link = (
        '  <link name="link_{i}">\n'
        '    <inertial><origin xyz="0 0 0.05"/><mass value="0.1"/>'
        '<inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/></inertial>\n'
        '    <visual><origin xyz="0 0 0.05"/><geometry><sphere radius="0.02"/></geometry></visual>\n'
        '    <collision><origin xyz="0 0 0.05"/><geometry><sphere radius="0.02"/></geometry></collision>\n'
        "  </link>\n"
    )
    joint = (
        '  <joint name="joint_{i}" type="revolute">\n'
        '    <parent link="link_{p}"/><child link="link_{i}"/>\n'
        '    <origin xyz="0 0 0.1"/><axis xyz="{axis}"/>\n'
        '    <limit lower="-0.5" upper="0.5" effort="10" velocity="1"/>\n'
        '    <dynamics damping="0.1" friction="1"/>\n'
        "  </joint>\n"
    )
    parts = [link.format(i=i) for i in range(joints + 1)]
    parts += [joint.format(i=i, p=i - 1, axis="1 0 0" if i % 2 else "0 1 0") for i in range(1, joints + 1)]
    path.write_text('<?xml version="1.0"?>\n<robot name="chain">\n' + "".join(parts) + "</robot>\n")
    return path


def _cpu_seconds() -> float:
    """This process's CPU seconds and its waited-for children's (the gate's checkers)."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def _validate_timed(urdf: Path, clock: Callable[[], float] = time.perf_counter) -> tuple[ValidationReport, float]:
    """The gate's report and the seconds it took on `clock`."""
    start = clock()
    report = validate_path(urdf)
    return report, clock() - start


def test_a_500_joint_chain_validates_in_seconds(tmp_path: Path) -> None:
    """Security issue 16: the gate took 13 s at 100 joints and over 5 min at 500. pybullet
    cannot hold 500 joints (see PYBULLET_MAX_JOINTS), so its checks fail without loading it."""
    urdf = _chain(tmp_path / "chain.urdf", 500)
    assert urdf.stat().st_size > 200_000
    report, seconds = _validate_timed(urdf)
    checks = {c.name: c for c in report.checks}
    assert checks["kinematic tree"].passed and checks["yourdfpy"].passed and checks["check_urdf"].passed
    for name in ("pybullet", "collisions", "physics"):
        assert not checks[name].passed and f"at most {PYBULLET_MAX_JOINTS} joints" in checks[name].detail
    assert seconds < 15, f"{seconds:.1f} s"


def test_the_gate_s_cost_grows_linearly_up_to_pybullet_s_limit(tmp_path: Path) -> None:
    """Every check runs at 30 and at 120 joints; four times the joints may cost at most about
    four times as much (eight, for noise), where the old sweep grew by 64. In CPU seconds, not
    wall, so that a loaded machine does not make a linear cost look steep."""
    short, short_s = _validate_timed(_chain(tmp_path / "short.urdf", 30), clock=_cpu_seconds)
    long, long_s = _validate_timed(_chain(tmp_path / "long.urdf", 120), clock=_cpu_seconds)
    assert short.ok and long.ok, long.format()
    assert "120 joints left alone" in {c.name: c for c in long.checks}["physics"].detail
    assert long_s < 8 * max(short_s, 0.5) and long_s < 30, f"30 joints: {short_s:.2f} s; 120 joints: {long_s:.2f} s"


def test_a_lid_lifting_along_gravity_starts_where_it_rests(tmp_path: Path) -> None:
    urdf = tmp_path / "model.urdf"
    urdf.write_text(
        f"""<?xml version="1.0"?>
<robot name="jar">
  <link name="body">{INERTIAL.format(com="0 0 0.05", kg=0.5, i=1e-3)}
    <collision><origin xyz="0 0 0.05"/><geometry><cylinder radius="0.05" length="0.1"/></geometry></collision>
  </link>
  <link name="lid">{INERTIAL.format(com="0 0 0.005", kg=0.05, i=1e-5)}
    <collision><origin xyz="0 0 0.005"/><geometry><cylinder radius="0.05" length="0.01"/></geometry></collision>
  </link>
  <joint name="lid_lift" type="prismatic">
    <parent link="body"/><child link="lid"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
    <limit lower="0" upper="0.2" effort="10" velocity="1"/>
  </joint>
</robot>
"""
    )
    with captured_c_output():
        problems, _, drifts, resting = physics_problems(urdf)
    assert not problems
    assert [(d.name, d.start) for d in drifts] == [("lid_lift", 0.0)]
    assert resting is not None and not math.isnan(resting)
