"""The extension's settings and the measurement form's state, as Blender properties."""

from __future__ import annotations

import json

import bpy
from bpy.props import (
    BoolProperty,
    CollectionProperty,
    EnumProperty,
    FloatProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
)

from . import home, toolkit

ADDON_ID = __package__
# Blender keeps no reference to the items an enum callback returns: hold them here.
_ENUM_ITEMS: dict[str, list[tuple[str, str, str]]] = {}
_KINDS: dict[str, dict] = {}


class HomemodelPreferences(bpy.types.AddonPreferences):
    bl_idname = ADDON_ID

    command: StringProperty(
        name="homemodel command",
        description="How to run the toolkit, e.g. /home/me/homemodel/.venv/bin/homemodel (empty: homemodel on PATH)",
        default="",
    )

    def draw(self, context):
        self.layout.prop(self, "command")


def preference(context) -> str:
    addon = context.preferences.addons.get(ADDON_ID)
    return addon.preferences.command if addon is not None else ""


def spec_kinds(context) -> dict[str, dict]:
    """Every spec kind's schema and example, asked of the toolkit once per session."""
    if not _KINDS:
        _KINDS.update(json.loads(toolkit.run(["addon", "kinds"], preference(context)).stdout))
    return _KINDS


def _kind_items(self, context):
    items = _ENUM_ITEMS.setdefault("kinds", [])
    if not items:
        try:
            items.extend((k, k.replace("_", " "), f"a {k.replace('_', ' ')} from its measurements") for k in spec_kinds(context))
        except toolkit.ToolkitError as exc:
            return [("none", "(toolkit missing)", str(exc))]
    return items


def _row_choice_items(self, context):
    key = "choices:" + self.options
    if key not in _ENUM_ITEMS:
        _ENUM_ITEMS[key] = [(o, o, "") for o in json.loads(self.options or "[]")] or [("none", "none", "")]
    return _ENUM_ITEMS[key]


class FormRow(bpy.types.PropertyGroup):
    """One field of the measurement form (see `spec_form` for the row kinds)."""

    path: StringProperty()
    kind: StringProperty()
    label: StringProperty()
    unit: StringProperty()
    help: StringProperty()
    depth: IntProperty()
    given: BoolProperty()
    options: StringProperty()  # JSON list of an enum's choices
    default: StringProperty()  # JSON of the value first shown
    error: StringProperty()
    number: FloatProperty(precision=4, step=1)
    integer: IntProperty()
    boolean: BoolProperty()
    text: StringProperty()
    choice: EnumProperty(items=_row_choice_items)

    def value(self):
        return {"number": self.number, "integer": self.integer, "bool": self.boolean, "text": self.text, "enum": self.choice}.get(self.kind)

    def set_value(self, value) -> None:
        if self.kind == "number":
            self.number = float(value)
        elif self.kind == "integer":
            self.integer = int(value)
        elif self.kind == "bool":
            self.boolean = bool(value)
        elif self.kind == "text":
            self.text = value
        elif self.kind == "enum":
            self.choice = value


class MeasurementForm(bpy.types.PropertyGroup):
    kind: EnumProperty(name="Kind", items=_kind_items, description="what to build")
    loaded_kind: StringProperty()  # the kind the rows are for
    rows: CollectionProperty(type=FormRow)
    message: StringProperty()  # the last build's problem, shown at the top
    target: StringProperty()  # the object "Edit measurements" opened, for Rebuild


def _room_items(self, context):
    items = [(c[home.ROOM], c.get(home.ROOM_NAME, c.name), f"room {c[home.ROOM]}") for c in home.rooms(self)]
    _ENUM_ITEMS["rooms"] = items or [("", "(no room yet)", "Add room makes one")]
    return _ENUM_ITEMS["rooms"]


def _relation_get(self) -> int:
    return home.RELATIONS.index(self.get(home.RELATION, "on"))


def _relation_set(self, value: int) -> None:
    self[home.RELATION] = home.RELATIONS[value]


def _parking_default_get(self) -> bool:
    return bool(self.get(home.PARKING_DEFAULT, False))


def _parking_default_set(self, value: bool) -> None:
    if value and self.parent is not None:  # one default per large object
        for other in home.parking_of(self.parent):
            other[home.PARKING_DEFAULT] = False
    self[home.PARKING_DEFAULT] = bool(value)


def _object_id_get(self) -> str:
    return self.get(home.OBJECT_ID, "")


def _object_id_set(self, value: str) -> None:
    self[home.OBJECT_ID] = home.safe_id(value)


CLASSES = (HomemodelPreferences, FormRow, MeasurementForm)


def register() -> None:
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.homemodel_form = PointerProperty(type=MeasurementForm)
    bpy.types.Scene.homemodel_room = EnumProperty(name="Room", items=_room_items, description="the room objects are placed in")
    bpy.types.Scene.homemodel_job_progress = FloatProperty(name="Progress", subtype="PERCENTAGE", min=0, max=100)
    bpy.types.Scene.homemodel_job_status = StringProperty(name="Job")
    bpy.types.Object.homemodel_relation = EnumProperty(
        name="Relation",
        items=[(r, r, f"the object stands {r} its parent") for r in home.RELATIONS],
        get=_relation_get,
        set=_relation_set,
    )
    bpy.types.Object.homemodel_parking_default = BoolProperty(
        name="Default", description="the parking position the robot tries first", get=_parking_default_get, set=_parking_default_set
    )
    bpy.types.Object.homemodel_object_id = StringProperty(
        name="Object id", description="the object's id in the semantic map", get=_object_id_get, set=_object_id_set
    )


def unregister() -> None:
    for name in ("homemodel_relation", "homemodel_object_id", "homemodel_parking_default"):
        delattr(bpy.types.Object, name)
    for name in ("homemodel_form", "homemodel_room", "homemodel_job_progress", "homemodel_job_status"):
        delattr(bpy.types.Scene, name)
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
