"""Fixtures that cost seconds, made once and kept on disk, keyed by a hash of their inputs and
of the code that makes them: a rerun, or the second of two pytest-xdist workers, reuses the
folder the first one made. A change to an input file or to the source of a listed package
makes a new key, so a stale result is never used.

The cache is `build/test-cache/` (gitignored), or HOMEMODEL_TEST_CACHE. A clean clone starts
empty, so CI measures the cold time. Each fixture keeps only its newest entry.
"""

from __future__ import annotations

import fcntl
import hashlib
import importlib.metadata
import importlib.util
import os
import shutil
import tempfile
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
CACHE_ROOT = Path(os.environ.get("HOMEMODEL_TEST_CACHE", REPO / "build" / "test-cache"))
DONE = ".complete"
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
            return entry
        for old in root.iterdir():  # another key's entry, or a build that died half-way
            if old.is_dir():
                shutil.rmtree(old, ignore_errors=True)
        work = Path(tempfile.mkdtemp(prefix=".making-", dir=root))
        make(work)
        (work / DONE).touch()
        work.rename(entry)
        return entry
