"""What the simulator exporters need to know of a joint beyond its kinematics: the damping
and friction to write, and the torque gravity puts on it.

A model's own `Joint.dynamics` wins. Where a model has none, every exporter writes the same
default, scaled by the mass the joint moves, so a door, a drawer and a knob all come to rest.
The friction written is at least the holding torque gravity needs at the joint's worst
angle (with a margin): a bottom-hinged oven door left at 45 degrees stays there, as the
counterbalance spring of a real one makes it, instead of falling open.
"""

from __future__ import annotations

import numpy as np

from articulation.model import Joint, JointDynamics, Model
from articulation.scene import GRAVITY_M_S2

# Per kilogram moved: N·m·s/rad and N·m (revolute, continuous), N·s/m and N (prismatic).
_DAMPING_PER_KG = {"revolute": 0.1, "continuous": 0.1, "prismatic": 2.0}
_FRICTION_PER_KG = {"revolute": 0.05, "continuous": 0.05, "prismatic": 0.5}
# Floors so a 10 g knob is not a frictionless spinner.
_MIN_DAMPING = {"revolute": 0.002, "continuous": 0.002, "prismatic": 0.05}
_MIN_FRICTION = {"revolute": 0.002, "continuous": 0.002, "prismatic": 0.05}
HOLDING_MARGIN = 1.3
_ANGLE_SAMPLES = 91


def subtree(model: Model, link_name: str) -> list[str]:
    """`link_name` and every link below it."""
    children: dict[str, list[str]] = {}
    for j in model.joints:
        children.setdefault(j.parent, []).append(j.child)
    found, stack = [], [link_name]
    while stack:
        name = stack.pop()
        found.append(name)
        stack.extend(children.get(name, []))
    return found


def moved_mass_kg(model: Model, joint: Joint) -> float:
    return sum(model.link(n).inertial.mass_kg for n in subtree(model, joint.child) if model.link(n).inertial)


def gravity_effort(
    model: Model, joint: Joint, *, gravity_model: np.ndarray | None = None, positions: dict[str, float] | None = None
) -> float:
    """The largest torque (N·m) or force (N) gravity puts on `joint` over its range.

    `gravity_model` is the gravity vector in the model's frame (default: -z, upright);
    the other joints sit at `positions` (default zero).
    """
    g = np.array([0.0, 0.0, -GRAVITY_M_S2]) if gravity_model is None else np.asarray(gravity_model, dtype=float)
    if not joint.is_movable:
        return 0.0
    links = subtree(model, joint.child)
    lower, upper = (joint.limits.lower, joint.limits.upper) if joint.limits and joint.type != "continuous" else (-np.pi, np.pi)
    worst = 0.0
    for q in np.linspace(lower, upper, _ANGLE_SAMPLES if joint.type != "prismatic" else 2):
        frames = model.world_from_links({**(positions or {}), joint.name: float(q)})
        parent_joint = frames[joint.parent] @ joint.parent_from_joint
        axis = parent_joint[:3, :3] @ (joint.axis / np.linalg.norm(joint.axis))
        if joint.type == "prismatic":
            force = sum(model.link(n).inertial.mass_kg for n in links if model.link(n).inertial) * g
            worst = max(worst, abs(float(force @ axis)))
            continue
        torque = np.zeros(3)
        for name in links:
            inertial = model.link(name).inertial
            if inertial is None:
                continue
            com = (frames[name] @ np.append(inertial.com_m, 1.0))[:3]
            torque += np.cross(com - parent_joint[:3, 3], inertial.mass_kg * g)
        worst = max(worst, abs(float(torque @ axis)))
    return worst


def export_dynamics(model: Model, joint: Joint, *, gravity_model: np.ndarray | None = None) -> JointDynamics:
    """Damping and friction an exporter writes for a movable joint (see the module's note)."""
    kind = joint.type
    mass = moved_mass_kg(model, joint)
    if joint.dynamics is not None:
        damping, friction = joint.dynamics.damping, joint.dynamics.friction
    else:
        damping = max(_MIN_DAMPING[kind], _DAMPING_PER_KG[kind] * mass)
        friction = max(_MIN_FRICTION[kind], _FRICTION_PER_KG[kind] * mass)
    holding = HOLDING_MARGIN * gravity_effort(model, joint, gravity_model=gravity_model)
    return JointDynamics(damping=float(damping), friction=float(max(friction, holding)))


def actuator_effort(model: Model, joint: Joint, dynamics: JointDynamics) -> float:
    """What a position actuator must be able to give: the model's effort limit, or enough to
    beat the joint's friction (which already holds gravity) twice over."""
    given = joint.limits.effort if joint.limits is not None else 0.0
    return float(max(given, 2.0 * dynamics.friction))
