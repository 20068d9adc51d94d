"""What the database answers besides builds: find, remove, export, and `db:ID` model
references."""

from __future__ import annotations

import math
import operator
import re
import shutil
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

from homemodel.app.database.build import build_lock
from homemodel.app.database.index import MODELS_DIR, EntryRow, ModelIndex
from homemodel.core.atomic import atomic_dir
from homemodel.core.errors import InputError

DB_REF_PREFIX = "db:"
COMPARISONS: dict[str, Callable[[object, object], bool]] = {
    "<=": operator.le, ">=": operator.ge, "!=": operator.ne, "=": operator.eq, "<": operator.lt, ">": operator.gt,
}  # fmt: skip
_CONDITION = re.compile(r"\s*([^<>=!\s]+)\s*(<=|>=|!=|=|<|>)\s*(.*?)\s*")


def _number(text: object) -> float | None:
    try:
        value = float(str(text))
    except ValueError:
        return None
    return value if math.isfinite(value) else None


@dataclass(frozen=True)
class PropertyCondition:
    """`name=value`, `name!=value` or a range (`name>=0.7`, `<`, `<=`, `>`) over an entry's
    properties: names and text compare case-insensitively, numbers as numbers (0.80 = 0.8)."""

    name: str
    op: str
    value: str

    @classmethod
    def parse(cls, text: str) -> PropertyCondition:
        found = _CONDITION.fullmatch(text)
        if not found or not found.group(3):
            raise InputError(f"--property {text!r}: expected name=value, or name followed by !=, <, <=, > or >= and a value")
        condition = cls(*found.groups())
        if condition.op in ("<", "<=", ">", ">=") and _number(condition.value) is None:
            raise InputError(f"--property {text!r}: a range needs a number, not {condition.value!r}")
        return condition

    def holds(self, properties: dict) -> bool:
        """True when the entry has the property and it compares as asked."""
        values = [v for k, v in properties.items() if str(k).casefold() == self.name.casefold()]
        if not values:
            return False
        have, want = _number(values[0]), _number(self.value)
        if have is not None and want is not None:
            return COMPARISONS[self.op](have, want)
        if self.op in ("=", "!="):
            return COMPARISONS[self.op](str(values[0]).casefold(), self.value.casefold())
        return False  # a range over a value that is not a number


def find_entries(db_dir: Path, *, category: str | None = None, conditions: Iterable[PropertyCondition] = ()) -> list[EntryRow]:
    """The entries of `category` (any case) whose properties meet every condition."""
    conditions = list(conditions)
    with ModelIndex(db_dir) as index:
        rows = index.rows()
    return [
        row for row in rows
        if (category is None or row.category.casefold() == category.casefold()) and all(c.holds(row.properties) for c in conditions)
    ]  # fmt: skip


def remove_entry(db_dir: Path, entry_id: str) -> EntryRow:
    """Remove an entry: its row first, then its folder (so no row ever points to a partly
    deleted folder). Refused while a build runs on the database."""
    db_dir = Path(db_dir)
    with ModelIndex(db_dir) as index, build_lock(db_dir):
        row = index.require(entry_id)
        index.delete(entry_id)
    folder = db_dir / MODELS_DIR / entry_id
    if folder.exists():
        shutil.rmtree(folder)
    return row


def model_folder(db_dir: Path, entry_id: str) -> Path:
    """The stored model folder of an entry that was built (valid, or built but invalid)."""
    with ModelIndex(db_dir) as index:
        row = index.require(entry_id)
    if row.path is None:
        raise InputError(f"{db_dir}: entry {entry_id!r} was not built ({row.status}: {row.error})")
    return Path(db_dir) / row.path


def export_entry(db_dir: Path, entry_id: str, out_dir: Path, *, force: bool = False) -> Path:
    """Copy an entry's model folder to `out_dir`, atomically."""
    source = model_folder(db_dir, entry_id)
    with atomic_dir(Path(out_dir), force=force, inputs=[source]) as tmp:
        shutil.copytree(source, tmp, dirs_exist_ok=True)
    return Path(out_dir)


@dataclass(frozen=True)
class ModelRef:
    """A model a map may take: its folder and, for a `db:ID`, what the manifest says of it."""

    folder: Path
    category: str | None = None
    properties: dict[str, str] = field(default_factory=dict)


def resolve_model_ref(ref: str | Path, db_dir: Path | None) -> ModelRef:
    """`db:ID` to the entry's model folder (a valid one: the map takes validated models only),
    its category and properties; anything else is a path and is returned as it is."""
    text = str(ref)
    if not text.startswith(DB_REF_PREFIX):
        return ModelRef(Path(ref))
    if db_dir is None:
        raise InputError(f"{text}: a db: reference needs --db DIR")
    entry_id = text[len(DB_REF_PREFIX):]
    with ModelIndex(db_dir) as index:
        row = index.require(entry_id)
    if row.status != "valid":
        raise InputError(f"{text}: the entry did not pass the validation gate ({row.status}); fix it before adding it to a map")
    properties = {str(k): str(v) for k, v in row.properties.items()}
    return ModelRef(model_folder(db_dir, entry_id), row.category or None, properties)
