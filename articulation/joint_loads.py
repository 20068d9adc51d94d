"""What gravity asks of a joint: the torque (or force) it must hold, and the inertia it moves.

The model's frame is taken as standing upright (+z up), as every homemodel model stands
in its home. A joint carries its child and everything beyond it (its subtree); the load
is sampled over the joint's range with every other joint at rest, and the worst case is
what an actuator or a counterbalance must hold.
"""

from __future__ import annotations

import math

import numpy as np

from articulation.model import Joint, Model

STANDARD_GRAVITY_M_S2 = 9.80665
# Samples over a joint's range; 64 puts the worst angle of a hinge within 1.5 degrees
# of a 90-degree range's maximum, which changes sin() by well under 0.1 %.
_RANGE_SAMPLES = 65


def subtree_links(model: Model, joint: Joint) -> list[str]:
    """The joint's child and every link below it."""
    children: dict[str, list[str]] = {}
    for j in model.joints:
        children.setdefault(j.parent, []).append(j.child)
    found, stack = [], [joint.child]
    while stack:
        name = stack.pop()
        found.append(name)
        stack.extend(children.get(name, []))
    return found


def _positions(joint: Joint) -> np.ndarray:
    if joint.type == "continuous" or joint.limits is None:
        return np.linspace(-math.pi, math.pi, _RANGE_SAMPLES)
    return np.linspace(joint.limits.lower, joint.limits.upper, _RANGE_SAMPLES)


UPRIGHT_GRAVITY_M_S2 = np.array([0.0, 0.0, -STANDARD_GRAVITY_M_S2])


def moved_mass_kg(model: Model, joint: Joint) -> float:
    """The mass of the joint's subtree."""
    inertials = (model.link(name).inertial for name in subtree_links(model, joint))
    return sum(inertial.mass_kg for inertial in inertials if inertial is not None)


def gravity_load(model: Model, joint: Joint, position: float, gravity_model: np.ndarray = UPRIGHT_GRAVITY_M_S2) -> float:
    """Gravity's torque about the joint's axis (N·m), or force along it (N), on its subtree
    with the joint at `position` and the others at rest; signed along the axis.

    `gravity_model` is gravity in the model's frame: upright unless the model is placed tilted.
    """
    return float(_gravity_loads(model, joint, [position], gravity_model)[0])


def worst_gravity_load(model: Model, joint: Joint, gravity_model: np.ndarray = UPRIGHT_GRAVITY_M_S2) -> float:
    """The largest |gravity load| over the joint's range (N·m or N); 0 for a fixed joint."""
    if not joint.is_movable:
        return 0.0
    return float(np.abs(_gravity_loads(model, joint, _positions(joint), gravity_model)).max())


def _gravity_loads(model: Model, joint: Joint, positions, gravity_model: np.ndarray) -> np.ndarray:
    """`gravity_load` at each of `positions`. With the other joints at rest the subtree moves
    as one body, so its mass and mass-weighted centre are found once, in the child's frame,
    not the whole model's poses once per position."""
    world_from_rest = model.world_from_links()
    world_from_joint = world_from_rest[joint.parent] @ joint.parent_from_joint
    axis = world_from_joint[:3, :3] @ (joint.axis / np.linalg.norm(joint.axis))
    weight = np.asarray(gravity_model, dtype=np.float64)
    world_from_child_at_rest = world_from_rest[joint.child]
    mass_kg, mass_moment_kgm = 0.0, np.zeros(3)  # the sum of mass x centre, in the child's frame
    for name in subtree_links(model, joint):
        inertial = model.link(name).inertial
        if inertial is None:
            continue
        world_from_link = world_from_rest[name]
        com_world = world_from_link[:3, :3] @ inertial.com_m + world_from_link[:3, 3]
        mass_kg += inertial.mass_kg
        com_child = world_from_child_at_rest[:3, :3].T @ (com_world - world_from_child_at_rest[:3, 3])  # rigid: R^T (x - t)
        mass_moment_kgm += inertial.mass_kg * com_child
    if joint.type == "prismatic":
        return np.full(len(positions), float(axis @ (mass_kg * weight)))
    world_from_child = world_from_joint @ np.stack([joint.joint_from_child(float(q)) for q in positions])
    lever_kgm = world_from_child[:, :3, :3] @ mass_moment_kgm + mass_kg * (world_from_child[:, :3, 3] - world_from_joint[:3, 3])
    return np.cross(lever_kgm, weight) @ axis


def axis_inertia(model: Model, joint: Joint) -> float:
    """The subtree's moment of inertia about a revolute joint's axis (kg·m²) at rest, or
    its mass (kg) for a prismatic joint: what the joint's damping acts on."""
    world_from_link = model.world_from_links()
    world_from_joint = world_from_link[joint.parent] @ joint.parent_from_joint
    axis = world_from_joint[:3, :3] @ (joint.axis / np.linalg.norm(joint.axis))
    total = 0.0
    for name in subtree_links(model, joint):
        inertial = model.link(name).inertial
        if inertial is None:
            continue
        if joint.type == "prismatic":
            total += inertial.mass_kg
            continue
        rotation = world_from_link[name][:3, :3]
        about_com = axis @ (rotation @ inertial.inertia_kgm2 @ rotation.T) @ axis
        com = rotation @ inertial.com_m + world_from_link[name][:3, 3]
        offset = com - world_from_joint[:3, 3]
        off_axis = offset - axis * (axis @ offset)
        total += float(about_com) + inertial.mass_kg * float(off_axis @ off_axis)
    return total
