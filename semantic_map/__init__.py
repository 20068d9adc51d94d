"""The hierarchical semantic map of a home (RAMCIP D3.1 section 3.2.2, Figures 3-7).

An apartment holds rooms; a room holds switches and large objects (furniture, and
articulated ones with joints and handles or knobs); a large object holds the small objects
on, in or under it. Models register into the map with `SemanticMap.register_model`, which
takes over their category, affordances, properties, joints and grasp points.

Frames: large objects, switches and parking positions are in the map (world) frame; a small
object's pose and default positions are in its parent object's frame; joint origins, joint
axes and grasp points are in the owning object's frame (its model's root link frame with
every joint at zero). `SemanticMap.world_from_object` composes them.

The map's file is a format, so it lives with the others: `homemodel.exchange.map_xml` loads and
saves it (XML following its `semantic_map.xsd`, namespace https://homemodel.dev/semantic-map/1,
validated on load and on save), and `homemodel.exchange.home_scene` writes a home as one
simulator scene. `homemodel.model_folder.map_entry` registers a model folder into a map file.
Updates keep the previous pose or joint state in the object's timestamped history.
"""

from semantic_map.hierarchy import SemanticMap
from semantic_map.nodes import (
    Apartment,
    DefaultPosition,
    JointStateRecord,
    LargeArticulatedObject,
    LargeObject,
    MapObject,
    NamedState,
    Node,
    ObjectGraspPoint,
    ObjectJoint,
    ParkingPosition,
    Pose,
    PoseRecord,
    Room,
    SmallObject,
    Switch,
)

__all__ = [
    "Apartment",
    "DefaultPosition",
    "JointStateRecord",
    "LargeArticulatedObject",
    "LargeObject",
    "MapObject",
    "NamedState",
    "Node",
    "ObjectGraspPoint",
    "ObjectJoint",
    "ParkingPosition",
    "Pose",
    "PoseRecord",
    "Room",
    "SemanticMap",
    "SmallObject",
    "Switch",
]
