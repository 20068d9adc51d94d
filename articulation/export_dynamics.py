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

from articulation.joint_loads import UPRIGHT_GRAVITY_M_S2, moved_mass_kg, worst_gravity_load
from articulation.model import Joint, JointDynamics, Model

# Per kilogram moved: N·m·s/rad and N·m (revolute, continuous), N·s/m and N (prismatic).
_DAMPING_PER_KG = {"revolute": 0.1, "continuous": 0.1, "prismatic": 2.0}
_FRICTION_PER_KG = {"revolute": 0.05, "continuous": 0.05, "prismatic": 0.5}
# Floors so a 10 g knob is not a frictionless spinner.
_MIN_DAMPING = {"revolute": 0.002, "continuous": 0.002, "prismatic": 0.05}
_MIN_FRICTION = {"revolute": 0.002, "continuous": 0.002, "prismatic": 0.05}
HOLDING_MARGIN = 1.3


def export_dynamics(model: Model, joint: Joint, *, gravity_model: np.ndarray = UPRIGHT_GRAVITY_M_S2) -> JointDynamics:
    """Damping and friction an exporter writes for a movable joint (see the module's note)."""
    kind = joint.type
    mass = moved_mass_kg(model, joint)
    if joint.dynamics is not None:
        damping, friction = joint.dynamics.damping, joint.dynamics.friction
    else:
        damping = max(_MIN_DAMPING[kind], _DAMPING_PER_KG[kind] * mass)
        friction = max(_MIN_FRICTION[kind], _FRICTION_PER_KG[kind] * mass)
    holding = HOLDING_MARGIN * worst_gravity_load(model, joint, gravity_model)
    return JointDynamics(damping=float(damping), friction=float(max(friction, holding)))


def actuator_effort(model: Model, joint: Joint, dynamics: JointDynamics) -> float:
    """What a position actuator must be able to give: the model's effort limit, or enough to
    beat the joint's friction (which already holds gravity) twice over."""
    given = joint.limits.effort if joint.limits is not None else 0.0
    return float(max(given, 2.0 * dynamics.friction))
