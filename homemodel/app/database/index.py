"""The database's index, `DIR/index.sqlite`: one row per entry (id, category, source, content
key, status, the gate's checks, counts, times, error, paths) and the file-hash cache.

Only the process that runs a build writes it (workers return their results to it), in
transactions of the entries finished in the last half second, so a kill leaves every row
whole and loses at most those rows (their folders, already in place, are built again). A row
is written after its model folder is in place and removed (committed) before the folder is,
so no row ever points to a missing or half-written folder.
"""

from __future__ import annotations

import json
import sqlite3
from collections.abc import Iterator
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

from homemodel.core.errors import InputError

INDEX_FILE = "index.sqlite"
MODELS_DIR = "models"
STATUSES = ("valid", "invalid", "failed")  # passed the gate; built but failed it; not built

SCHEMA = """
CREATE TABLE IF NOT EXISTS models (
    id TEXT PRIMARY KEY,
    category TEXT NOT NULL,
    source TEXT NOT NULL,
    key TEXT NOT NULL,
    status TEXT NOT NULL,
    checks TEXT NOT NULL,        -- JSON list of {name, passed, detail}
    links INTEGER, joints INTEGER, grasp_points INTEGER, triangles INTEGER,
    build_s REAL NOT NULL,
    times_s TEXT NOT NULL,       -- JSON {stage: seconds}
    built_at TEXT NOT NULL,      -- UTC, ISO 8601
    error TEXT,
    path TEXT,                   -- the model folder, relative to the database; NULL when not built
    thumbnail TEXT,              -- relative to the database
    inputs TEXT NOT NULL,        -- JSON {role: absolute path}
    properties TEXT NOT NULL,    -- JSON {name: value}
    repairs TEXT NOT NULL,       -- JSON list of what --repair did
    worker TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS models_category ON models (category);
CREATE TABLE IF NOT EXISTS file_hashes (
    path TEXT PRIMARY KEY, size INTEGER NOT NULL, mtime_ns INTEGER NOT NULL, sha256 TEXT NOT NULL
);
"""
JSON_COLUMNS = ("checks", "times_s", "inputs", "properties", "repairs")
JSON_EMPTY = {"checks": [], "times_s": {}, "inputs": {}, "properties": {}, "repairs": []}


@dataclass(kw_only=True)
class EntryRow:
    """One entry of the database, as built (or not) by a worker and kept in the index."""

    id: str
    category: str
    source: str
    key: str
    status: str
    checks: list[dict] = field(default_factory=list)
    links: int | None = None
    joints: int | None = None
    grasp_points: int | None = None
    triangles: int | None = None
    build_s: float = 0.0
    times_s: dict[str, float] = field(default_factory=dict)
    built_at: str = ""
    error: str | None = None
    path: str | None = None
    thumbnail: str | None = None
    inputs: dict[str, str] = field(default_factory=dict)
    properties: dict[str, str] = field(default_factory=dict)
    repairs: list[str] = field(default_factory=list)
    worker: str = ""

    @property
    def failed_checks(self) -> list[str]:
        # Imported here: its pydantic models (0.2 s of CPU) would delay a build's first step,
        # starting its worker processes.
        from homemodel.core.model_summary import failed_check_lines

        return failed_check_lines((c["name"], c["passed"], c["detail"]) for c in self.checks)


class ModelIndex:
    """The open index of the database in `db_dir` (created on first use)."""

    def __init__(self, db_dir: Path, *, create: bool = False) -> None:
        self.db_dir = Path(db_dir)
        path = self.db_dir / INDEX_FILE
        if not create and not path.is_file():
            raise InputError(f"{self.db_dir}: not a model database (no {INDEX_FILE}; run `homemodel db build` first)")
        self.db_dir.mkdir(parents=True, exist_ok=True)
        try:
            # A long timeout: a reader (db serve) may hold the file while a build writes.
            self._conn = sqlite3.connect(path, timeout=60.0)
            self._conn.executescript(SCHEMA)
        except sqlite3.DatabaseError as exc:
            raise InputError(f"{path}: not a readable index: {exc}") from None

    def close(self) -> None:
        self._conn.close()

    def __enter__(self) -> ModelIndex:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _row(self, values: sqlite3.Row | tuple, names: list[str]) -> EntryRow:
        data = dict(zip(names, values))
        broken = []
        for column in JSON_COLUMNS:
            # A shared or hand-edited index may hold anything: a bad cell is said in the row's
            # error and read as empty, so one row never breaks a listing.
            empty = JSON_EMPTY[column]
            try:
                data[column] = json.loads(data[column])
            except (TypeError, ValueError):
                data[column] = None
            if not isinstance(data[column], type(empty)):
                broken.append(column)
                data[column] = type(empty)()
        if broken:
            said = f"the index's {', '.join(broken)} cell is not valid"
            data["error"] = f"{data['error']}; {said}" if data.get("error") else said
        return EntryRow(**data)

    def _select(self, where: str = "", params: tuple = ()) -> Iterator[EntryRow]:
        cursor = self._conn.execute(f"SELECT * FROM models {where} ORDER BY id", params)
        names = [d[0] for d in cursor.description]
        for values in cursor:
            yield self._row(values, names)

    def rows(self) -> list[EntryRow]:
        return list(self._select())

    def columns(self, names: tuple[str, ...]) -> list[tuple]:
        """Only these columns of every row, undecoded (the page's list reads 10,000 rows)."""
        if unknown := set(names) - {f.name for f in fields(EntryRow)}:
            raise ValueError(f"{sorted(unknown)} are not columns of the index")
        return self._conn.execute(f"SELECT {', '.join(names)} FROM models").fetchall()

    def get(self, entry_id: str) -> EntryRow | None:
        return next(self._select("WHERE id = ?", (entry_id,)), None)

    def require(self, entry_id: str) -> EntryRow:
        row = self.get(entry_id)
        if row is None:
            raise InputError(f"{self.db_dir}: no entry {entry_id!r} in the database")
        return row

    def keys(self) -> dict[str, tuple[str, str, str | None]]:
        """id -> (content key, status, model folder) of every entry."""
        return {i: (k, s, p) for i, k, s, p in self._conn.execute("SELECT id, key, status, path FROM models")}

    def put(self, row: EntryRow, *, commit: bool = True) -> None:
        """Insert or replace `row`; with `commit=False` it waits for the next `commit()`."""
        data = asdict(row)
        for column in JSON_COLUMNS:
            data[column] = json.dumps(data[column])
        names = list(data)
        self._conn.execute(
            f"INSERT OR REPLACE INTO models ({', '.join(names)}) VALUES ({', '.join('?' * len(names))})",
            [data[n] for n in names],
        )
        if commit:
            self._conn.commit()

    def set_labels(self, entry_id: str, category: str, properties: dict[str, str]) -> None:
        """Update what the manifest says of an entry without rebuilding it."""
        with self._conn:
            self._conn.execute(
                "UPDATE models SET category = ?, properties = ? WHERE id = ?", (category, json.dumps(properties), entry_id)
            )

    def delete(self, entry_id: str) -> None:
        with self._conn:
            self._conn.execute("DELETE FROM models WHERE id = ?", (entry_id,))

    # The file-hash cache of content_key.

    def cached_hash(self, path: str, size: int, mtime_ns: int) -> str | None:
        found = self._conn.execute(
            "SELECT sha256 FROM file_hashes WHERE path = ? AND size = ? AND mtime_ns = ?", (path, size, mtime_ns)
        ).fetchone()
        return found[0] if found else None

    def store_hash(self, path: str, size: int, mtime_ns: int, sha256: str) -> None:
        self._conn.execute("INSERT OR REPLACE INTO file_hashes VALUES (?, ?, ?, ?)", (path, size, mtime_ns, sha256))

    def commit(self) -> None:
        self._conn.commit()
