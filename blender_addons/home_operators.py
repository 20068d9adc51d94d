"""Operators on the home: rooms, placing objects, parking positions, map import and export."""

from __future__ import annotations

import json
import math
import tempfile
from pathlib import Path

import bpy
from bpy.props import BoolProperty, StringProperty
from bpy_extras.io_utils import ImportHelper
from mathutils import Matrix

from . import home, rig, toolkit
from .properties import preference

# What Export home last reported, for the panel.
HOME_REPORT: list[str] = []


def _root(context):
    return rig.model_root(context.active_object)


class HOMEMODEL_OT_add_room(bpy.types.Operator):
    """Add a room: a collection the home's objects go into"""

    bl_idname = "homemodel.add_room"
    bl_label = "Add room"
    bl_options = {"REGISTER", "UNDO"}
    name: StringProperty(name="Name", default="Kitchen")

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        room_id = home.safe_id(self.name.lower())
        if room_id in {r[home.ROOM] for r in home.rooms(context.scene)}:
            self.report({"ERROR"}, f"there is already a room {room_id!r}")
            return {"CANCELLED"}
        home.add_room(context.scene, room_id, self.name)
        context.scene.homemodel_room = room_id
        return {"FINISHED"}


class HOMEMODEL_OT_place(bpy.types.Operator):
    """Put the selected model in the chosen room; a small object goes on, in or under the large object it stands on"""

    bl_idname = "homemodel.place"
    bl_label = "Place in room"
    bl_options = {"REGISTER", "UNDO"}
    small: BoolProperty(name="Small object", description="it stands on, in or under a large object", default=False)

    @classmethod
    def poll(cls, context):
        return _root(context) is not None

    def execute(self, context):
        root = _root(context)
        room = next((r for r in home.rooms(context.scene) if r[home.ROOM] == context.scene.homemodel_room), None)
        if room is None:
            self.report({"ERROR"}, "choose a room first (Add room makes one)")
            return {"CANCELLED"}
        if home.OBJECT_ID not in root:
            root[home.OBJECT_ID] = home.object_id(root)
        home.move_to_collection(root, room)
        if self.small:
            context.view_layer.update()
            offered = home.offered_placement(context.scene, root)
            if offered is None:
                self.report({"ERROR"}, f"{root[home.OBJECT_ID]} stands on no large object: move it onto, into or under one")
                return {"CANCELLED"}
            root[home.PARENT], root[home.RELATION] = offered
            self.report({"INFO"}, f"{root[home.OBJECT_ID]} is {offered[1]} {offered[0]}")
        else:
            for key in (home.PARENT, home.RELATION):
                if key in root:
                    del root[key]
        return {"FINISHED"}


class HOMEMODEL_OT_add_parking(bpy.types.Operator):
    """Add a parking position for the robot's base at the 3D cursor, facing the selected large object"""

    bl_idname = "homemodel.add_parking"
    bl_label = "Add parking position"
    bl_options = {"REGISTER", "UNDO"}
    name: StringProperty(name="Name", default="front")
    default: BoolProperty(name="Default", description="the position the robot tries first", default=False)

    @classmethod
    def poll(cls, context):
        root = _root(context)
        return root is not None and home.PARENT not in root

    def execute(self, context):
        root = _root(context)
        cursor = context.scene.cursor.location
        target = root.matrix_world.translation
        yaw = math.atan2(target.y - cursor.y, target.x - cursor.x)  # the robot faces the object
        world_from_base = Matrix.Translation((cursor.x, cursor.y, 0.0)) @ Matrix.Rotation(yaw, 4, "Z")
        existing = home.parking_of(root)
        if self.name in {p[home.PARKING] for p in existing}:
            self.report({"ERROR"}, f"{home.object_id(root)} already has a parking position {self.name!r}")
            return {"CANCELLED"}
        home.add_parking(root, self.name, world_from_base, self.default or not existing)
        return {"FINISHED"}


class HOMEMODEL_OT_import_map(bpy.types.Operator, ImportHelper):
    """Import a semantic map: a collection per room, every object at its pose with its joints' states, parking positions and grasp points"""

    bl_idname = "homemodel.import_map"
    bl_label = "Import homemodel map"
    bl_options = {"REGISTER", "UNDO"}
    filename_ext = ".xml"
    filter_glob: StringProperty(default="*.xml", options={"HIDDEN"})

    def execute(self, context):
        work = Path(tempfile.mkdtemp(prefix="homemodel-map-"))
        try:
            toolkit.run(["addon", "describe-map", self.filepath, "--out", str(work / "home"), "--force"], preference(context))
        except toolkit.ToolkitError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        home_doc = toolkit.read_json(work / "home" / "home.json")
        home.add_home(context.scene, home_doc, lambda rel: toolkit.read_json(work / "home" / rel))
        if home_doc["rooms"]:
            context.scene.homemodel_room = home_doc["rooms"][0]["id"]
        context.view_layer.update()
        return {"FINISHED"}


class HOMEMODEL_OT_export_home(bpy.types.Operator):
    """Write the semantic map (checked against its XSD) and a validated model folder for every object"""

    bl_idname = "homemodel.export_home"
    bl_label = "Export home"
    bl_options = {"REGISTER"}
    directory: StringProperty(subtype="DIR_PATH", description="the folder to write map.xml and models/ into (replaced)")

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def execute(self, context):
        rig.evaluate(context.view_layer, home.model_roots(context.scene))
        depsgraph = context.evaluated_depsgraph_get()
        work = Path(tempfile.mkdtemp(prefix="homemodel-home-"))
        (work / "models").mkdir()

        def write_model(object_id: str, doc: dict) -> str:
            (work / "models" / f"{object_id}.json").write_text(json.dumps(doc), encoding="utf-8")
            return f"models/{object_id}.json"

        try:
            doc = home.home_document(context.scene, depsgraph, write_model)
        except ValueError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        if not doc["objects"]:
            self.report({"ERROR"}, "the home has no objects: place models in rooms first")
            return {"CANCELLED"}
        (work / "home.json").write_text(json.dumps(doc), encoding="utf-8")
        try:
            result = toolkit.run(
                ["addon", "export-home", str(work / "home.json"), "--out", str(Path(self.directory)), "--force"],
                preference(context),
                accept=(0, 1),
            )
        except toolkit.ToolkitError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        HOME_REPORT[:] = result.stdout.splitlines()
        failed = [line for line in HOME_REPORT if line.startswith("FAIL")]
        if failed:
            self.report({"WARNING"}, f"exported, but {len(failed)} checks failed: {failed[0]}")
        else:
            self.report({"INFO"}, f"exported {len(doc['objects'])} objects; every model passed the gate")
        return {"FINISHED"}


CLASSES = (HOMEMODEL_OT_add_room, HOMEMODEL_OT_place, HOMEMODEL_OT_add_parking, HOMEMODEL_OT_import_map, HOMEMODEL_OT_export_home)
