"""The node types of the hierarchical semantic map (D3.1 section 3.2.2, Figures 3-7).

Frames:

- the map (world) frame is the metric map's frame; rooms have no frame of their own;
- `Switch.world_from_switch`, `LargeObject.world_from_object` and
  `ParkingPosition.world_from_base` are in the map frame;
- `SmallObject.parent_from_object` and its `DefaultPosition`s are in the parent object's frame;
- `ObjectJoint.object_from_joint`, `ObjectJoint.axis` and `ObjectGraspPoint.object_from_grasp`
  are in the owning object's frame: its model's root link frame with every joint at zero.

Poses are held as `Pose` (xyz + rpy, exactly the numbers the map file holds), not as
matrices, so that loading and saving a map reproduces the file byte for byte; `Pose.matrix()`
gives the 4x4 transform and numpy accepts a `Pose` wherever it expects that matrix.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import datetime
from typing import Literal

import numpy as np

from articulation.joint_types import MOVABLE_JOINT_TYPES, MovableJointType
from homemodel.core.errors import MapError
from homemodel.core.transforms import (
    as_transform,
    axis_angle_transform,
    transform_from_xyz_rpy,
    translation_transform,
    xyz_rpy_from_transform,
)

Relation = Literal["on", "in", "under"]
SwitchType = Literal["rotational", "prismatic"]
RELATIONS: tuple[str, ...] = ("on", "in", "under")
SWITCH_TYPES: tuple[str, ...] = ("rotational", "prismatic")

# The ASCII part of an XML NCName: ids become xs:ID values in the file.
ID_PATTERN = r"^[A-Za-z_][A-Za-z0-9_.-]*$"
_ID = re.compile(ID_PATTERN)
# XML Schema's xs:token collapses whitespace; a label must survive that unchanged.
_LABEL = re.compile(r"^\S+( \S+)*$")


def check_id(value: str) -> str:
    if not isinstance(value, str) or not _ID.match(value):
        raise MapError(f"{value!r} is not a valid id: use a letter or _ followed by letters, digits, _ . -")
    return value


def check_label(value: str, what: str) -> str:
    if not isinstance(value, str) or not _LABEL.match(value):
        raise MapError(f"{what} {value!r} must be non-empty, without leading, trailing or repeated spaces")
    return value


def clean_floats(values: Sequence[float]) -> tuple[float, ...]:
    """Computed transforms carry float noise (6e-17 for a zero); 12 decimals, a picometre or
    a picoradian, keep the file clean."""
    return tuple(round(float(v), 12) + 0.0 for v in values)


def _vector3(values: Sequence[float], what: str) -> tuple[float, float, float]:
    # "+ 0.0" turns -0.0 into 0.0 so equal maps write equal bytes.
    vector = tuple(float(v) + 0.0 for v in values)
    if len(vector) != 3 or not all(math.isfinite(v) for v in vector):
        raise MapError(f"{what}={values!r} but expected 3 finite numbers")
    return vector  # type: ignore[return-value]


@dataclass(frozen=True)
class Pose:
    """A rigid transform as URDF xyz (m) and fixed-axis roll, pitch, yaw (rad)."""

    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "xyz", _vector3(self.xyz, "xyz"))
        object.__setattr__(self, "rpy", _vector3(self.rpy, "rpy"))

    @classmethod
    def from_matrix(cls, a_from_b: np.ndarray) -> Pose:
        m = as_transform(a_from_b)
        rotation = m[:3, :3]
        rigid = (
            np.allclose(rotation.T @ rotation, np.eye(3), atol=1e-6)
            and np.linalg.det(rotation) > 0
            and np.allclose(m[3], (0, 0, 0, 1))
        )
        if not rigid:
            raise MapError(f"not a rigid transform: {m.tolist()}")
        xyz, rpy = xyz_rpy_from_transform(m)
        return cls(clean_floats(xyz), clean_floats(rpy))  # type: ignore[arg-type]

    def matrix(self) -> np.ndarray:
        return transform_from_xyz_rpy(self.xyz, self.rpy)

    def __array__(self, dtype: object = None, copy: object = None) -> np.ndarray:
        return self.matrix() if dtype is None else self.matrix().astype(dtype)


def as_pose(a_from_b: Pose | np.ndarray | Sequence[Sequence[float]]) -> Pose:
    """A `Pose` from a Pose or a 4x4 rigid transform."""
    return a_from_b if isinstance(a_from_b, Pose) else Pose.from_matrix(np.asarray(a_from_b))


@dataclass(kw_only=True)
class ParkingPosition:
    """Where the robot's base stands to observe or reach an object; `world_from_base` may
    be given as a 4x4 matrix and is kept as a `Pose`."""

    name: str
    world_from_base: Pose
    default: bool = False

    def __post_init__(self) -> None:
        check_label(self.name, "parking position name")
        self.world_from_base = as_pose(self.world_from_base)


@dataclass(kw_only=True)
class DefaultPosition:
    """Where a small object is usually found, in its parent's frame (a 4x4 matrix or a Pose)."""

    name: str
    parent_from_object: Pose

    def __post_init__(self) -> None:
        check_label(self.name, "default position name")
        self.parent_from_object = as_pose(self.parent_from_object)


@dataclass(kw_only=True)
class Switch:
    id: str
    type: SwitchType
    world_from_switch: Pose


@dataclass(kw_only=True)
class NamedState:
    """A named discrete position of a joint (rad or m), e.g. a door's "open"."""

    name: str
    position: float


@dataclass(kw_only=True)
class ObjectJoint:
    """A joint of a large articulated object, in the object's frame at joint zero.

    `axis` is a unit vector; `limits` (lower, upper) are required unless the joint is
    continuous; `parent` is the nearest movable joint between this one and the root.
    """

    name: str
    type: MovableJointType
    object_from_joint: Pose
    axis: tuple[float, float, float]
    limits: tuple[float, float] | None
    position: float = 0.0
    states: list[NamedState] = field(default_factory=list)
    parent: str | None = None

    def __post_init__(self) -> None:
        what = f"joint {self.name!r}"
        if self.type not in MOVABLE_JOINT_TYPES:
            raise MapError(f"{what}: type {self.type!r} is not one of {', '.join(MOVABLE_JOINT_TYPES)}")
        self.axis = _vector3(self.axis, "axis")
        if not abs(np.linalg.norm(self.axis) - 1.0) < 1e-6:
            raise MapError(f"{what}: axis {self.axis} is not a unit vector")
        if self.type != "continuous":
            if self.limits is None:
                raise MapError(f"{what}: a {self.type} joint needs limits")
            if not self.limits[0] <= self.limits[1]:
                raise MapError(f"{what}: lower limit {self.limits[0]} is above upper limit {self.limits[1]}")
        self.check_position(self.position)
        for state in self.states:
            self.check_position(state.position, f"state {state.name!r} ")

    def check_position(self, position: float, what: str = "") -> float:
        position = float(position)
        if not math.isfinite(position):
            raise MapError(f"joint {self.name!r}: {what}position {position} is not a number")
        if self.limits is not None and not self.limits[0] <= position <= self.limits[1]:
            raise MapError(
                f"joint {self.name!r}: {what}position {position} is outside its limits "
                f"[{self.limits[0]}, {self.limits[1]}]"
            )
        return position

    def object_motion(self, position: float) -> np.ndarray:
        """How the joint at `position` moves its child, expressed in the object frame."""
        if self.type == "prismatic":
            return translation_transform(np.asarray(self.axis) * position)
        through = translation_transform(self.object_from_joint.xyz)
        return through @ axis_angle_transform(self.axis, position) @ np.linalg.inv(through)


@dataclass(kw_only=True)
class ObjectGraspPoint:
    """A grasp frame in the object's frame at joint zero; `joint` is the joint moving it."""

    name: str
    kind: str
    object_from_grasp: Pose
    joint: str | None = None


@dataclass(kw_only=True)
class PoseRecord:
    """A pose the object held until `until`; for a small object also where it was."""

    until: datetime
    pose: Pose
    parent: str | None = None
    relation: Relation | None = None


@dataclass(kw_only=True)
class JointStateRecord:
    until: datetime
    joint: str
    position: float


@dataclass(kw_only=True)
class Jointed:
    """What an object with joints has: a large articulated object, or a small one such as a
    pill box with a hinged lid."""

    joints: list[ObjectJoint] = field(default_factory=list)

    def joint(self, name: str) -> ObjectJoint:
        for joint in self.joints:
            if joint.name == name:
                return joint
        raise MapError(f"object {self.id!r} has no joint {name!r} (it has {[j.name for j in self.joints]})")


@dataclass(kw_only=True)
class SmallObject(Jointed):
    """A household item on, in or under a large object; its pose is in the parent's frame.
    Its joints, if any (a lid's hinge), are in its own frame."""

    id: str
    type: str
    parent: str
    relation: Relation
    parent_from_object: Pose
    default_positions: list[DefaultPosition]
    graspable: bool = True
    grasp_points: list[ObjectGraspPoint] = field(default_factory=list)
    affordances: list[str] = field(default_factory=list)
    properties: dict[str, str] = field(default_factory=dict)
    model_ref: str | None = None
    history: list[PoseRecord | JointStateRecord] = field(default_factory=list)


@dataclass(kw_only=True)
class LargeObject:
    """A piece of furniture or an appliance; its pose and parking positions are in the map
    frame, the default parking position first."""

    id: str
    type: str
    world_from_object: Pose
    parking_positions: list[ParkingPosition]
    graspable: bool = False
    grasp_points: list[ObjectGraspPoint] = field(default_factory=list)
    affordances: list[str] = field(default_factory=list)
    properties: dict[str, str] = field(default_factory=dict)
    model_ref: str | None = None
    small_objects: list[SmallObject] = field(default_factory=list)
    history: list[PoseRecord | JointStateRecord] = field(default_factory=list)


@dataclass(kw_only=True)
class LargeArticulatedObject(LargeObject, Jointed):
    """A large object with joints (doors, drawers, knobs) moved by its grasp points."""


@dataclass(kw_only=True)
class Room:
    """A room; `outline`, if known, is its floor plan: polygon corners (x, y) in the map frame."""

    id: str
    name: str
    point_cloud: str | None = None
    outline: list[tuple[float, float]] | None = None
    switches: list[Switch] = field(default_factory=list)
    objects: list[LargeObject] = field(default_factory=list)

    def __post_init__(self) -> None:
        if self.outline is None:
            return
        corners = [tuple(float(v) + 0.0 for v in corner) for corner in self.outline]
        if len(corners) < 3 or any(len(c) != 2 or not all(math.isfinite(v) for v in c) for c in corners):
            raise MapError(f"room {self.id!r}: outline needs at least 3 corners of 2 finite numbers, got {self.outline!r}")
        self.outline = corners  # type: ignore[assignment]


@dataclass(kw_only=True)
class Apartment:
    id: str
    name: str
    rooms: list[Room] = field(default_factory=list)


MapObject = LargeObject | SmallObject
Node = Apartment | Room | Switch | LargeObject | SmallObject
