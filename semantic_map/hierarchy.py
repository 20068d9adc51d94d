"""`SemanticMap`: the apartment > room > object hierarchy, its queries and timestamped updates.

Frames as in `semantic_map.nodes`: large objects, switches and parking positions in the map
(world) frame, small objects in their parent's frame, joints and grasp points in their
object's frame at joint zero. `world_from_object` composes these.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from datetime import datetime, timezone
from typing import TypeVar

import numpy as np

from articulation.model import Model
from homemodel.core.errors import MapError
from semantic_map.nodes import (
    RELATIONS,
    SWITCH_TYPES,
    Apartment,
    DefaultPosition,
    Jointed,
    JointStateRecord,
    LargeObject,
    MapObject,
    Node,
    ParkingPosition,
    Pose,
    PoseRecord,
    Relation,
    Room,
    SmallObject,
    Switch,
    SwitchType,
    as_pose,
    check_id,
    check_label,
)
from semantic_map.registration import large_object_from_model, small_object_from_model

N = TypeVar("N", bound=Node)


def _children(node: Node) -> list[Node]:
    if isinstance(node, Apartment):
        return list(node.rooms)
    if isinstance(node, Room):
        return [*node.switches, *node.objects]
    if isinstance(node, LargeObject):
        return list(node.small_objects)
    return []


def _utc(time: datetime | None) -> datetime:
    if time is None:
        return datetime.now(timezone.utc)
    if time.tzinfo is None:
        raise ValueError(f"{time=} has no time zone; give an aware datetime (e.g. in UTC)")
    return time.astimezone(timezone.utc)


class SemanticMap:
    """The hierarchical semantic map of one apartment; every id is unique across it."""

    def __init__(self, apartment: Apartment) -> None:
        self.apartment = apartment
        self._nodes: dict[str, Node] = {}
        self._parents: dict[str, str | None] = {}
        self._index(apartment, None)

    @classmethod
    def new(cls, *, apartment_id: str, name: str) -> SemanticMap:
        return cls(Apartment(id=check_id(apartment_id), name=check_label(name, "apartment name")))

    def __eq__(self, other: object) -> bool:
        return isinstance(other, SemanticMap) and self.apartment == other.apartment

    __hash__ = None  # type: ignore[assignment]

    def _index(self, node: Node, parent_id: str | None) -> None:
        if node.id in self._nodes:
            raise MapError(f"id {node.id!r} is used twice")
        self._nodes[node.id] = node
        self._parents[node.id] = parent_id
        for child in _children(node):
            self._index(child, node.id)

    def check_new_id(self, node_id: str) -> None:
        """A MapError unless `node_id` is a valid id not yet in the map."""
        check_id(node_id)
        if node_id in self._nodes:
            raise MapError(f"id {node_id!r} is already in the map (a {type(self._nodes[node_id]).__name__})")

    def _new_id(self, node_id: str) -> str:
        self.check_new_id(node_id)
        return node_id

    # Building

    def add_room(
        self,
        *,
        room_id: str,
        name: str,
        point_cloud: str | None = None,
        outline: list[tuple[float, float]] | None = None,
    ) -> Room:
        """Add a room; `point_cloud` refers to its part of the metric map, `outline` is its
        floor plan (polygon corners in the map frame)."""
        room = Room(
            id=self._new_id(room_id), name=check_label(name, "room name"), point_cloud=point_cloud, outline=outline
        )
        self.apartment.rooms.append(room)
        self._index(room, self.apartment.id)
        return room

    def add_switch(
        self, *, room_id: str, switch_id: str, world_from_switch: np.ndarray | Pose, type: SwitchType
    ) -> Switch:
        room = self._typed(room_id, Room)
        if type not in SWITCH_TYPES:
            raise MapError(f"switch {switch_id!r}: type {type!r} is not one of {', '.join(SWITCH_TYPES)}")
        switch = Switch(id=self._new_id(switch_id), type=type, world_from_switch=as_pose(world_from_switch))
        room.switches.append(switch)
        self._index(switch, room.id)
        return switch

    def register_model(
        self,
        model: Model,
        *,
        object_id: str,
        parent_id: str,
        relation: Relation | None = None,
        parent_from_object: np.ndarray | Pose | None = None,
        model_ref: str | None = None,
        parking_positions: Sequence[ParkingPosition] = (),
        default_positions: Sequence[DefaultPosition] | None = None,
        graspable: bool | None = None,
        properties: dict[str, str] | None = None,
        joint_positions: dict[str, float] | None = None,
    ) -> MapObject:
        """Add `model` under `parent_id`: under a room it becomes a large object (articulated
        if it has movable joints), under a large object a small one.

        `parent_from_object` is the object's pose in its parent's frame (the map frame for a
        room); `relation` (default "on") applies to small objects only, `parking_positions`
        (one of them the default) to large ones only. `graspable` defaults to True for small
        objects and False for large ones; `properties` are merged over the model's.
        """
        self._new_id(object_id)
        parent = self.node(parent_id)
        pose = as_pose(np.eye(4) if parent_from_object is None else parent_from_object)
        if isinstance(parent, Room):
            if relation is not None:
                raise MapError(f"large object {object_id!r}: a relation ({relation!r}) applies to small objects only")
            if default_positions is not None:
                raise MapError(f"large object {object_id!r}: default positions apply to small objects only")
            node: MapObject = large_object_from_model(
                model,
                object_id=object_id,
                world_from_object=pose,
                parking_positions=parking_positions,
                graspable=False if graspable is None else graspable,
                properties=properties,
                model_ref=model_ref,
                joint_positions=joint_positions,
            )
            parent.objects.append(node)
        elif isinstance(parent, LargeObject):
            relation = relation or "on"
            if relation not in RELATIONS:
                raise MapError(f"small object {object_id!r}: relation {relation!r} is not one of {', '.join(RELATIONS)}")
            if parking_positions:
                raise MapError(f"small object {object_id!r}: parking positions belong to large objects")
            node = small_object_from_model(
                model,
                object_id=object_id,
                parent_id=parent.id,
                relation=relation,
                parent_from_object=pose,
                default_positions=default_positions,
                graspable=True if graspable is None else graspable,
                properties=properties,
                model_ref=model_ref,
                joint_positions=joint_positions,
            )
            parent.small_objects.append(node)
        else:
            raise MapError(
                f"cannot place {object_id!r} under {parent_id!r}, a {type(parent).__name__}: "
                "large objects go in rooms, small objects on, in or under large objects"
            )
        self._index(node, parent.id)
        return node

    # Queries

    def node(self, node_id: str) -> Node:
        try:
            return self._nodes[node_id]
        except KeyError:
            raise MapError(f"no node with id {node_id!r} in the map") from None

    def _typed(self, node_id: str, kind: type[N]) -> N:
        node = self.node(node_id)
        if not isinstance(node, kind):
            raise MapError(f"{node_id!r} is a {type(node).__name__}, not a {kind.__name__}")
        return node

    def parent(self, node_id: str) -> Node | None:
        """The node holding `node_id`; None for the apartment."""
        self.node(node_id)
        parent_id = self._parents[node_id]
        return None if parent_id is None else self._nodes[parent_id]

    def path_to(self, node_id: str) -> list[str]:
        """The ids from the apartment down to `node_id`, as the robot's request walks them."""
        self.node(node_id)
        path: list[str] = []
        current: str | None = node_id
        while current is not None:
            path.append(current)
            current = self._parents[current]
        return path[::-1]

    def objects(self) -> Iterator[MapObject]:
        """Every large and small object, in document order."""
        for room in self.apartment.rooms:
            for large in room.objects:
                yield large
                yield from large.small_objects

    def find(self, *, type: str | None = None, properties: dict[str, str] | None = None) -> list[MapObject]:
        """The objects of `type` (any when None) whose properties include all of `properties`."""
        wanted = (properties or {}).items()
        return [
            obj
            for obj in self.objects()
            if (type is None or obj.type == type) and all(obj.properties.get(k) == v for k, v in wanted)
        ]

    def parking_positions(self, object_id: str) -> list[ParkingPosition]:
        """A large object's parking positions, the default first."""
        node = self.node(object_id)
        if isinstance(node, SmallObject):
            raise MapError(
                f"{object_id!r} is a small object; parking positions belong to its parent {node.parent!r}"
            )
        return list(self._typed(object_id, LargeObject).parking_positions)

    def world_from_object(self, node_id: str) -> np.ndarray:
        """The pose of an object or switch in the map frame."""
        node = self.node(node_id)
        if isinstance(node, LargeObject):
            return node.world_from_object.matrix()
        if isinstance(node, Switch):
            return node.world_from_switch.matrix()
        if isinstance(node, SmallObject):
            return self.world_from_object(node.parent) @ node.parent_from_object.matrix()
        raise MapError(f"{node_id!r} is a {type(node).__name__}; only objects and switches have a pose")

    def world_from_grasp_point(self, object_id: str, grasp_name: str) -> np.ndarray:
        """A grasp point in the map frame, with the object's joints at their current positions."""
        obj = self.node(object_id)
        if not isinstance(obj, LargeObject | SmallObject):
            raise MapError(f"{object_id!r} is a {type(obj).__name__}, not an object")
        grasp = next((g for g in obj.grasp_points if g.name == grasp_name), None)
        if grasp is None:
            raise MapError(f"object {object_id!r} has no grasp point {grasp_name!r}")
        object_from_grasp = grasp.object_from_grasp.matrix()
        joint_name = grasp.joint
        # Each joint's motion, in the object frame, applies to everything downstream of it.
        while joint_name is not None and isinstance(obj, Jointed):
            joint = obj.joint(joint_name)
            object_from_grasp = joint.object_motion(joint.position) @ object_from_grasp
            joint_name = joint.parent
        return self.world_from_object(object_id) @ object_from_grasp

    # Updates, each keeping the previous value in the object's history

    def _check_time(self, obj: MapObject, time: datetime) -> None:
        if obj.history and time < obj.history[-1].until:
            raise MapError(
                f"object {obj.id!r}: update at {time.isoformat()} is before its last recorded change "
                f"at {obj.history[-1].until.isoformat()}"
            )

    def update_pose(self, object_id: str, new_pose: np.ndarray | Pose, time: datetime | None = None) -> None:
        """Set an object's pose (map frame for a large object, parent's frame for a small one)."""
        obj = self.node(object_id)
        pose, at = as_pose(new_pose), _utc(time)
        if isinstance(obj, LargeObject):
            self._check_time(obj, at)
            obj.history.append(PoseRecord(until=at, pose=obj.world_from_object))
            obj.world_from_object = pose
        elif isinstance(obj, SmallObject):
            self._check_time(obj, at)
            obj.history.append(PoseRecord(until=at, pose=obj.parent_from_object, parent=obj.parent, relation=obj.relation))
            obj.parent_from_object = pose
        else:
            raise MapError(f"{object_id!r} is a {type(obj).__name__}, not an object")

    def move_object(
        self,
        object_id: str,
        *,
        parent_id: str,
        relation: Relation,
        parent_from_object: np.ndarray | Pose,
        time: datetime | None = None,
    ) -> None:
        """Move a small object onto, into or under another large object."""
        obj = self._typed(object_id, SmallObject)
        new_parent = self._typed(parent_id, LargeObject)
        if relation not in RELATIONS:
            raise MapError(f"small object {object_id!r}: relation {relation!r} is not one of {', '.join(RELATIONS)}")
        pose, at = as_pose(parent_from_object), _utc(time)
        self._check_time(obj, at)
        old_parent = self._typed(obj.parent, LargeObject)
        obj.history.append(PoseRecord(until=at, pose=obj.parent_from_object, parent=obj.parent, relation=obj.relation))
        old_parent.small_objects.remove(obj)
        new_parent.small_objects.append(obj)
        obj.parent, obj.relation, obj.parent_from_object = new_parent.id, relation, pose
        self._parents[obj.id] = new_parent.id

    def set_joint_state(
        self, object_id: str, joint_name: str, value: float | str, time: datetime | None = None
    ) -> None:
        """Set a joint's position (rad or m), or one of its named states such as "open"."""
        obj = self.node(object_id)
        if not isinstance(obj, Jointed):
            raise MapError(f"{object_id!r} is a {type(obj).__name__}, which has no joints")
        joint = obj.joint(joint_name)
        if isinstance(value, str):
            state = next((s for s in joint.states if s.name == value), None)
            if state is None:
                raise MapError(
                    f"joint {joint_name!r} of {object_id!r} has no state {value!r} "
                    f"(it has {[s.name for s in joint.states]})"
                )
            value = state.position
        position = joint.check_position(value)
        at = _utc(time)
        self._check_time(obj, at)
        obj.history.append(JointStateRecord(until=at, joint=joint.name, position=joint.position))
        joint.position = position
