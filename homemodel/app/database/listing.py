"""The page's list of models, searched, sorted and paged on the server: the index's rows are
read once per change of the index file and kept as small summaries with their sort keys,
so a query over 10,000 models is a filter and a slice (milliseconds), not a read."""

from __future__ import annotations

import functools
import json
import math
import re
import threading
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import quote

from homemodel.app.database.index import INDEX_FILE, MODELS_DIR, STATUSES, ModelIndex
from homemodel.core.errors import InputError

SORT_KEYS = ("id", "category", "source", "status", "triangles", "joints", "build_s")
NUMBER_KEYS = ("links", "joints", "grasp_points", "triangles", "build_s")
LIST_COLUMNS = ("id", "category", "source", "status", "thumbnail", "properties", "error", *NUMBER_KEYS)
MAX_LIMIT = 500
_DIGITS = re.compile(r"(\d+)")


@functools.lru_cache(maxsize=1 << 16)
def natural_key(text: str) -> tuple:
    """`base_unit_2` before `base_unit_10`, case-insensitive: digit runs compare as numbers."""
    return tuple(int(part) if i % 2 else part for i, part in enumerate(_DIGITS.split(text.casefold())))


def finite_number(value: object) -> int | float | None:
    """A count or time from the index, or None when the cell holds anything else (a hand-edited
    index may hold text or NaN, which JSON cannot carry)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return value if math.isfinite(value) else None


def thumbnail_url(db_dir: Path, thumbnail: object) -> str | None:
    """The URL of an entry's thumbnail when the index names a .png under models/, else None."""
    if not isinstance(thumbnail, str) or not thumbnail.startswith(f"{MODELS_DIR}/") or not thumbnail.endswith(".png"):
        return None
    return "/db/" + quote(thumbnail.removeprefix(f"{MODELS_DIR}/"))


def summary(db_dir: Path, values: Mapping[str, object]) -> dict:
    """What the page's table shows of an entry (`values`: its index columns, `properties`
    as JSON text or decoded), every value a plain string or number."""
    properties, error = values["properties"], values["error"]
    if isinstance(properties, str):
        try:
            properties = json.loads(properties)
        except ValueError:
            properties = None
    if not isinstance(properties, dict):
        note = "the index's properties cell is not valid"
        properties, error = {}, f"{error}; {note}" if error else note
    data = {
        "id": str(values["id"]),
        "category": str(values["category"]),
        "source": str(values["source"]),
        "status": str(values["status"]),
        "thumbnail": thumbnail_url(db_dir, values["thumbnail"]),
        "properties": {str(k): str(v) for k, v in properties.items()},
        "error": None if error is None else str(error),
    }
    return data | {key: finite_number(values[key]) for key in NUMBER_KEYS}


@dataclass(kw_only=True)
class ListQuery:
    """One page of the list: free text `q` (every word in the id, category, source or a
    `name=value` property; `status:valid` is an exact status), a status, sort and page."""

    q: str = ""
    status: str | None = None
    sort: str = "id"
    descending: bool = False
    offset: int = 0
    limit: int = 100

    def check(self) -> None:
        if self.sort not in SORT_KEYS:
            raise InputError(f"sort: {self.sort!r} is not one of {', '.join(SORT_KEYS)}")
        if self.status is not None and self.status not in STATUSES:
            raise InputError(f"status: {self.status!r} is not one of {', '.join(STATUSES)}")
        if self.offset < 0 or not 1 <= self.limit <= MAX_LIMIT:
            raise InputError(f"offset {self.offset}, limit {self.limit}: need offset >= 0 and 1 <= limit <= {MAX_LIMIT}")
        if len(self.q) > 1000:
            raise InputError("q: longer than 1000 characters")


@dataclass
class _Snapshot:
    """The index as the list reads it, in parallel lists (fast to filter)."""

    summaries: list[dict]
    texts: list[str]  # what free text searches, case-folded
    statuses: list[str]
    orders: dict[str, list[int]]  # sort key -> row positions in ascending order, made on demand

    @classmethod
    def of(cls, summaries: list[dict]) -> _Snapshot:
        texts = [
            " ".join([s["id"], s["category"], s["source"], *(f"{k}={v}" for k, v in s["properties"].items())]).casefold()
            for s in summaries
        ]  # fmt: skip
        return cls(summaries, texts, [s["status"] for s in summaries], {})

    def order(self, key: str) -> list[int]:
        if key not in self.orders:
            rows = self.summaries
            if key in NUMBER_KEYS:
                sort_key = lambda i: (rows[i][key] is None, rows[i][key] or 0, natural_key(rows[i]["id"]))  # noqa: E731
            else:
                sort_key = lambda i: (natural_key(rows[i][key]), natural_key(rows[i]["id"]))  # noqa: E731
            self.orders[key] = sorted(range(len(rows)), key=sort_key)
        return self.orders[key]


class Listing:
    """The database's rows as summaries, read again whenever the index file changes."""

    def __init__(self, db_dir: Path) -> None:
        self.db_dir = Path(db_dir)
        self._lock = threading.Lock()
        self._stamp: tuple | None = None
        self._snapshot = _Snapshot.of([])

    def _index_stamp(self) -> tuple:
        stamps = []
        for name in (INDEX_FILE, f"{INDEX_FILE}-wal"):
            try:
                stat = (self.db_dir / name).stat()
                stamps.append((stat.st_mtime_ns, stat.st_size, stat.st_ino))
            except FileNotFoundError:
                stamps.append(None)
        return tuple(stamps)

    def _current(self) -> _Snapshot:
        with self._lock:
            stamp = self._index_stamp()
            if stamp != self._stamp:
                with ModelIndex(self.db_dir) as index:
                    rows = index.columns(LIST_COLUMNS)
                self._snapshot = _Snapshot.of([summary(self.db_dir, dict(zip(LIST_COLUMNS, r))) for r in rows])
                self._stamp = stamp
            return self._snapshot

    def query(self, query: ListQuery) -> dict:
        """{total, matched, offset, rows}: one page of the rows `query` selects, in its order."""
        query.check()
        snapshot = self._current()
        words, status = [], query.status
        for word in query.q.casefold().split():
            if word.startswith("status:"):
                status = word.removeprefix("status:")
            else:
                words.append(word)
        chosen = snapshot.order(query.sort)
        if query.descending:
            chosen = chosen[::-1]
        if status is not None:
            statuses = snapshot.statuses
            chosen = [i for i in chosen if statuses[i] == status]
        texts = snapshot.texts
        for word in words:
            chosen = [i for i in chosen if word in texts[i]]
        page = chosen[query.offset : query.offset + query.limit]
        rows = snapshot.summaries
        return {"total": len(rows), "matched": len(chosen), "offset": query.offset, "rows": [rows[i] for i in page]}
