"""Write the map's nodes as XML elements in the schema's namespace, deterministically.

Floats are written with `repr` (the shortest text that reads back to the same float),
properties sorted by name, everything else in the map's own order, so the same map always
gives the same bytes.
"""

from __future__ import annotations

from collections.abc import Sequence
from datetime import datetime, timezone

from lxml import etree

from semantic_map.nodes import (
    Apartment,
    JointStateRecord,
    LargeArticulatedObject,
    LargeObject,
    ObjectGraspPoint,
    ObjectJoint,
    Pose,
    PoseRecord,
    Room,
    SmallObject,
)

NAMESPACE = "https://homemodel.dev/semantic-map/1"


def q(tag: str) -> str:
    return f"{{{NAMESPACE}}}{tag}"


def number(value: float) -> str:
    return repr(float(value) + 0.0)


def numbers(values: Sequence[float]) -> str:
    return " ".join(number(v) for v in values)


def utc_text(time: datetime) -> str:
    return time.astimezone(timezone.utc).isoformat().replace("+00:00", "Z")


def _sub(owner: etree._Element, tag: str, **attributes: str | None) -> etree._Element:
    return etree.SubElement(owner, q(tag), {k: v for k, v in attributes.items() if v is not None})


def _pose(element: etree._Element, pose: Pose) -> None:
    element.set("xyz", numbers(pose.xyz))
    element.set("rpy", numbers(pose.rpy))


def _posed(owner: etree._Element, tag: str, pose: Pose, **attributes: str | None) -> etree._Element:
    element = _sub(owner, tag, **attributes)
    _pose(element, pose)
    return element


def _object(owner: etree._Element, tag: str, obj: LargeObject | SmallObject, pose: Pose, **placement: str) -> etree._Element:
    graspable = "true" if obj.graspable else "false"
    element = _sub(owner, tag, id=obj.id, type=obj.type, **placement, graspable=graspable, model=obj.model_ref)
    _pose(element, pose)
    return element


def _semantics(element: etree._Element, obj: LargeObject | SmallObject) -> None:
    for affordance in obj.affordances:
        _sub(element, "affordance").text = affordance
    for name in sorted(obj.properties):
        _sub(element, "property", name=name, value=obj.properties[name])


def _grasp_points(element: etree._Element, points: Sequence[ObjectGraspPoint]) -> None:
    for g in points:
        _posed(element, "graspPoint", g.object_from_grasp, name=g.name, kind=g.kind, joint=g.joint)


def _history(element: etree._Element, records: Sequence[PoseRecord | JointStateRecord]) -> None:
    if not records:
        return
    history = _sub(element, "history")
    for r in records:
        if isinstance(r, PoseRecord):
            _posed(history, "pose", r.pose, until=utc_text(r.until), parent=r.parent, relation=r.relation)
        else:
            _sub(history, "jointState", until=utc_text(r.until), joint=r.joint, position=number(r.position))


def _joint(element: etree._Element, joint: ObjectJoint) -> None:
    el = _sub(element, "joint", name=joint.name, type=joint.type, position=number(joint.position), parent=joint.parent)
    _posed(el, "origin", joint.object_from_joint)
    _sub(el, "axis", xyz=numbers(joint.axis))
    if joint.limits is not None:
        _sub(el, "limits", lower=number(joint.limits[0]), upper=number(joint.limits[1]))
    for state in joint.states:
        _sub(el, "state", name=state.name, position=number(state.position))


def _small_object(owner: etree._Element, obj: SmallObject) -> None:
    el = _object(owner, "smallObject", obj, obj.parent_from_object, parent=obj.parent, relation=obj.relation)
    for position in obj.default_positions:
        _posed(el, "defaultPosition", position.parent_from_object, name=position.name)
    _semantics(el, obj)
    for joint in obj.joints:
        _joint(el, joint)
    _grasp_points(el, obj.grasp_points)
    _history(el, obj.history)


def _large_object(room: etree._Element, obj: LargeObject) -> None:
    articulated = isinstance(obj, LargeArticulatedObject)
    el = _object(room, "largeArticulatedObject" if articulated else "largeObject", obj, obj.world_from_object)
    for p in obj.parking_positions:
        _posed(el, "defaultParking" if p.default else "parking", p.world_from_base, name=p.name)
    _semantics(el, obj)
    if isinstance(obj, LargeArticulatedObject):
        for joint in obj.joints:
            _joint(el, joint)
    _grasp_points(el, obj.grasp_points)
    _history(el, obj.history)
    for small in obj.small_objects:
        _small_object(el, small)


def _room(apartment: etree._Element, room: Room) -> None:
    el = _sub(apartment, "room", id=room.id, name=room.name, pointCloud=room.point_cloud)
    if room.outline is not None:
        outline = _sub(el, "outline")
        for corner in room.outline:
            _sub(outline, "corner", xy=numbers(corner))
    for switch in room.switches:
        _posed(el, "switch", switch.world_from_switch, id=switch.id, type=switch.type)
    for obj in room.objects:
        _large_object(el, obj)


def apartment_to_bytes(apartment: Apartment) -> bytes:
    root = etree.Element(q("apartment"), nsmap={None: NAMESPACE})
    root.set("id", apartment.id)
    root.set("name", apartment.name)
    for room in apartment.rooms:
        _room(root, room)
    return etree.tostring(root, xml_declaration=True, encoding="UTF-8", pretty_print=True)
