"""Read a schema-valid map document into nodes.

The schema has already checked the structure, ids, enumerations and references; what it
cannot say (a joint position outside its limits, limits missing on a revolute joint) the
node types check, and the message gains the file and line here.
"""

from __future__ import annotations

from collections.abc import Callable
from datetime import datetime
from typing import TypeVar

from lxml import etree

from homemodel.core.errors import MapError
from homemodel.exchange.map_xml.write import q
from semantic_map.nodes import (
    Apartment,
    DefaultPosition,
    JointStateRecord,
    LargeArticulatedObject,
    LargeObject,
    NamedState,
    ObjectGraspPoint,
    ObjectJoint,
    ParkingPosition,
    Pose,
    PoseRecord,
    Room,
    SmallObject,
    Switch,
)

T = TypeVar("T")


def _floats(text: str) -> tuple[float, ...]:
    return tuple(float(v) for v in text.split())


def _pose(el: etree._Element) -> Pose:
    return Pose(_floats(el.get("xyz")), _floats(el.get("rpy")))  # type: ignore[arg-type]


class _Reader:
    def __init__(self, source: str) -> None:
        self.source = source

    def at(self, el: etree._Element, build: Callable[[], T]) -> T:
        """`build()`, with a failure reported at `el`'s line."""
        try:
            return build()
        except (MapError, ValueError) as exc:
            raise MapError(f"{self.source}: line {el.sourceline}: {exc}") from None

    def time(self, el: etree._Element) -> datetime:
        return self.at(el, lambda: datetime.fromisoformat(el.get("until")))

    def semantics(self, el: etree._Element) -> dict:
        return dict(
            id=el.get("id"),
            type=el.get("type"),
            graspable=el.get("graspable") in ("true", "1"),
            model_ref=el.get("model"),
            affordances=[a.text for a in el.iterfind(q("affordance"))],
            properties={p.get("name"): p.get("value") for p in el.iterfind(q("property"))},
            grasp_points=[
                ObjectGraspPoint(name=g.get("name"), kind=g.get("kind"), object_from_grasp=_pose(g), joint=g.get("joint"))
                for g in el.iterfind(q("graspPoint"))
            ],
        )

    def history(self, el: etree._Element) -> list[PoseRecord | JointStateRecord]:
        records: list[PoseRecord | JointStateRecord] = []
        for r in el.iterfind(f"{q('history')}/*"):
            if r.tag == q("pose"):
                records.append(
                    PoseRecord(until=self.time(r), pose=_pose(r), parent=r.get("parent"), relation=r.get("relation"))
                )
            else:
                records.append(JointStateRecord(until=self.time(r), joint=r.get("joint"), position=float(r.get("position"))))
        return records

    def joint(self, el: etree._Element) -> ObjectJoint:
        limits = el.find(q("limits"))
        return self.at(
            el,
            lambda: ObjectJoint(
                name=el.get("name"),
                type=el.get("type"),
                object_from_joint=_pose(el.find(q("origin"))),
                axis=_floats(el.find(q("axis")).get("xyz")),  # type: ignore[arg-type]
                limits=None if limits is None else (float(limits.get("lower")), float(limits.get("upper"))),
                position=float(el.get("position")),
                states=[NamedState(name=s.get("name"), position=float(s.get("position"))) for s in el.iterfind(q("state"))],
                parent=el.get("parent"),
            ),
        )

    def small_object(self, el: etree._Element) -> SmallObject:
        return SmallObject(
            **self.semantics(el),
            parent=el.get("parent"),
            relation=el.get("relation"),
            parent_from_object=_pose(el),
            default_positions=[
                self.at(p, lambda p=p: DefaultPosition(name=p.get("name"), parent_from_object=_pose(p)))
                for p in el.iterfind(q("defaultPosition"))
            ],
            joints=[self.joint(j) for j in el.iterfind(q("joint"))],
            history=self.history(el),
        )

    def large_object(self, el: etree._Element) -> LargeObject:
        fields = dict(
            **self.semantics(el),
            world_from_object=_pose(el),
            parking_positions=[
                self.at(
                    p,
                    lambda p=p: ParkingPosition(
                        name=p.get("name"), world_from_base=_pose(p), default=p.tag == q("defaultParking")
                    ),
                )
                for p in el
                if p.tag in (q("defaultParking"), q("parking"))
            ],
            small_objects=[self.small_object(s) for s in el.iterfind(q("smallObject"))],
            history=self.history(el),
        )
        if el.tag == q("largeObject"):
            return LargeObject(**fields)
        return LargeArticulatedObject(**fields, joints=[self.joint(j) for j in el.iterfind(q("joint"))])

    def room(self, el: etree._Element) -> Room:
        return Room(
            id=el.get("id"),
            name=el.get("name"),
            point_cloud=el.get("pointCloud"),
            outline=[_floats(c.get("xy")) for c in el.iterfind(f"{q('outline')}/{q('corner')}")] or None,
            switches=[
                Switch(id=s.get("id"), type=s.get("type"), world_from_switch=_pose(s)) for s in el.iterfind(q("switch"))
            ],
            objects=[self.large_object(o) for o in el if o.tag in (q("largeObject"), q("largeArticulatedObject"))],
        )


def apartment_from_tree(tree: etree._ElementTree, source: str) -> Apartment:
    """The apartment of a schema-valid tree; `source` names the file in error messages."""
    root = tree.getroot()
    reader = _Reader(source)
    return Apartment(id=root.get("id"), name=root.get("name"), rooms=[reader.room(r) for r in root.iterfind(q("room"))])
