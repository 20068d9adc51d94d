"""Every summary file the tests write is checked against its published JSON Schema, chosen by
its name (`homemodel.core.summary_files`): any summary.json against the model summary's
(homemodel/schemas/model_summary.schema.json), home_summary.json and export_summary.json
against theirs, with jsonschema, a client that never sees the pydantic models they were
generated from (conftest's module-scoped autouse fixture)."""

from __future__ import annotations

import functools
import json
from collections.abc import Iterable
from pathlib import Path

import jsonschema

from homemodel.core.model_summary import SUMMARY_FILE
from homemodel.core.summary_files import SUMMARY_SCHEMAS

SCHEMA_OF_FILE = {published.file_name: published for published in SUMMARY_SCHEMAS}


@functools.cache
def validator(file_name: str = SUMMARY_FILE) -> jsonschema.Draft202012Validator:
    return jsonschema.Draft202012Validator(json.loads(SCHEMA_OF_FILE[file_name].path().read_text()))


def summary_files(roots: Iterable[Path]) -> list[Path]:
    """The summary files under `roots`: every summary.json (a model folder's, whatever
    folder it is in), home_summary.json and export_summary.json."""
    return [path for root in roots for path in Path(root).rglob("*summary.json") if path.name in SCHEMA_OF_FILE]


_looked_at: set[Path] = set()  # pytest's basetemp's folders already checked in this process


def unchecked_summary_problems(base: Path) -> list[str]:
    """Schema problems of the summary files under the folders of `base` (pytest's basetemp)
    not checked before in this process: a module's own folders, and those a session fixture
    made before the module's first test (the built kitchen: a difference taken around the
    module never sees them, since pytest sets session fixtures up before module ones)."""
    folders = {path for path in base.iterdir() if not path.is_symlink()} - _looked_at  # not pytest's `...current` links
    _looked_at.update(folders)
    return [problem for path in summary_files(sorted(folders)) for problem in schema_problems(path)]


def _not_json(constant: str) -> None:
    """Python's json writes NaN and Infinity, which JSON (RFC 8259) and its other clients refuse."""
    raise ValueError(f"{constant} is not JSON (a figure that is not a number should be null)")


def schema_problems(path: Path) -> list[str]:
    """`path: field: message` of every way the file breaks the schema of its name."""
    try:
        data = json.loads(path.read_text(), parse_constant=_not_json)
    except (OSError, ValueError) as exc:  # JSONDecodeError is a ValueError
        return [f"{path}: {exc}"]
    return [
        f"{path}: {'.'.join(str(p) for p in error.absolute_path) or 'summary'}: {error.message}"
        for error in validator(path.name).iter_errors(data)
    ]
