"""The "homemodel" tab of the 3D viewport's sidebar, its menus, and the File menu entries.

Drawing code keeps to API that Blender 3.4 and 5.0 share, so the real-window screenshots
(Debian's Blender 3.4) show what 5.0 users see.
"""

from __future__ import annotations

import json

import bpy

from . import home, jobs, rig
from .home_operators import HOME_REPORT
from .model_operators import GATE_REPORT, joint_display

VALUE_PROPS = {"number": "number", "integer": "integer", "bool": "boolean", "text": "text", "enum": "choice"}


class _SidebarPanel:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "homemodel"


class HOMEMODEL_PT_build(_SidebarPanel, bpy.types.Panel):
    bl_label = "Build from measurements"

    def draw(self, context):
        layout = self.layout
        form = context.scene.homemodel_form
        row = layout.row(align=True)
        row.prop(form, "kind", text="")
        row.operator("homemodel.form_kind", text="New", icon="FILE_NEW")
        if not form.rows:
            layout.label(text="Pick a kind and press New")
            return
        layout.label(text=f"{form.loaded_kind.replace('_', ' ')}: lengths in metres, angles in degrees")
        if form.message:
            layout.label(text=form.message, icon="ERROR")
        column = layout.column(align=True)
        for item in form.rows:
            _draw_row(column, item)
        row = layout.row(align=True)
        row.operator("homemodel.build", icon="MOD_BUILD")
        if form.target:
            row.operator("homemodel.rebuild", icon="FILE_REFRESH")


def _draw_row(layout, item) -> None:
    row = layout.row(align=True)
    if item.depth:  # one step of indent: deeper ones would squeeze the fields
        row.label(text="", icon="BLANK1")
    if item.kind in ("list", "item", "group"):
        row.label(text=item.label)
        if item.kind == "list":
            row.operator("homemodel.form_add_item", text="", icon="ADD").path = item.path
        elif item.kind == "item":
            row.operator("homemodel.form_remove_item", text="", icon="REMOVE").path = item.path
    else:
        split = row.split(factor=0.5, align=True)
        split.label(text=f"{item.label} ({item.unit})" if item.unit else item.label)
        field = split.row(align=True)
        field.prop(item, VALUE_PROPS[item.kind], text="")
        if item.help:
            field.operator("homemodel.field_help", text="", icon="INFO").help = item.help
    if item.error:
        layout.label(text=item.error, icon="ERROR")


class HOMEMODEL_MT_joint_states(bpy.types.Menu):
    bl_label = "States"

    def draw(self, context):
        joint = getattr(context, "homemodel_joint", None)
        if joint is None:
            return
        for state in json.loads(joint.get(rig.STATES, "[]")):
            op = self.layout.operator("homemodel.set_joint_state", text=state["name"])
            op.joint_object, op.position = joint.name, state["position"]


class HOMEMODEL_PT_model(_SidebarPanel, bpy.types.Panel):
    bl_label = "Model and joints"

    def draw(self, context):
        layout = self.layout
        root = rig.model_root(context.active_object)
        if root is None:
            layout.label(text="Select a model (Build, or File > Import)")
            return
        info = json.loads(root[rig.MODEL])
        layout.label(text=f"{info['name']} ({info.get('category', 'object')})", icon="OBJECT_DATA")
        row = layout.row(align=True)
        row.operator("homemodel.edit_measurements", icon="PREFERENCES")
        row.operator("homemodel.rest", icon="LOOP_BACK")
        column = layout.column(align=True)
        for joint in rig.joints_of(root):
            if joint[rig.JOINT_TYPE] == "fixed":
                continue
            split = column.split(factor=0.4, align=True)
            split.label(text=joint[rig.JOINT])
            row = split.row(align=True)
            row.prop(joint, f'["{rig.POSITION}"]', text="", slider=True)
            if joint[rig.JOINT_TYPE] == "prismatic":  # the slider shows metres
                row.label(text=joint_display(joint))
            if json.loads(joint.get(rig.STATES, "[]")):
                row.context_pointer_set("homemodel_joint", joint)
                row.menu("HOMEMODEL_MT_joint_states", text="", icon="DOWNARROW_HLT")
        active = context.active_object
        if active is not None and rig.JOINT in active:
            layout.operator("homemodel.edit_joint", icon="CON_PIVOT")
        layout.operator("homemodel.export_model", icon="EXPORT")
        for line in GATE_REPORT[1:]:
            layout.label(text=line, icon="CHECKMARK" if line.startswith(("PASS", "OK")) else "ERROR")


class HOMEMODEL_PT_home(_SidebarPanel, bpy.types.Panel):
    bl_label = "Lay out the home"

    def draw(self, context):
        layout = self.layout
        scene = context.scene
        row = layout.row(align=True)
        row.prop(scene, "homemodel_room", text="Room")
        row.operator("homemodel.add_room", text="", icon="ADD")
        root = rig.model_root(context.active_object)
        if root is not None:
            layout.prop(root, "homemodel_object_id")
            row = layout.row(align=True)
            row.operator("homemodel.place", text="Place large object").small = False
            row.operator("homemodel.place", text="Place small object").small = True
            if home.PARENT in root:
                row = layout.row(align=True)
                row.prop(root, "homemodel_relation", text="")
                row.label(text=root[home.PARENT])
            else:
                layout.operator("homemodel.add_parking", icon="EMPTY_SINGLE_ARROW")
                for parking in home.parking_of(root):
                    row = layout.row(align=True)
                    row.label(text=parking[home.PARKING], icon="EMPTY_ARROWS")
                    row.prop(parking, "homemodel_parking_default", text="default")
        layout.operator("homemodel.export_home", icon="EXPORT")
        for line in HOME_REPORT:
            layout.label(text=line, icon="ERROR" if line.startswith("FAIL") else "CHECKMARK")


class HOMEMODEL_PT_jobs(_SidebarPanel, bpy.types.Panel):
    bl_label = "Scans and photos"

    def draw(self, context):
        layout = self.layout
        for kind, (label, icon) in jobs.JOB_BUTTONS.items():
            layout.operator("homemodel.run_job", text=label, icon=icon).kind = kind
        layout.operator("homemodel.render", text="Render selection or room", icon="RENDER_STILL")
        status = context.scene.homemodel_job_status
        if status:
            layout.label(text=status)
            layout.prop(context.scene, "homemodel_job_progress", slider=True)


class HOMEMODEL_MT_main(bpy.types.Menu):
    bl_label = "homemodel"

    def draw(self, context):
        layout = self.layout
        for op in ("build", "edit_measurements", "rebuild", "rest", "edit_joint", "export_model", "add_room",
                   "add_parking", "export_home", "render", "make_model", "add_joint"):
            layout.operator(f"homemodel.{op}")
        layout.operator("homemodel.place", text="Place large object").small = False
        layout.operator("homemodel.place", text="Place small object").small = True
        for kind, (label, icon) in jobs.JOB_BUTTONS.items():
            layout.operator("homemodel.run_job", text=label, icon=icon).kind = kind


def _import_menu(self, context):
    self.layout.operator("homemodel.import_model", text="homemodel model (URDF folder, .urdf, .glb)")
    self.layout.operator("homemodel.import_map", text="homemodel map (.xml)")


def _export_menu(self, context):
    self.layout.operator("homemodel.export_model", text="homemodel model folder")
    self.layout.operator("homemodel.export_home", text="homemodel home (map.xml and models)")


def _object_menu(self, context):
    self.layout.menu("HOMEMODEL_MT_main")


CLASSES = (HOMEMODEL_MT_joint_states, HOMEMODEL_MT_main, HOMEMODEL_PT_build, HOMEMODEL_PT_model, HOMEMODEL_PT_home, HOMEMODEL_PT_jobs)
MENUS = ((bpy.types.TOPBAR_MT_file_import, _import_menu), (bpy.types.TOPBAR_MT_file_export, _export_menu), (bpy.types.VIEW3D_MT_object, _object_menu))


def register() -> None:
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    for menu, draw in MENUS:
        menu.append(draw)


def unregister() -> None:
    for menu, draw in MENUS:
        menu.remove(draw)
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
