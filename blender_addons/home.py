"""A home in a .blend: rooms as collections, objects as models placed in them, small
objects on, in or under large ones, and parking positions as arrow empties.

Scheme (custom properties, as for models; see `rig`):
- the scene's `hm_apartment`: JSON {id, name};
- a room is a collection with `hm_room` (its id) and `hm_room_name`;
- a model's root link holds `hm_object_id` and `hm_properties` (JSON, the map's properties
  of the object); a small object also `hm_parent` (the large object's id) and `hm_relation`
  (on, in or under). Objects are in the map frame;
- a light switch or button is an empty in its room with `hm_switch` (id) and `hm_switch_type`;
- a parking position is an empty (arrows: x is where the robot faces) parented to its
  large object, with `hm_parking` (its name) and `hm_parking_default`.
"""

from __future__ import annotations

import json
import re

import bpy
from mathutils import Matrix, Vector

from . import rig

APARTMENT = "hm_apartment"
ROOM = "hm_room"
ROOM_NAME = "hm_room_name"
OBJECT_ID = "hm_object_id"
PARENT = "hm_parent"
PROPERTIES = "hm_properties"  # JSON: what the map says of the object beyond its model
RELATION = "hm_relation"
SWITCH = "hm_switch"
SWITCH_TYPE = "hm_switch_type"
PARKING = "hm_parking"
PARKING_DEFAULT = "hm_parking_default"
HOME_FORMAT = "homemodel.blender-home/1"
RELATIONS = ("on", "in", "under")
# Where a small object's base may be from a surface and still stand "on" it.
ON_TOLERANCE_M = 0.01


def safe_id(text: str) -> str:
    """`text` made into a map id (letters, digits, _ and -, starting with a letter)."""
    cleaned = re.sub(r"[^A-Za-z0-9_-]+", "_", text).strip("_") or "object"
    return cleaned if cleaned[0].isalpha() else f"o_{cleaned}"


def object_id(root: bpy.types.Object) -> str:
    return root.get(OBJECT_ID) or safe_id(json.loads(root[rig.MODEL])["name"])


def room_of(root: bpy.types.Object) -> bpy.types.Collection | None:
    return next((c for c in root.users_collection if ROOM in c), None)


def rooms(scene: bpy.types.Scene) -> list[bpy.types.Collection]:
    return [c for c in scene.collection.children_recursive if ROOM in c]


def add_room(scene: bpy.types.Scene, room_id: str, name: str) -> bpy.types.Collection:
    collection = bpy.data.collections.new(name)
    collection[ROOM] = safe_id(room_id)
    collection[ROOM_NAME] = name
    scene.collection.children.link(collection)
    return collection


def move_to_collection(root: bpy.types.Object, collection: bpy.types.Collection) -> None:
    for obj in [root, *rig.model_objects(root), *parking_of(root)]:
        for old in list(obj.users_collection):
            old.objects.unlink(obj)
        collection.objects.link(obj)


def model_roots(scene: bpy.types.Scene) -> list[bpy.types.Object]:
    return [obj for obj in scene.objects if rig.MODEL in obj]


def large_objects(scene: bpy.types.Scene) -> dict[str, bpy.types.Object]:
    return {object_id(root): root for root in model_roots(scene) if PARENT not in root}


def parking_of(root: bpy.types.Object) -> list[bpy.types.Object]:
    return [child for child in root.children if PARKING in child]


def add_parking(root: bpy.types.Object, name: str, world_from_base: Matrix, default: bool) -> bpy.types.Object:
    empty = bpy.data.objects.new(f"{object_id(root)}:parking:{name}", None)
    empty.empty_display_type = "ARROWS"
    empty.empty_display_size = 0.3
    empty.show_name = True
    empty[PARKING] = name
    empty[PARKING_DEFAULT] = bool(default)
    for collection in root.users_collection:
        collection.objects.link(empty)
    empty.parent = root
    empty.matrix_parent_inverse = root.matrix_world.inverted()
    empty.matrix_world = world_from_base
    if default:
        for other in parking_of(root):
            if other is not empty:
                other[PARKING_DEFAULT] = False
    return empty


def _world_bounds(root: bpy.types.Object) -> tuple[list[float], list[float]]:
    corners = [obj.matrix_world @ Vector(c) for obj in rig.model_objects(root) if obj.type == "MESH" for c in obj.bound_box]
    if not corners:
        p = root.matrix_world.translation
        return [p.x, p.y, p.z], [p.x, p.y, p.z]
    return [min(c[i] for c in corners) for i in range(3)], [max(c[i] for c in corners) for i in range(3)]


def offered_placement(scene: bpy.types.Scene, small: bpy.types.Object) -> tuple[str, str] | None:
    """(large object id, relation) from where `small` stands: the large object whose
    footprint holds its base; "on" its top, "under" it, or "in" it; None when it stands
    on no large object."""
    base = small.matrix_world.translation
    best = None
    for large_id, large in large_objects(scene).items():
        if large is small:
            continue
        low, high = _world_bounds(large)
        if not (low[0] <= base.x <= high[0] and low[1] <= base.y <= high[1]):
            continue
        if abs(base.z - high[2]) <= ON_TOLERANCE_M:
            relation = "on"
        elif base.z < low[2] + ON_TOLERANCE_M:
            relation = "under"
        elif base.z < high[2]:
            relation = "in"
        else:
            continue
        # The nearest surface below wins (a cup on a tray on a table goes to the tray).
        gap = abs(base.z - high[2])
        if best is None or gap < best[0]:
            best = (gap, large_id, relation)
    return None if best is None else (best[1], best[2])


def home_document(scene: bpy.types.Scene, depsgraph, write_model) -> dict:
    """The home document of the scene; `write_model(object_id, model_doc)` stores each
    model's document and returns its path relative to the home document."""
    apartment = json.loads(scene.get(APARTMENT, "{}")) or {"id": "home", "name": "Home"}
    larges = large_objects(scene)
    objects, seen = [], set()
    for room in rooms(scene):
        roots = [o for o in room.objects if rig.MODEL in o]
        ordered = [r for r in roots if PARENT not in r] + [r for r in roots if PARENT in r]
        for root in ordered:
            oid = object_id(root)
            if oid in seen:
                raise ValueError(f"two objects share the id {oid!r}; rename one (Object id in the homemodel panel)")
            seen.add(oid)
            entry = {
                "id": oid,
                "room": room[ROOM],
                "model": write_model(oid, rig.model_document(root, depsgraph)),
                "joint_positions": {j[rig.JOINT]: float(j[rig.POSITION]) for j in rig.joints_of(root) if j[rig.JOINT_TYPE] != "fixed"},
                "properties": json.loads(root.get(PROPERTIES, "{}")),
                "parking": [],
                "relation": None,
            }
            world_from_object = rig.rigid(root.matrix_world)
            if PARENT in root:
                parent = larges.get(root[PARENT])
                if parent is None:
                    raise ValueError(f"{oid!r} stands {root.get(RELATION, 'on')} {root[PARENT]!r}, which is not in the home")
                entry.update(parent=root[PARENT], relation=root.get(RELATION, "on"),
                             parent_from_object=rig.rows_of(rig.rigid(parent.matrix_world).inverted() @ world_from_object))
            else:
                entry.update(parent=room[ROOM], parent_from_object=rig.rows_of(world_from_object))
                entry["parking"] = [
                    {"name": p[PARKING], "default": bool(p.get(PARKING_DEFAULT)), "world_from_base": rig.rows_of(rig.rigid(p.matrix_world))}
                    for p in parking_of(root)
                ]
            objects.append(entry)
    return {
        "format": HOME_FORMAT,
        "apartment": apartment,
        "rooms": [{"id": r[ROOM], "name": r.get(ROOM_NAME, r.name), "point_cloud": r.get("hm_point_cloud")} for r in rooms(scene)],
        "switches": [
            {"id": o[SWITCH], "room": r[ROOM], "type": o.get(SWITCH_TYPE, "light"), "world_from_switch": rig.rows_of(rig.rigid(o.matrix_world))}
            for r in rooms(scene)
            for o in r.objects
            if SWITCH in o
        ],
        "objects": objects,
    }


def add_home(scene: bpy.types.Scene, home: dict, read_model) -> list[bpy.types.Object]:
    """Put a home document's rooms and objects into the scene; `read_model(path)` gives a
    model document. Returns the models' root links."""
    scene[APARTMENT] = json.dumps(home["apartment"])
    collections = {}
    for room in home["rooms"]:
        collections[room["id"]] = add_room(scene, room["id"], room["name"])
        if room.get("point_cloud"):
            collections[room["id"]]["hm_point_cloud"] = room["point_cloud"]
    for switch in home.get("switches", []):
        empty = bpy.data.objects.new(f"switch:{switch['id']}", None)
        empty.empty_display_type = "CUBE"
        empty.empty_display_size = 0.04
        empty.show_name = True
        empty[SWITCH], empty[SWITCH_TYPE] = switch["id"], switch["type"]
        collections[switch["room"]].objects.link(empty)
        empty.matrix_world = rig.matrix_of(switch["world_from_switch"])
    roots: dict[str, bpy.types.Object] = {}
    for obj in home["objects"]:
        parent_from_object = rig.matrix_of(obj["parent_from_object"])
        small = obj.get("relation") is not None
        world_from_object = (roots[obj["parent"]].matrix_world @ parent_from_object) if small else parent_from_object
        root = rig.add_model(read_model(obj["model"]), collections[obj["room"]], world_from_object)
        root[OBJECT_ID] = obj["id"]
        if obj.get("properties"):
            root[PROPERTIES] = json.dumps(obj["properties"])
        if small:
            root[PARENT] = obj["parent"]
            root[RELATION] = obj["relation"]
        for joint in rig.joints_of(root):
            if joint[rig.JOINT] in obj.get("joint_positions", {}):
                rig.set_position(joint, obj["joint_positions"][joint[rig.JOINT]])
        for parking in obj.get("parking", []):
            add_parking(root, parking["name"], rig.matrix_of(parking["world_from_base"]), parking.get("default", False))
        roots[obj["id"]] = root
    return list(roots.values())
