"""Load a YAML file into a pydantic model, with one-line errors naming the file and the field."""

from __future__ import annotations

from pathlib import Path
from typing import TypeVar

import pydantic
import yaml

from homemodel.errors import SpecError

MAX_SPEC_BYTES = 4 * 1024 * 1024
SpecT = TypeVar("SpecT", bound=pydantic.BaseModel)


def read_yaml_mapping(path: Path) -> dict:
    """The top-level mapping of a YAML file (safe loader, size-bounded)."""
    path = Path(path)
    if not path.is_file():
        raise SpecError(f"{path}: no such file")
    if path.stat().st_size > MAX_SPEC_BYTES:
        raise SpecError(f"{path}: larger than {MAX_SPEC_BYTES} bytes, not a measurement spec")
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise SpecError(f"{path}: not valid YAML: {' '.join(str(exc).split())}") from None
    if not isinstance(data, dict):
        raise SpecError(f"{path}: expected a mapping of fields at the top level")
    return data


def format_validation_error(path: Path, error: pydantic.ValidationError) -> str:
    """`file: dotted.field: message` for the first problem, with a count of the others."""
    first = error.errors()[0]
    field = ".".join(str(part) for part in first["loc"]) or "(top level)"
    message = first["msg"].removeprefix("Value error, ")
    more = len(error.errors()) - 1
    suffix = f" (and {more} more problem{'s' if more > 1 else ''})" if more else ""
    return f"{path}: {field}: {message}{suffix}"


def validate_mapping(path: Path, data: dict, spec_type: type[SpecT]) -> SpecT:
    try:
        return spec_type.model_validate(data)
    except pydantic.ValidationError as exc:
        raise SpecError(format_validation_error(path, exc)) from None


def load_yaml_spec(path: Path, spec_type: type[SpecT]) -> SpecT:
    return validate_mapping(Path(path), read_yaml_mapping(Path(path)), spec_type)
