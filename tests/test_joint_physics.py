"""modeller: joint dynamics by kind, effort limits from gravity, masses by part, knobs on
their axes, a jar's lid that lifts off; checked on the built catalogue and in pybullet."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from spec_edits import read_spec, with_field, write_spec

from articulation.joint_loads import (
    STANDARD_GRAVITY_M_S2,
    gravity_load,
    worst_gravity_load,
)
from homemodel.core.c_stdio_capture import captured_c_output
from homemodel.exchange.model_files import write_model_files
from modeller import BuildOptions, build, build_model
from modeller.joint_physics import HOLD_FRACTION, MAX_SINK_RAD_S

pytestmark = pytest.mark.bpy


def test_the_oven_door_is_counterbalanced_and_its_effort_holds_it(catalogue) -> None:
    model = catalogue["oven"].model
    hinge = model.joint("door_0_hinge")
    door_kg = model.link("door_0").inertial.mass_kg + model.link("door_0_handle").inertial.mass_kg
    # Gravity on a door hinged at its bottom edge is worst lying flat: weight times the
    # centre of mass's distance from the hinge (about half the door's height).
    load = worst_gravity_load(model, hinge)
    assert abs(gravity_load(model, hinge, hinge.limits.upper)) == pytest.approx(load, rel=1e-3)
    assert load == pytest.approx(door_kg * STANDARD_GRAVITY_M_S2 * 0.626 / 2, rel=0.1)
    assert abs(gravity_load(model, hinge, 0.0)) < 0.05 * load  # upright: nearly nothing
    assert hinge.dynamics.friction == pytest.approx(HOLD_FRACTION * load)
    assert hinge.limits.effort >= load + hinge.dynamics.friction and hinge.limits.effort != 10.0
    # A drawer slides level: gravity does not load it, and its effort is the minimum.
    slide = model.joint("drawer_0_slide")
    assert worst_gravity_load(model, slide) < 1e-9 and slide.limits.effort == 10.0


@pytest.mark.parametrize("name", ["oven", "washing_machine"])
def test_knobs_have_their_centre_of_mass_on_the_axis(catalogue, name: str) -> None:
    model = catalogue[name].model
    knobs = [j for j in model.movable_joints if j.name.startswith("knob_")]
    assert knobs
    for joint in knobs:
        com = model.link(joint.child).inertial.com_m
        axis = joint.axis / np.linalg.norm(joint.axis)
        assert np.linalg.norm(com - axis * (axis @ com)) < 1e-12
        assert worst_gravity_load(model, joint) < 1e-9
        assert 0 < joint.dynamics.friction and 0 < joint.dynamics.damping


def test_masses_follow_the_parts_and_keep_the_total(catalogue) -> None:
    masses = {}
    for name in ("fridge", "oven", "washing_machine", "jar", "cupboard"):
        spec, model, _ = catalogue[name]
        masses[name] = {link.name: link.inertial.mass_kg for link in model.links}
        assert sum(masses[name].values()) == pytest.approx(spec.mass_kg)
    fridge = masses["fridge"]
    assert fridge["drawer_0"] <= fridge["door_0"] < 15.0  # was 16 kg of freezer drawer by volume
    assert 4.0 < masses["oven"]["door_0"] < 9.0
    assert masses["washing_machine"]["door_0"] < 8.0  # was 11 kg
    assert masses["jar"]["lid"] < 0.2 * sum(masses["jar"].values())  # was 0.27 of 0.60 kg
    # A cupboard's door is a board of its carcass' material: area x thickness x chipboard.
    spec = catalogue["cupboard"].spec
    door = spec.doors[0]
    panel_kg = door.width_m * door.height_m * spec.door_thickness_m * spec.default_density_kg_m3
    assert masses["cupboard"]["door_0"] == pytest.approx(panel_kg, rel=1e-6)


def test_the_jar_lid_lifts_off_under_its_own_weight_back_onto_the_jar(catalogue) -> None:
    model = catalogue["jar"].model
    lift = model.joint("lid_lift")
    lid_kg = model.link("lid").inertial.mass_kg
    assert gravity_load(model, lift, 0.0) == pytest.approx(-lid_kg * STANDARD_GRAVITY_M_S2)
    assert lift.limits.effort > lid_kg * STANDARD_GRAVITY_M_S2


def test_a_spec_overrides_a_joint_s_dynamics_and_the_urdf_carries_them(catalogue_dir: Path, tmp_path: Path) -> None:
    data = with_field(read_spec(catalogue_dir / "cupboard.yaml"), "doors.0.dynamics", {"damping": 2.5, "friction": 0.75})
    model = build_model(write_spec(tmp_path, data))
    dynamics = model.joint("door_0_hinge").dynamics
    assert (dynamics.damping, dynamics.friction) == (2.5, 0.75)
    assert model.joint("door_1_hinge").dynamics.damping != 2.5  # the other door keeps its kind's
    write_model_files(model, tmp_path / "out")
    assert '<dynamics damping="2.5" friction="0.75"/>' in (tmp_path / "out" / "model.urdf").read_text()


def test_the_summary_lists_every_part_s_mass(catalogue_dir: Path, tmp_path: Path) -> None:
    built = build(catalogue_dir / "fridge.yaml", tmp_path / "fridge", BuildOptions())
    assert built.valid, built.validation.format()
    summary = json.loads((tmp_path / "fridge" / "summary.json").read_text())
    assert set(summary["modeller"]["masses_kg"]) == {link.name for link in built.model.links}
    assert sum(summary["modeller"]["masses_kg"].values()) == pytest.approx(70.0, abs=1e-3)
    assert summary["mass_kg"] == pytest.approx(70.0, abs=1e-3)
    assert "physics" in {check["name"] for check in summary["gate"]["checks"]}


def _oven_door_after(urdf: Path, start_deg: float, *, with_dynamics: bool) -> list[float]:
    """The oven door's angle (deg) every 0.25 s for 1 s after release at `start_deg`."""
    import pybullet as pb

    with captured_c_output():
        client = pb.connect(pb.DIRECT)
        try:
            body = pb.loadURDF(str(urdf), useFixedBase=True, flags=pb.URDF_USE_INERTIA_FROM_FILE, physicsClientId=client)
            joints = [pb.getJointInfo(body, i, physicsClientId=client) for i in range(pb.getNumJoints(body, physicsClientId=client))]
            door = next(info for info in joints if info[1] == b"door_0_hinge")
            for info in joints:
                friction = float(info[7]) if with_dynamics else 0.0
                pb.setJointMotorControl2(body, info[0], pb.VELOCITY_CONTROL, force=friction, physicsClientId=client)
                if not with_dynamics:
                    pb.changeDynamics(body, info[0], jointDamping=0.0, physicsClientId=client)
            pb.resetJointState(body, door[0], math.radians(start_deg), physicsClientId=client)
            pb.setGravity(0, 0, -STANDARD_GRAVITY_M_S2, physicsClientId=client)
            angles = []
            for _ in range(4):
                for _ in range(60):
                    pb.stepSimulation(physicsClientId=client)
                angles.append(math.degrees(pb.getJointState(body, door[0], physicsClientId=client)[0]))
        finally:
            pb.disconnect(physicsClientId=client)
    return angles


def test_the_oven_door_stays_where_put_and_sinks_slowly_past_its_balance(catalogue, tmp_path: Path) -> None:
    write_model_files(catalogue["oven"].model, tmp_path)
    urdf = tmp_path / "model.urdf"
    assert max(abs(a - 45.0) for a in _oven_door_after(urdf, 45.0, with_dynamics=True)) < 0.1
    # Near flat, gravity beats the counterbalance: the door sinks, at most MAX_SINK_RAD_S.
    sinking = _oven_door_after(urdf, 75.0, with_dynamics=True)
    assert 75.0 < sinking[-1] < 75.0 + math.degrees(MAX_SINK_RAD_S) * 1.2
    # Without its dynamics the same door falls open to its stop within the second.
    assert _oven_door_after(urdf, 45.0, with_dynamics=False)[-1] > 89.0
