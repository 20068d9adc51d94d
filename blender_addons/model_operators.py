"""Operators on one model: its joints, making one by hand, import and export."""

from __future__ import annotations

import json
import math
import tempfile
from pathlib import Path

import bpy
from bpy.props import EnumProperty, FloatProperty, FloatVectorProperty, StringProperty
from bpy_extras.io_utils import ImportHelper
from mathutils import Matrix, Vector

from . import rig, toolkit
from .properties import preference

# What Export model last reported, one line per check of the gate, for the panel.
GATE_REPORT: list[str] = []


def report_toolkit_error(operator, exc: Exception) -> set[str]:
    operator.report({"ERROR"}, str(exc))
    return {"CANCELLED"}


def selected_model(context) -> bpy.types.Object | None:
    return rig.model_root(context.active_object)


class HOMEMODEL_OT_rest(bpy.types.Operator):
    """Put every joint of the selected model back to zero (or its nearest limit)"""

    bl_idname = "homemodel.rest"
    bl_label = "Rest"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return selected_model(context) is not None

    def execute(self, context):
        for joint in rig.joints_of(selected_model(context)):
            rig.set_position(joint, 0.0)
        context.view_layer.update()
        return {"FINISHED"}


class HOMEMODEL_OT_set_joint_state(bpy.types.Operator):
    """Move the joint to this named state"""

    bl_idname = "homemodel.set_joint_state"
    bl_label = "Set state"
    bl_options = {"REGISTER", "UNDO", "INTERNAL"}
    joint_object: StringProperty()
    position: FloatProperty()

    def execute(self, context):
        rig.set_position(bpy.data.objects[self.joint_object], self.position)
        context.view_layer.update()
        return {"FINISHED"}


class HOMEMODEL_OT_edit_joint(bpy.types.Operator):
    """Change the active link's joint: its type, axis and limits"""

    bl_idname = "homemodel.edit_joint"
    bl_label = "Edit joint"
    bl_options = {"REGISTER", "UNDO"}
    joint_type: EnumProperty(name="Type", items=[(t, t, "") for t in rig.JOINT_TYPES])
    axis: FloatVectorProperty(name="Axis", size=3, default=(0.0, 0.0, 1.0), description="in the joint's frame")
    lower: FloatProperty(name="Lower", description="rad for a revolute joint, m for a prismatic one")
    upper: FloatProperty(name="Upper", description="rad for a revolute joint, m for a prismatic one")

    @classmethod
    def poll(cls, context):
        return context.active_object is not None and rig.JOINT in context.active_object

    def invoke(self, context, event):
        joint = context.active_object
        self.joint_type, self.axis = joint[rig.JOINT_TYPE], tuple(joint[rig.AXIS])
        self.lower, self.upper = rig.joint_range(joint) if joint[rig.JOINT_TYPE] != "continuous" else (0.0, 0.0)
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        if Vector(self.axis).length < 1e-9:
            self.report({"ERROR"}, "the axis must not be zero")
            return {"CANCELLED"}
        if self.joint_type in rig.LIMITED_JOINT_TYPES and self.lower > self.upper:
            self.report({"ERROR"}, f"lower limit {self.lower:g} is above upper limit {self.upper:g}")
            return {"CANCELLED"}
        joint = context.active_object
        joint[rig.JOINT_TYPE] = self.joint_type
        joint[rig.AXIS] = list(Vector(self.axis).normalized())
        if self.joint_type in rig.LIMITED_JOINT_TYPES:
            joint[rig.LOWER], joint[rig.UPPER] = self.lower, self.upper
        rig.rig_joint(joint)
        context.view_layer.update()
        return {"FINISHED"}


class HOMEMODEL_OT_make_model(bpy.types.Operator):
    """Make the selected meshes one model: its root link stands at the 3D cursor"""

    bl_idname = "homemodel.make_model"
    bl_label = "Make model from selection"
    bl_options = {"REGISTER", "UNDO"}
    name: StringProperty(name="Name", default="object")
    category: StringProperty(name="Category", default="object", description="the object's type in the map, e.g. cupboard")

    @classmethod
    def poll(cls, context):
        return any(o.type == "MESH" and rig.model_root(o) is None for o in context.selected_objects)

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        meshes = [o for o in context.selected_objects if o.type == "MESH" and rig.model_root(o) is None]
        root = rig.make_model(self.name, self.category, meshes, Matrix.Translation(context.scene.cursor.location), context.collection)
        rig.select_only(context, root)
        return {"FINISHED"}


class HOMEMODEL_OT_add_joint(bpy.types.Operator):
    """Make the selected meshes of a model a new part that moves: hinged or sliding at the 3D cursor"""

    bl_idname = "homemodel.add_joint"
    bl_label = "Add joint"
    bl_options = {"REGISTER", "UNDO"}
    name: StringProperty(name="Name", default="door")
    joint_type: EnumProperty(name="Type", items=[(t, t, "") for t in rig.JOINT_TYPES])
    axis: FloatVectorProperty(name="Axis", size=3, default=(0.0, 0.0, 1.0), description="in the model's frame")
    lower: FloatProperty(name="Lower", default=0.0, description="rad for a revolute joint, m for a prismatic one")
    upper: FloatProperty(name="Upper", default=math.pi / 2, description="rad for a revolute joint, m for a prismatic one")

    @classmethod
    def poll(cls, context):
        return any(rig.model_root(o) is not None and o.type == "MESH" for o in context.selected_objects)

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        meshes = [o for o in context.selected_objects if o.type == "MESH" and rig.model_root(o) is not None]
        if Vector(self.axis).length < 1e-9 or (self.joint_type in rig.LIMITED_JOINT_TYPES and self.lower > self.upper):
            self.report({"ERROR"}, "the axis must not be zero and the lower limit not above the upper")
            return {"CANCELLED"}
        link = rig.add_joint(meshes, self.name, self.joint_type, Vector(self.axis), (self.lower, self.upper), context.scene.cursor.location)
        context.view_layer.update()
        rig.select_only(context, link)
        return {"FINISHED"}


def _import_glb(context, path: Path) -> bpy.types.Object | None:
    """A glb exported from Blender with this extension's properties (Include › Custom
    Properties), rigged again; None (and nothing left in the scene) for any other glb."""
    before = set(bpy.data.objects)
    bpy.ops.import_scene.gltf(filepath=str(path))
    new = [obj for obj in bpy.data.objects if obj not in before]
    roots = rig.rig_imported(new)
    if len(roots) == 1:
        return roots[0]
    for obj in new:
        bpy.data.objects.remove(obj, do_unlink=True)
    return None


class HOMEMODEL_OT_import_model(bpy.types.Operator, ImportHelper):
    """Import a homemodel model folder, any URDF (PartNet-Mobility's mobility.urdf too), or a glb exported from Blender with its properties, joints rigged"""

    bl_idname = "homemodel.import_model"
    bl_label = "Import homemodel model"
    bl_options = {"REGISTER", "UNDO"}
    filename_ext = ".urdf"
    filter_glob: StringProperty(default="*.urdf;*.glb", options={"HIDDEN"})

    def execute(self, context):
        path = Path(self.filepath)
        root = _import_glb(context, path) if path.suffix.lower() == ".glb" and path.is_file() else None
        if root is None:
            # A folder, a URDF, or a glb inside a model folder: the toolkit reads the URDF.
            source = path.parent if path.is_file() and path.suffix.lower() != ".urdf" else path
            work = Path(tempfile.mkdtemp(prefix="homemodel-import-"))
            try:
                toolkit.run(["addon", "describe", str(source), "--out", str(work / "model.json")], preference(context))
            except toolkit.ToolkitError as exc:
                return report_toolkit_error(self, exc)
            root = rig.add_model(toolkit.read_json(work / "model.json"), context.collection)
            root.matrix_world = Matrix.Translation(context.scene.cursor.location)
        rig.select_only(context, root)
        return {"FINISHED"}


class HOMEMODEL_OT_export_model(bpy.types.Operator):
    """Write the selected model as a model folder (URDF, glb, meshes) and run the validation gate on it"""

    bl_idname = "homemodel.export_model"
    bl_label = "Export model"
    bl_options = {"REGISTER"}
    directory: StringProperty(subtype="DIR_PATH", description="the model folder to write (replaced if it exists)")

    @classmethod
    def poll(cls, context):
        return selected_model(context) is not None

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def execute(self, context):
        root = selected_model(context)
        rig.evaluate(context.view_layer, [root])
        doc = rig.model_document(root, context.evaluated_depsgraph_get())
        work = Path(tempfile.mkdtemp(prefix="homemodel-export-"))
        (work / "model.json").write_text(json.dumps(doc), encoding="utf-8")
        try:
            result = toolkit.run(
                ["addon", "export", str(work / "model.json"), "--out", str(Path(self.directory)), "--force"],
                preference(context),
                accept=(0, 1),
            )
        except toolkit.ToolkitError as exc:
            return report_toolkit_error(self, exc)
        GATE_REPORT[:] = result.stdout.splitlines()
        failed = [line for line in GATE_REPORT if line.startswith("FAIL ")]
        _select_failures(root, failed)
        if failed:
            self.report({"WARNING"}, f"exported, but the gate failed {len(failed)} checks: {failed[0]}")
        else:
            self.report({"INFO"}, GATE_REPORT[-1] if GATE_REPORT else "exported")
        return {"FINISHED"}


def _select_failures(root: bpy.types.Object, failed: list[str]) -> None:
    """Select the links the failed checks name (the two links that collide), and only them."""
    text = " ".join(failed)
    for link in rig.links_of(root):
        named = f"'{link[rig.LINK]}'" in text
        for obj in [link, *rig.owned(link)]:
            obj.select_set(named)


def joint_display(joint: bpy.types.Object) -> str:
    """The joint's position in the unit an installer reads: degrees or millimetres."""
    q = float(joint[rig.POSITION])
    return f"{q * 1000:.0f} mm" if joint[rig.JOINT_TYPE] == "prismatic" else f"{math.degrees(q):.0f}°"


CLASSES = (
    HOMEMODEL_OT_rest,
    HOMEMODEL_OT_set_joint_state,
    HOMEMODEL_OT_edit_joint,
    HOMEMODEL_OT_make_model,
    HOMEMODEL_OT_add_joint,
    HOMEMODEL_OT_import_model,
    HOMEMODEL_OT_export_model,
)
