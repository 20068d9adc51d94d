"""What the Blender extension's measurement form needs from the specs: each kind's JSON
Schema with a filled-in example, and every problem of a filled form, field by field."""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path
from typing import Any

import pydantic

from homemodel.core.yaml_specs import read_yaml_mapping, validation_problems

# examples/catalogue, shipped as package data (`catalogue` is a link to it in a checkout).
CATALOGUE = files("homemodel.app.blender") / "catalogue"


def spec_kinds() -> dict[str, dict[str, Any]]:
    """{kind: {"schema": JSON Schema, "example": a valid spec of that kind}} for every kind."""
    from modeller.kinds import SPEC_TYPES

    kinds = {}
    for kind, spec_type in SPEC_TYPES.items():
        example_path = CATALOGUE / f"{kind}.yaml"
        # A kind newer than the catalogue starts from its defaults.
        example = read_yaml_mapping(Path(str(example_path))) if example_path.is_file() else {"kind": kind}
        kinds[kind] = {"schema": spec_type.model_json_schema(), "example": example}
    return kinds


def spec_problems(path: Path) -> list[dict[str, str]]:
    """Every problem of the spec at `path` as {"field": "doors.0.width_m", "message": ...};
    empty when the spec is valid."""
    from modeller.kinds import SPEC_TYPES

    data = read_yaml_mapping(Path(path))
    spec_type = SPEC_TYPES.get(data.get("kind")) if isinstance(data.get("kind"), str) else None
    if spec_type is None:
        return [{"field": "kind", "message": f"expected one of {', '.join(SPEC_TYPES)}"}]
    try:
        spec_type.model_validate(data)
    except pydantic.ValidationError as exc:
        return [{"field": field, "message": message} for field, message in validation_problems(exc)]
    return []
