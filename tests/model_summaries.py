"""Every model folder's summary.json the tests write is checked against the published JSON
Schema (homemodel/schemas/model_summary.schema.json) with jsonschema, a client that never
sees the pydantic model it was generated from (conftest's module-scoped autouse fixture)."""

from __future__ import annotations

import functools
import json
from collections.abc import Iterable
from pathlib import Path

import jsonschema

from homemodel.core.model_summary import SUMMARY_FILE, schema_path


@functools.cache
def validator() -> jsonschema.Draft202012Validator:
    return jsonschema.Draft202012Validator(json.loads(schema_path().read_text()))


def model_summary_files(roots: Iterable[Path]) -> list[Path]:
    """summary.json files of model folders (beside model.urdf and model.glb) under `roots`;
    a home's or a simulator export's summary.json is another document."""
    found = []
    for root in roots:
        for path in Path(root).rglob(SUMMARY_FILE):
            if (path.parent / "model.urdf").is_file() and (path.parent / "model.glb").is_file():
                found.append(path)
    return found


_looked_at: set[Path] = set()  # pytest's basetemp's folders already checked in this process


def unchecked_summary_problems(base: Path) -> list[str]:
    """Schema problems of the model summaries under the folders of `base` (pytest's basetemp)
    not checked before in this process: a module's own folders, and those a session fixture
    made before the module's first test (the built kitchen: a difference taken around the
    module never sees them, since pytest sets session fixtures up before module ones)."""
    folders = {path for path in base.iterdir() if not path.is_symlink()} - _looked_at  # not pytest's `...current` links
    _looked_at.update(folders)
    return [problem for path in model_summary_files(sorted(folders)) for problem in schema_problems(path)]


def _not_json(constant: str) -> None:
    """Python's json writes NaN and Infinity, which JSON (RFC 8259) and its other clients refuse."""
    raise ValueError(f"{constant} is not JSON (a figure that is not a number should be null)")


def schema_problems(path: Path) -> list[str]:
    """`path: field: message` of every way the file breaks the schema."""
    try:
        data = json.loads(path.read_text(), parse_constant=_not_json)
    except (OSError, ValueError) as exc:  # JSONDecodeError is a ValueError
        return [f"{path}: {exc}"]
    return [
        f"{path}: {'.'.join(str(p) for p in error.absolute_path) or 'summary'}: {error.message}"
        for error in validator().iter_errors(data)
    ]
