"""What the database answers besides builds: remove, export, and `db:ID` model references."""

from __future__ import annotations

import shutil
from pathlib import Path

from homemodel.app.database.build import build_lock
from homemodel.app.database.index import MODELS_DIR, EntryRow, ModelIndex
from homemodel.core.atomic import atomic_dir
from homemodel.core.errors import InputError

DB_REF_PREFIX = "db:"


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


def resolve_model_ref(ref: str | Path, db_dir: Path | None) -> Path:
    """`db:ID` to the entry's model folder (a valid one: the map takes validated models only);
    anything else is a path and is returned as it is."""
    text = str(ref)
    if not text.startswith(DB_REF_PREFIX):
        return Path(ref)
    if db_dir is None:
        raise InputError(f"{text}: a db: reference needs --db DIR")
    entry_id = text[len(DB_REF_PREFIX):]
    with ModelIndex(db_dir) as index:
        row = index.require(entry_id)
    if row.status != "valid":
        raise InputError(f"{text}: the entry did not pass the validation gate ({row.status}); fix it before adding it to a map")
    return model_folder(db_dir, entry_id)
