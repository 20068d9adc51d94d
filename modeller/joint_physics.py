"""Joint physics of a built model: damping and friction by the joint's kind, effort limits
from the torque that holds the child against gravity, and knobs balanced on their axes.

Runs once the links have their masses. The kinds follow the builders' joint names
(`modeller.builders.cabinet`, `.handles`, `.boxes`, `.vessels`): `door_<i>_hinge`,
`drawer_<i>_slide`, `knob_<i>_turn`, `lid_hinge`, `lid_lift`.

A hinge that gravity turns (a bottom-hinged oven door, a wall cabinet's top-hinged flap, a
pill box's lid) is counterbalanced as its real springs or stays do: Coulomb friction holds
`HOLD_FRACTION` of the worst gravity torque, so the part stays where it is put over most of
its range (an oven door up to 64 degrees from upright), and beyond that it sinks against
viscous damping at no more than `MAX_SINK_RAD_S` instead of slamming: slow enough that a
part left anywhere moves less than the gate's 5 degrees in a second.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from articulation.joint_loads import axis_inertia, worst_gravity_load
from articulation.model import Inertial, Joint, JointDynamics, Model
from modeller.specs.joint_dynamics import JointDynamicsSpec


@dataclass(frozen=True)
class KindDynamics:
    """A kind's own damping and friction, before any counterbalance."""

    damping: float
    friction: float


# Units: N·m·s/rad and N·m for hinges, N·s/m and N for slides.
KIND_DYNAMICS: dict[str, KindDynamics] = {
    "door": KindDynamics(damping=0.5, friction=0.2),  # hinges with a soft-close feel
    "drawer": KindDynamics(damping=5.0, friction=2.0),  # ball-bearing runners
    "knob": KindDynamics(damping=1e-4, friction=0.02),  # the detent a hand feels
    "lid": KindDynamics(damping=0.01, friction=0.002),  # a lid's hinge or a jar's lid lifting off
}
_KIND_BY_PREFIX = (("door_", "door"), ("drawer_", "drawer"), ("knob_", "knob"), ("lid_", "lid"))

HOLD_FRACTION = 0.9
MAX_SINK_RAD_S = 0.05
# A simulator stepping explicitly at 240 Hz (pybullet's default) integrates damping c on
# an inertia I only while c·dt/I stays below 1; keep it at half that.
STABLE_STEP_S = 1 / 240
_STABLE_DAMPING_FRACTION = 0.5
# Below this (N·m) gravity does not turn the joint: a vertical hinge, a balanced knob.
_NO_LOAD = 1e-9
# Effort limits: the worst holding load plus friction, with this margin; never below the minimum.
EFFORT_MARGIN = 1.5
MIN_EFFORT = {"revolute": 1.0, "continuous": 1.0, "prismatic": 10.0}  # N·m, N


def spec_dynamics(override: JointDynamicsSpec | None) -> JointDynamics | None:
    """A spec's override as the joint's dynamics; None leaves them to `set_joint_physics`."""
    return None if override is None else JointDynamics(damping=override.damping, friction=override.friction)


def joint_kind(joint: Joint) -> str | None:
    for prefix, kind in _KIND_BY_PREFIX:
        if joint.name.startswith(prefix):
            return kind
    return None


def balance_knobs(model: Model) -> None:
    """Put each knob's centre of mass on its turning axis: its marker line makes it a
    fraction of a millimetre lopsided, which lets gravity swing a free knob by half a radian."""
    for joint in model.movable_joints:
        inertial = model.link(joint.child).inertial
        if joint_kind(joint) != "knob" or inertial is None:
            continue
        # The child's frame is the joint frame, so the axis runs through its origin.
        axis = joint.axis / np.linalg.norm(joint.axis)
        on_axis = axis * float(axis @ inertial.com_m)
        model.link(joint.child).inertial = Inertial(
            mass_kg=inertial.mass_kg, com_m=on_axis, inertia_kgm2=inertial.inertia_kgm2
        )


def kind_dynamics(model: Model, joint: Joint, kind: KindDynamics, load: float) -> JointDynamics:
    """The kind's damping and friction, with a counterbalance where gravity turns the joint
    (`load`: its worst gravity load)."""
    if joint.type == "prismatic" or load < _NO_LOAD:
        # A slide along gravity (a jar's lid) is meant to fall back into place.
        return JointDynamics(damping=kind.damping, friction=kind.friction)
    sink_damping = (1 - HOLD_FRACTION) * load / MAX_SINK_RAD_S
    stable = _STABLE_DAMPING_FRACTION * axis_inertia(model, joint) / STABLE_STEP_S
    damping = min(max(kind.damping, sink_damping), stable)
    return JointDynamics(damping=damping, friction=max(kind.friction, HOLD_FRACTION * load))


def effort_limit(joint: Joint, load: float) -> float:
    """What an actuator needs to hold the child at its worst angle (`load`) and overcome friction."""
    friction = joint.dynamics.friction if joint.dynamics is not None else 0.0
    needed = EFFORT_MARGIN * (load + friction)
    return max(needed, MIN_EFFORT[joint.type])


def set_joint_physics(model: Model) -> None:
    """Balance the knobs, then give every movable joint its dynamics (a spec's override
    kept) and an effort limit computed from its loads."""
    balance_knobs(model)
    for joint in model.movable_joints:
        kind = joint_kind(joint)
        load = worst_gravity_load(model, joint)  # a sweep of its range: once per joint
        if joint.dynamics is None and kind is not None:
            joint.dynamics = kind_dynamics(model, joint, KIND_DYNAMICS[kind], load)
        if joint.limits is not None:
            joint.limits.effort = effort_limit(joint, load)
