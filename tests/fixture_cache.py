"""Fixtures that cost seconds, made once and kept on disk, keyed by a hash of their inputs and
of the code that makes them: a rerun, or the second of two pytest-xdist workers, reuses the
folder the first one made. A change to an input file or to the source of a listed package
makes a new key, so a stale result is never used.

The cache is `build/test-cache/` (gitignored), or HOMEMODEL_TEST_CACHE. A clean clone starts
empty, so CI measures the cold time. Each fixture keeps its entries used in the last
KEEP_UNUSED_S, at most KEEP_ENTRIES of them: another run (another checkout state) may be
reading an older key's folder at the same time, so no entry is removed as soon as it is old.
"""

from __future__ import annotations

import fcntl
import hashlib
import importlib.metadata
import importlib.util
import os
import shutil
import tempfile
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
CACHE_ROOT = Path(os.environ.get("HOMEMODEL_TEST_CACHE", REPO / "build" / "test-cache"))
DONE = ".complete"  # written last; its mtime is the entry's last use
KEEP_ENTRIES = 3
KEEP_UNUSED_S = 6 * 3600
SOURCE_SUFFIXES = (".py", ".js", ".yaml", ".xsd")


def _files(path: Path) -> Iterator[Path]:
    if path.is_dir():
        yield from sorted(p for p in path.rglob("*") if p.is_file() and "__pycache__" not in p.parts)
    else:
        yield path


def content_key(
    *, inputs: Iterable[Path] = (), packages: Iterable[str] = (), distributions: Iterable[str] = (), settings: str = ""
) -> str:
    """A hash of `settings`, every input file's path and bytes (folders walked), every source
    file of `packages` (found without importing them) and the installed versions of
    `distributions` (bpy, whose renderer makes the pictures)."""
    digest = hashlib.sha256(settings.encode())
    for name in distributions:
        digest.update(f"{name}=={importlib.metadata.version(name)}".encode())
    for item in inputs:
        for path in _files(Path(item)):
            digest.update(path.relative_to(REPO).as_posix().encode() if path.is_relative_to(REPO) else path.name.encode())
            digest.update(path.read_bytes())
    for name in packages:
        spec = importlib.util.find_spec(name)
        if spec is None or not spec.submodule_search_locations:
            raise RuntimeError(f"package {name} not found")
        folder = Path(next(iter(spec.submodule_search_locations)))
        for path in _files(folder):
            if path.suffix in SOURCE_SUFFIXES:
                digest.update(f"{name}/{path.relative_to(folder).as_posix()}".encode())
                digest.update(path.read_bytes())
    return digest.hexdigest()[:20]


@contextmanager
def locked(name: str) -> Iterator[Path]:
    """The fixture's cache folder, held by this process (other workers wait)."""
    folder = CACHE_ROOT / name
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield folder
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def cached_folder(name: str, key: str, make: Callable[[Path], None]) -> Path:
    """The folder `make(folder)` fills, made once per key: later calls (other runs, other
    workers) get the same folder. Treat it as read-only; copy what a test changes."""
    with locked(name) as root:
        entry = root / key
        if (entry / DONE).is_file():
            (entry / DONE).touch()
            return entry
        _prune(root)
        work = Path(tempfile.mkdtemp(prefix=".making-", dir=root))
        make(work)
        (work / DONE).touch()
        work.rename(entry)
        return entry


def _prune(root: Path) -> None:
    """Under the lock: remove builds that died half-way (no one else is making), entries unused
    for KEEP_UNUSED_S, and the least recently used beyond KEEP_ENTRIES - 1 (one is being made)."""
    entries = []
    for folder in (p for p in root.iterdir() if p.is_dir()):
        if not (folder / DONE).is_file():
            shutil.rmtree(folder, ignore_errors=True)
        else:
            entries.append(((folder / DONE).stat().st_mtime, folder))
    entries.sort(reverse=True)
    for rank, (used, folder) in enumerate(entries):
        if rank >= KEEP_ENTRIES - 1 or time.time() - used > KEEP_UNUSED_S:
            shutil.rmtree(folder, ignore_errors=True)
