"""The semantic map of D3.1 Figure 47's house and the small models in it, built in code for
the tests of the map, its command line and the pipelines that register into it; and hostile
XML files that every map reader must refuse."""

from __future__ import annotations

from datetime import datetime, timezone

import numpy as np
import trimesh

from articulation.model import GraspPoint, Joint, JointLimits, JointState, Link, Material, Model, Visual
from homemodel.core.transforms import transform_from_xyz_rpy
from semantic_map import ParkingPosition, SemanticMap

T0 = datetime(2025, 3, 1, 9, 30, tzinfo=timezone.utc)
TABLE_POSE = transform_from_xyz_rpy((2.0, 1.0, 0.0), (0.0, 0.0, np.pi / 2))
BLUE_CUP_POSE = transform_from_xyz_rpy((0.3, -0.1, 0.75), (0.0, 0.0, 0.4))


def _link(name: str, mesh: trimesh.Trimesh, at: np.ndarray | None = None) -> Link:
    visual = Visual(
        name=name, mesh=mesh, material=Material(name="grey"), link_from_visual=np.eye(4) if at is None else at
    )
    return Link(name=name, visuals=[visual])


def box_model(category: str, size: tuple[float, float, float], **semantics) -> Model:
    return Model(name=category, links=[_link("body", trimesh.creation.box(size))], category=category, **semantics)


def cup_model(category: str = "cup", colour: str = "white") -> Model:
    return Model(
        name=category,
        links=[_link("body", trimesh.creation.cylinder(radius=0.04, height=0.1, sections=12))],
        grasp_points=[
            GraspPoint(name="side", link="body", link_from_grasp=transform_from_xyz_rpy((0.04, 0, 0.05)), kind="body")
        ],
        category=category,
        affordances=["container"],
        properties={"colour": colour, "material": "ceramic"},
    )


def cupboard_model() -> Model:
    """A body, a door on a vertical hinge (its joint frame rolled, so the axis must be turned
    into the object frame), and a lock knob on the door: a joint under a joint."""
    hinge = Joint(
        name="door_hinge",
        type="revolute",
        parent="body",
        child="door",
        parent_from_joint=transform_from_xyz_rpy((0.3, -0.25, 0.05), (np.pi / 2, 0, 0)),
        axis=(0, 1, 0),
        limits=JointLimits(lower=0.0, upper=1.9),
        states=[JointState(name="closed", position=0.0), JointState(name="open", position=1.57)],
    )
    knob = Joint(
        name="lock",
        type="continuous",
        parent="door",
        child="knob",
        parent_from_joint=transform_from_xyz_rpy((-0.5, 0.4, 0.02)),
        axis=(0, 0, 1),
    )
    return Model(
        name="cupboard",
        links=[
            _link("body", trimesh.creation.box((0.6, 0.5, 0.9)), transform_from_xyz_rpy((0, 0, 0.45))),
            _link("door", trimesh.creation.box((0.6, 0.8, 0.02)), transform_from_xyz_rpy((-0.3, 0.45, 0))),
            _link("knob", trimesh.creation.cylinder(radius=0.02, height=0.03, sections=8)),
        ],
        joints=[hinge, knob],
        grasp_points=[
            GraspPoint(
                name="door_handle",
                link="door",
                link_from_grasp=transform_from_xyz_rpy((-0.55, 0.45, 0.03)),
                kind="handle",
            ),
            GraspPoint(
                name="lock_knob", link="knob", link_from_grasp=transform_from_xyz_rpy((0, 0, 0.03)), kind="knob"
            ),
        ],
        category="cupboard",
        affordances=["container"],
    )


def fridge_model() -> Model:
    drawer = Joint(
        name="freezer_drawer",
        type="prismatic",
        parent="body",
        child="drawer",
        parent_from_joint=transform_from_xyz_rpy((0.35, 0, 0.2)),
        axis=(1, 0, 0),
        limits=JointLimits(lower=0.0, upper=0.4),
    )
    return Model(
        name="fridge",
        links=[
            _link("body", trimesh.creation.box((0.7, 0.6, 1.8))),
            _link("drawer", trimesh.creation.box((0.6, 0.5, 0.3))),
        ],
        joints=[drawer],
        grasp_points=[
            GraspPoint(name="drawer_handle", link="drawer", link_from_grasp=transform_from_xyz_rpy((0.32, 0, 0.1)))
        ],
        category="fridge",
        affordances=["container"],
    )


def parking(name: str, x: float, y: float, yaw: float, default: bool = False) -> ParkingPosition:
    return ParkingPosition(name=name, world_from_base=transform_from_xyz_rpy((x, y, 0), (0, 0, yaw)), default=default)


def build_house() -> SemanticMap:
    """Figure 47: a kitchen and a bathroom; a table, a cupboard and a fridge in the kitchen;
    a red cup, a bowl, a sugar container and the blue cup on the table."""
    smap = SemanticMap.new(apartment_id="house", name="House")
    smap.add_room(room_id="kitchen", name="Kitchen", point_cloud="clouds/kitchen.pcd")
    smap.add_room(room_id="bathroom", name="Bathroom")
    smap.add_switch(
        room_id="kitchen",
        switch_id="kitchen_light",
        world_from_switch=transform_from_xyz_rpy((0, 0.1, 1.2)),
        type="rotational",
    )
    smap.register_model(
        box_model("table", (1.2, 0.8, 0.75), affordances=["supporting_surface"]),
        object_id="table",
        parent_id="kitchen",
        parent_from_object=TABLE_POSE,
        model_ref="models/table/model.urdf",
        # Given out of order: the map keeps the default first, the rest as given.
        parking_positions=[
            parking("left", 1.0, 1.0, 0.0),
            parking("front", 2.0, 0.0, np.pi / 2, default=True),
            parking("right", 3.0, 1.0, np.pi),
        ],
    )
    smap.register_model(
        cupboard_model(),
        object_id="cupboard",
        parent_id="kitchen",
        parent_from_object=transform_from_xyz_rpy((4.0, 0.3, 0.0), (0, 0, -np.pi / 2)),
        model_ref="models/cupboard/model.urdf",
        parking_positions=[parking("front", 4.0, 1.2, -np.pi / 2, default=True)],
        properties={"colour": "white"},
    )
    smap.register_model(
        fridge_model(),
        object_id="fridge",
        parent_id="kitchen",
        parent_from_object=transform_from_xyz_rpy((5.0, 0.3, 0.0)),
        parking_positions=[parking("front", 5.0, 1.3, -np.pi / 2, default=True)],
    )
    on_table = [
        ("red_cup", cup_model(colour="red"), (-0.3, 0.1)),
        ("bowl", cup_model("bowl"), (0.0, 0.2)),
        ("sugar", cup_model("sugar_container"), (0.1, -0.2)),
    ]
    for object_id, model, (x, y) in on_table:
        smap.register_model(
            model,
            object_id=object_id,
            parent_id="table",
            relation="on",
            parent_from_object=transform_from_xyz_rpy((x, y, 0.75)),
        )
    smap.register_model(
        cup_model(colour="white"),
        object_id="blue_cup",
        parent_id="table",
        relation="on",
        parent_from_object=BLUE_CUP_POSE,
        model_ref="models/blue_cup/model.urdf",
        properties={"colour": "blue"},
    )
    return smap


HOSTILE = {
    "external-entity": b'<?xml version="1.0"?>\n<!DOCTYPE x [<!ENTITY e SYSTEM "file:///etc/passwd">]>\n'
    b'<apartment xmlns="https://homemodel.dev/semantic-map/1" id="h" name="&e;"/>\n',
    "billion-laughs": b'<?xml version="1.0"?>\n<!DOCTYPE lolz [\n <!ENTITY lol "lol">\n'
    + b"".join(
        b' <!ENTITY lol%d "%s">\n' % (i, (b"&lol%d;" % (i - 1) if i > 1 else b"&lol;") * 10) for i in range(1, 10)
    )
    + b']>\n<apartment xmlns="https://homemodel.dev/semantic-map/1" id="h" name="&lol9;"/>\n',
}
