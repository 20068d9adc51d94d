"""The hierarchical semantic map of a home (RAMCIP D3.1 section 3.2.2, Figures 3-7).

An apartment holds rooms; a room holds switches and large objects (furniture, and
articulated ones with joints and handles or knobs); a large object holds the small objects
on, in or under it. Models register into the map with `SemanticMap.register_model`, which
takes over their category, affordances, properties, joints and grasp points.

Frames: large objects, switches and parking positions are in the map (world) frame; a small
object's pose and default positions are in its parent object's frame; joint origins, joint
axes and grasp points are in the owning object's frame (its model's root link frame with
every joint at zero). `SemanticMap.world_from_object` composes them.

`scene_from_map` turns a map into a simulator scene and `export_home` writes it as URDF, MJCF,
SDF, USD or glTF (`homemodel map export`).

`add_model_folder` registers a model folder into a map file (the command `homemodel map add`
and the pipelines' maps); `add_asset` imports a raw asset (a glb or OBJ, a ROS URDF) into a
model folder first.

Files follow `schema/semantic_map.xsd` (namespace https://homemodel.dev/semantic-map/1) and
are validated on load and on save; updates keep the previous pose or joint state in the
object's timestamped history.
"""

from semantic_map.hierarchy import SemanticMap
from semantic_map.home_scene import export_home, scene_from_map
from semantic_map.model_folder import MapEntry, Registration, add_asset, add_model_folder
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
from semantic_map.xml_io import SCHEMA_PATH, load_map, map_to_bytes, save_map

__all__ = [
    "SCHEMA_PATH",
    "Apartment",
    "DefaultPosition",
    "JointStateRecord",
    "LargeArticulatedObject",
    "LargeObject",
    "MapEntry",
    "MapObject",
    "NamedState",
    "Node",
    "ObjectGraspPoint",
    "ObjectJoint",
    "ParkingPosition",
    "Pose",
    "PoseRecord",
    "Registration",
    "Room",
    "SemanticMap",
    "SmallObject",
    "Switch",
    "add_asset",
    "add_model_folder",
    "export_home",
    "load_map",
    "map_to_bytes",
    "save_map",
    "scene_from_map",
]
