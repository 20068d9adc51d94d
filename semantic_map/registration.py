"""Turn an articulated model into a map node: its category becomes the object's type, its
affordances, properties, joints and grasp points flow into the map.

Joint origins, axes and grasp points are expressed in the object's frame (the model's root
link frame) with every joint at zero, so the map needs no kinematic tree to use them.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from articulation.model import Joint, Model
from homemodel.core.errors import MapError
from semantic_map.nodes import (
    DefaultPosition,
    LargeArticulatedObject,
    LargeObject,
    NamedState,
    ObjectGraspPoint,
    ObjectJoint,
    ParkingPosition,
    Pose,
    Relation,
    SmallObject,
    check_label,
    clean_floats,
)


def ordered_parking(object_id: str, parking_positions: Sequence[ParkingPosition]) -> list[ParkingPosition]:
    """The parking positions with the one default first, the others in the given order."""
    defaults = [p.name for p in parking_positions if p.default]
    if len(defaults) != 1:
        raise MapError(
            f"large object {object_id!r} needs exactly one default parking position, got "
            f"{len(defaults)} among {[p.name for p in parking_positions]}"
        )
    names = [p.name for p in parking_positions]
    if len(set(names)) != len(names):
        raise MapError(f"large object {object_id!r}: parking position names repeat: {names}")
    return sorted(parking_positions, key=lambda p: not p.default)


def _properties(model: Model, extra: dict[str, str] | None) -> dict[str, str]:
    merged = {**model.properties, **(extra or {})}
    for name, value in merged.items():
        check_label(name, "property name")
        if not isinstance(value, str):
            raise MapError(f"property {name!r}: value {value!r} is not a string")
    return merged


def _affordances(model: Model) -> list[str]:
    return [check_label(a, "affordance") for a in dict.fromkeys(model.affordances)]


def _map_joint(model: Model, joint: Joint, object_from_links: dict[str, np.ndarray], position: float | None) -> ObjectJoint:
    object_from_joint = object_from_links[joint.parent] @ joint.parent_from_joint
    norm = float(np.linalg.norm(joint.axis))
    if not norm > 1e-9:
        raise MapError(f"model {model.name!r}: joint {joint.name!r} has a zero axis")
    limits = None
    if joint.type != "continuous":
        if joint.limits is None:
            raise MapError(f"model {model.name!r}: {joint.type} joint {joint.name!r} has no limits")
        limits = (float(joint.limits.lower), float(joint.limits.upper))
    if position is None:
        # Start at zero, or at the nearest limit when zero lies outside them.
        position = 0.0 if limits is None else float(np.clip(0.0, *limits))
    upstream = model.joint_driving(joint.parent)
    return ObjectJoint(
        name=joint.name,
        type=joint.type,  # type: ignore[arg-type]
        object_from_joint=Pose.from_matrix(object_from_joint),
        axis=clean_floats(object_from_joint[:3, :3] @ (joint.axis / norm)),  # type: ignore[arg-type]
        limits=limits,
        position=position,
        states=[NamedState(name=s.name, position=s.position) for s in joint.states],
        parent=upstream.name if upstream else None,
    )


def _grasp_points(model: Model) -> list[ObjectGraspPoint]:
    object_from_grasps = model.world_from_grasp_points()
    points = []
    for g in model.grasp_points:
        driving = model.joint_driving(g.link)
        points.append(
            ObjectGraspPoint(
                name=check_label(g.name, "grasp point name"),
                kind=check_label(g.kind, "grasp point kind"),
                object_from_grasp=Pose.from_matrix(object_from_grasps[g.name]),
                joint=driving.name if driving else None,
            )
        )
    return points


def _map_joints(model: Model, joint_positions: dict[str, float] | None) -> list[ObjectJoint]:
    """The model's movable joints for the map, at `joint_positions` (default: zero)."""
    positions = dict(joint_positions or {})
    movable = model.movable_joints
    unknown = sorted(set(positions) - {j.name for j in movable})
    if unknown:
        raise MapError(f"model {model.name!r}: no movable joints named {unknown}")
    object_from_links = model.world_from_links()
    return [_map_joint(model, j, object_from_links, positions.get(j.name)) for j in movable]


def large_object_from_model(
    model: Model,
    *,
    object_id: str,
    world_from_object: Pose,
    parking_positions: Sequence[ParkingPosition],
    graspable: bool,
    properties: dict[str, str] | None,
    model_ref: str | None,
    joint_positions: dict[str, float] | None,
) -> LargeObject:
    """A large object, or a large articulated object when the model has movable joints."""
    common = dict(
        id=object_id,
        type=check_label(model.category, "object type"),
        world_from_object=world_from_object,
        parking_positions=ordered_parking(object_id, parking_positions),
        graspable=graspable,
        grasp_points=_grasp_points(model),
        affordances=_affordances(model),
        properties=_properties(model, properties),
        model_ref=model_ref,
    )
    joints = _map_joints(model, joint_positions)
    if not joints:
        return LargeObject(**common)  # type: ignore[arg-type]
    return LargeArticulatedObject(**common, joints=joints)  # type: ignore[arg-type]


def small_object_from_model(
    model: Model,
    *,
    object_id: str,
    parent_id: str,
    relation: Relation,
    parent_from_object: Pose,
    default_positions: Sequence[DefaultPosition] | None,
    graspable: bool,
    properties: dict[str, str] | None,
    model_ref: str | None,
    joint_positions: dict[str, float] | None = None,
) -> SmallObject:
    """A small object (with its joints, if it has any: a pill box's lid); without default
    positions, where it is registered is its default."""
    positions = list(default_positions or [DefaultPosition(name="registered", parent_from_object=parent_from_object)])
    names = [p.name for p in positions]
    if len(set(names)) != len(names):
        raise MapError(f"small object {object_id!r}: default position names repeat: {names}")
    return SmallObject(
        id=object_id,
        type=check_label(model.category, "object type"),
        parent=parent_id,
        relation=relation,
        parent_from_object=parent_from_object,
        default_positions=positions,
        graspable=graspable,
        grasp_points=_grasp_points(model),
        affordances=_affordances(model),
        properties=_properties(model, properties),
        model_ref=model_ref,
        joints=_map_joints(model, joint_positions),
    )
