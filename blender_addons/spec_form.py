"""A measurement form from a spec kind's JSON Schema: flat rows Blender can draw, and back.

Plain Python (no bpy), so the form's logic is tested without Blender. A row is a dict:
    path   dotted field path ("doors.0.handle.type")
    kind   number | integer | bool | enum | text | group | list | item
    value  the field's value (text rows: JSON text, or the bare string)
    label, unit, help, options (enum choices), depth (nesting, for indenting)
`group` heads a nested object, `list` a list of objects (an add button), `item` one element
of it (a remove button). Fields the schema cannot show as one widget (a colour given as a
name or an RGB triple, a list of names) are text rows holding JSON.
"""

from __future__ import annotations

import copy
import json
from typing import Any

# A field's unit is the suffix of its name (see modeller.specs.common).
UNITS = {"_m": "m", "_mm": "mm", "_deg": "°", "_kg": "kg", "_s": "s", "_n": "N"}


def _resolve(schema: dict, root: dict) -> dict:
    """The schema a `$ref` points to; the one real branch of an optional field (`X | None`)."""
    while True:
        if "$ref" in schema:
            schema = root["$defs"][schema["$ref"].rsplit("/", 1)[-1]]
            continue
        branches = [b for b in schema.get("anyOf", []) if b.get("type") != "null"]
        if len(branches) == 1 and len(schema["anyOf"]) == 2:
            schema = branches[0]
            continue
        return schema


def _unit(name: str) -> str:
    return next((unit for suffix, unit in UNITS.items() if name.endswith(suffix)), "")


def _label(name: str) -> str:
    unit_suffix = next((s for s in UNITS if name.endswith(s)), "")
    return (name[: -len(unit_suffix)] if unit_suffix else name).replace("_", " ").capitalize()


def _widget(schema: dict, root: dict) -> tuple[str, list[str]]:
    """The row kind for a leaf field, and its choices when it is an enum."""
    schema = _resolve(schema, root)
    if "enum" in schema:
        return "enum", [str(v) for v in schema["enum"]]
    kind = schema.get("type")
    if kind in ("number", "integer"):
        return kind, []
    if kind == "boolean":
        return "bool", []
    return "text", []


def _object_schema(schema: dict, root: dict) -> dict | None:
    schema = _resolve(schema, root)
    return schema if schema.get("type") == "object" and "properties" in schema else None


def _list_item_schema(schema: dict, root: dict) -> dict | None:
    schema = _resolve(schema, root)
    if schema.get("type") == "array" and "items" in schema:
        return _object_schema(schema["items"], root)
    return None


def text_of(value: Any) -> str:
    """What a text row shows: a name as it is, nothing for "not given", else JSON."""
    if value is None:
        return ""
    return value if isinstance(value, str) else json.dumps(value)


def value_of_text(text: str) -> Any:
    """A text row's value: None when empty, JSON when it parses, else the bare string ("white")."""
    if not text.strip():
        return None
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def default_of(schema: dict, root: dict) -> Any:
    """A new field's value: the schema's default, else an empty object or list, else 0."""
    if "default" in schema:
        return copy.deepcopy(schema["default"])
    schema = _resolve(schema, root)
    if "default" in schema:
        return copy.deepcopy(schema["default"])
    obj = _object_schema(schema, root)
    if obj is not None:
        return {name: default_of(field, root) for name, field in obj["properties"].items() if name in obj.get("required", [])}
    if schema.get("type") == "array":
        return []
    if "enum" in schema:
        return schema["enum"][0]
    return {"number": 0.0, "integer": 0, "boolean": False, "string": ""}.get(schema.get("type"), None)


def rows_for(schema: dict, values: dict, *, root: dict | None = None, prefix: str = "", depth: int = 0) -> list[dict]:
    """The form's rows for an object schema filled with `values` (a spec as a dict)."""
    root = root or schema
    rows: list[dict] = []
    for name, field in _resolve(schema, root)["properties"].items():
        if name == "kind" and not prefix:
            continue  # the spec's kind is the form's, chosen above it; a nested `kind` is a field
        path = f"{prefix}{name}"
        value = values[name] if name in values else default_of(field, root)
        # A field the spec leaves out stays out unless edited: some checks ask what was given.
        base = {"path": path, "given": name in values, "label": _label(name), "unit": _unit(name), "depth": depth,
                "help": field.get("description") or _resolve(field, root).get("description", "").split("\n")[0],
                "options": [], "value": None}
        item_schema = _list_item_schema(field, root)
        nested = _object_schema(field, root)
        if item_schema is not None and isinstance(value, list | None):
            # An optional list left empty goes back as null (the spec's "use the default").
            rows.append({**base, "kind": "list", "value": None if value is None or field.get("default", []) is None else []})
            value = value or []
            for i, item in enumerate(value):
                rows.append({**base, "path": f"{path}.{i}", "label": f"{base['label']} {i + 1}", "kind": "item", "depth": depth + 1, "given": True})
                rows += rows_for(item_schema, item, root=root, prefix=f"{path}.{i}.", depth=depth + 2)
        elif nested is not None and isinstance(value, dict):
            rows.append({**base, "kind": "group"})
            rows += rows_for(nested, value, root=root, prefix=f"{path}.", depth=depth + 1)
        else:
            kind, options = _widget(field, root)
            if value is None or (kind == "enum" and value not in options):
                kind = "text"  # an optional field left at null: typed as JSON (a number, a name)
            shown = text_of(value) if kind == "text" else value
            rows.append({**base, "kind": kind, "options": options, "value": shown, "default": shown})
    return rows


def _set(target: dict, parts: list[str], value: Any) -> None:
    for i, part in enumerate(parts[:-1]):
        following = parts[i + 1]
        container = target[int(part)] if isinstance(target, list) else target.setdefault(part, [] if following.isdigit() else {})
        if isinstance(container, list) and following.isdigit():
            while len(container) <= int(following):
                container.append({})
        target = container
    last = parts[-1]
    if isinstance(target, list):
        while len(target) <= int(last):
            target.append({})
        target[int(last)] = value
    else:
        target[last] = value


def spec_from_rows(kind: str, rows: list[dict]) -> dict:
    """The spec (a dict, `kind` first) the rows hold."""
    spec: dict = {"kind": kind}
    null_when_empty = []
    for row in rows:
        parts = row["path"].split(".")
        if not row["given"] and (row["kind"] in ("list", "group") or row["value"] == row.get("default")):
            continue
        if row["kind"] == "list":
            _set(spec, parts, [])
            if row["value"] is None:
                null_when_empty.append(parts)
        elif row["kind"] in ("item", "group"):
            _set(spec, parts, {})
        else:
            _set(spec, parts, value_of_text(row["value"]) if row["kind"] == "text" else row["value"])
    for parts in null_when_empty:
        if _get(spec, parts) == []:
            _set(spec, parts, None)
    return spec


def _field_schema(schema: dict, path: list[str]) -> dict:
    """The schema of the field at `path` (list indices skipped)."""
    current = schema
    for part in path:
        if part.isdigit():
            current = _resolve(current, schema)["items"]
        else:
            current = _resolve(current, schema)["properties"][part]
    return current


def with_item_added(schema: dict, kind: str, rows: list[dict], list_path: str) -> list[dict]:
    """The rows with a new element, filled from the schema's defaults, appended to the list at `list_path`."""
    spec = spec_from_rows(kind, rows)
    parts = list_path.split(".")
    item_schema = _resolve(_field_schema(schema, parts), schema)["items"]
    try:
        items = _get(spec, parts)
    except KeyError:  # a list the spec left out
        items = None
    if items is None:
        items = []
        _set(spec, parts, items)
    new_item = copy.deepcopy(items[-1]) if items else default_of(item_schema, schema)
    items.append(new_item)
    return rows_for(schema, spec)


def with_item_removed(schema: dict, kind: str, rows: list[dict], item_path: str) -> list[dict]:
    spec = spec_from_rows(kind, rows)
    parts = item_path.split(".")
    del _get(spec, parts[:-1])[int(parts[-1])]
    return rows_for(schema, spec)


def _get(spec: dict, parts: list[str]) -> Any:
    for part in parts:
        spec = spec[int(part)] if isinstance(spec, list) else spec[part]
    return spec
