"""The measurement form: a kind's fields from its schema, Build, Edit measurements, Rebuild."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import bpy
from bpy.props import StringProperty
from mathutils import Matrix

from . import home, rig, spec_form, toolkit
from .model_operators import GATE_REPORT, report_toolkit_error, selected_model
from .properties import preference, spec_kinds


def _form(context):
    return context.scene.homemodel_form


def fill_form(form, kind: str, rows: list[dict]) -> None:
    form.rows.clear()
    form.loaded_kind = kind
    for row in rows:
        item = form.rows.add()
        for key in ("path", "kind", "label", "unit", "help", "depth", "given"):
            setattr(item, key, row[key])
        item.options = json.dumps(row["options"])
        item.default = json.dumps(row.get("default"))
        if row["kind"] not in ("list", "group", "item"):
            item.set_value(row["value"])
        elif row["kind"] == "list":
            item.text = json.dumps(row["value"])


def form_rows(form) -> list[dict]:
    """The form as `spec_form` rows (a field left at its default and not in the spec stays out)."""
    rows = []
    for item in form.rows:
        value = item.value() if item.kind not in ("list", "group", "item") else (json.loads(item.text or "null") if item.kind == "list" else None)
        if item.kind == "number":
            value = float(f"{value:.7g}")  # Blender keeps float32: 0.397 comes back as 0.39700001
        rows.append({"path": item.path, "kind": item.kind, "given": item.given, "value": value, "default": json.loads(item.default or "null")})
    return rows


def form_spec(form) -> dict:
    return spec_form.spec_from_rows(form.loaded_kind, form_rows(form))


class HOMEMODEL_OT_form_kind(bpy.types.Operator):
    """Start the measurement form of the chosen kind, filled with an example"""

    bl_idname = "homemodel.form_kind"
    bl_label = "New form"
    bl_options = {"REGISTER", "INTERNAL"}

    def execute(self, context):
        form = _form(context)
        try:
            kind = spec_kinds(context)[form.kind]
        except (toolkit.ToolkitError, KeyError) as exc:
            return report_toolkit_error(self, exc)
        fill_form(form, form.kind, spec_form.rows_for(kind["schema"], kind["example"]))
        form.message = ""
        form.target = ""
        return {"FINISHED"}


class HOMEMODEL_OT_form_add_item(bpy.types.Operator):
    """Add an element to this list (a copy of the last one)"""

    bl_idname = "homemodel.form_add_item"
    bl_label = "Add"
    bl_options = {"REGISTER", "INTERNAL"}
    path: StringProperty()

    def execute(self, context):
        form = _form(context)
        schema = spec_kinds(context)[form.loaded_kind]["schema"]
        fill_form(form, form.loaded_kind, spec_form.with_item_added(schema, form.loaded_kind, form_rows(form), self.path))
        return {"FINISHED"}


class HOMEMODEL_OT_form_remove_item(bpy.types.Operator):
    """Remove this element from its list"""

    bl_idname = "homemodel.form_remove_item"
    bl_label = "Remove"
    bl_options = {"REGISTER", "INTERNAL"}
    path: StringProperty()

    def execute(self, context):
        form = _form(context)
        schema = spec_kinds(context)[form.loaded_kind]["schema"]
        fill_form(form, form.loaded_kind, spec_form.with_item_removed(schema, form.loaded_kind, form_rows(form), self.path))
        return {"FINISHED"}


class HOMEMODEL_OT_field_help(bpy.types.Operator):
    """What this measurement is"""

    bl_idname = "homemodel.field_help"
    bl_label = "Help"
    bl_options = {"INTERNAL"}
    help: StringProperty()

    @classmethod
    def description(cls, context, properties):
        return properties.help or "no description"

    def execute(self, context):
        self.report({"INFO"}, self.help or "no description")
        return {"FINISHED"}


def _build(operator, context) -> bpy.types.Object | None:
    """Check the form, build its spec with the toolkit and put the model in the scene;
    None (with the problems marked on the form) when the spec is impossible."""
    form = _form(context)
    for item in form.rows:
        item.error = ""
    spec = form_spec(form)
    work = Path(tempfile.mkdtemp(prefix="homemodel-build-"))
    spec_path = work / f"{spec.get('name') or form.loaded_kind}.json"
    spec_path.write_text(json.dumps(spec), encoding="utf-8")
    # Built straight away: a spec the toolkit refuses (exit 2) is then checked field by field
    # for the form, so a good spec costs one start of the toolkit, not two.
    built = toolkit.run(["addon", "build", str(spec_path), "--out", str(work / "model"), "--force"], preference(context), accept=(0, 1, 2))
    if built.returncode == 2:
        problems = json.loads(toolkit.run(["addon", "check-spec", str(spec_path)], preference(context), accept=(0, 1)).stdout)
        if not problems:  # refused for another reason than a field
            raise toolkit.ToolkitError(built.error_line())
        by_path = {item.path: item for item in form.rows}
        for problem in problems:
            # The deepest row the field path names: a list's problem lands on its header.
            parts = problem["field"].split(".")
            while parts and ".".join(parts) not in by_path:
                parts.pop()
            target = by_path.get(".".join(parts))
            if target is not None:
                target.error = problem["message"]
        form.message = f"{problems[0]['field']}: {problems[0]['message']}"
        operator.report({"ERROR"}, form.message)
        return None
    GATE_REPORT[:] = built.stdout.splitlines()
    failed = [line for line in GATE_REPORT if line.startswith("FAIL ")]
    if failed:  # built, but the gate refused it: the installer sees why in the panel
        operator.report({"WARNING"}, f"built, but the gate failed {len(failed)} checks: {failed[0]}")
    doc = toolkit.read_json(work / "model" / "blender.json")
    root = rig.add_model(doc, context.collection)
    form.message = ""
    return root


class HOMEMODEL_OT_build(bpy.types.Operator):
    """Build the model from the form's measurements and put it at the 3D cursor"""

    bl_idname = "homemodel.build"
    bl_label = "Build"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        try:
            root = _build(self, context)
        except toolkit.ToolkitError as exc:
            return report_toolkit_error(self, exc)
        if root is None:
            return {"CANCELLED"}
        root.matrix_world = Matrix.Translation(context.scene.cursor.location)
        rig.select_only(context, root)
        return {"FINISHED"}


class HOMEMODEL_OT_edit_measurements(bpy.types.Operator):
    """Open the selected model's measurements in the form, to change them and Rebuild"""

    bl_idname = "homemodel.edit_measurements"
    bl_label = "Edit measurements"
    bl_options = {"REGISTER"}

    @classmethod
    def poll(cls, context):
        root = selected_model(context)
        return root is not None and rig.SPEC in root

    def execute(self, context):
        root = selected_model(context)
        spec = json.loads(root[rig.SPEC])
        try:
            schema = spec_kinds(context)[spec["kind"]]["schema"]
        except (toolkit.ToolkitError, KeyError) as exc:
            return report_toolkit_error(self, exc)
        form = _form(context)
        fill_form(form, spec["kind"], spec_form.rows_for(schema, spec))
        form.target = root.name
        form.message = ""
        return {"FINISHED"}


class HOMEMODEL_OT_rebuild(bpy.types.Operator):
    """Build the form's measurements again and replace the model in place, keeping its pose and place in the home"""

    bl_idname = "homemodel.rebuild"
    bl_label = "Rebuild"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return bpy.data.objects.get(_form(context).target) is not None

    def execute(self, context):
        old = bpy.data.objects[_form(context).target]
        try:
            new = _build(self, context)
        except toolkit.ToolkitError as exc:
            return report_toolkit_error(self, exc)
        if new is None:
            return {"CANCELLED"}
        new.matrix_world = old.matrix_world.copy()
        for key in (home.OBJECT_ID, home.PARENT, home.RELATION):
            if key in old:
                new[key] = old[key]
        collection = home.room_of(old)
        if collection is not None:
            home.move_to_collection(new, collection)
        for parking in home.parking_of(old):
            world = parking.matrix_world.copy()
            parking.parent = new
            parking.matrix_parent_inverse = new.matrix_world.inverted()
            parking.matrix_world = world
        rig.remove_model(old)
        context.view_layer.update()
        _form(context).target = new.name
        rig.select_only(context, new)
        return {"FINISHED"}


CLASSES = (
    HOMEMODEL_OT_form_kind,
    HOMEMODEL_OT_form_add_item,
    HOMEMODEL_OT_form_remove_item,
    HOMEMODEL_OT_field_help,
    HOMEMODEL_OT_build,
    HOMEMODEL_OT_edit_measurements,
    HOMEMODEL_OT_rebuild,
)
