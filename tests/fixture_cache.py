"""Fixtures that cost seconds, made once and kept on disk, keyed by a hash of their inputs and
of the code that makes them: a rerun, another checkout of the same code, or the second of the
pytest-xdist workers reuses the folder the first one made. A change to an input file, to any
file of a listed package or of the packages the layers let it import, to the Python or to any
installed distribution makes a new key, so a stale result is never used.

The cache is the user's (`${XDG_CACHE_HOME:-~/.cache}/homemodel/test-fixtures`), so a fresh
clone starts warm where the same code was tested before; HOMEMODEL_TEST_CACHE moves it (an
empty folder measures the cold time). One key is made by one process at a time, while other
keys (other checkouts) are made beside it. Each fixture keeps its entries used in the last
KEEP_UNUSED_S, at most KEEP_ENTRIES of them, and never removes one used in the last IN_USE_S:
another run may be reading it.
"""

from __future__ import annotations

import configparser
import fcntl
import functools
import hashlib
import importlib.metadata
import importlib.util
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
USER_CACHE = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
CACHE_ROOT = Path(os.environ.get("HOMEMODEL_TEST_CACHE") or USER_CACHE / "homemodel" / "test-fixtures")
DONE = ".complete"  # written last; its mtime is the entry's last use
MAKING = ".making-"
KEEP_ENTRIES = 3
KEEP_UNUSED_S = 7 * 24 * 3600
IN_USE_S = 3 * 3600  # longer than a suite run on a loaded machine
PROJECT = "homemodel"  # its own distribution: its code is hashed file by file instead


def _files(path: Path) -> Iterator[Path]:
    """The files under `path` (symlinked folders followed: the package's catalogue), in a fixed order."""
    if not path.is_dir():
        yield path
        return
    found = []
    for folder, dirs, names in os.walk(path, followlinks=True):
        dirs[:] = [d for d in dirs if d != "__pycache__"]
        found += [Path(folder) / name for name in names if not name.endswith(".pyc")]
    yield from sorted(found)


@functools.cache
def _layers() -> tuple[tuple[str, ...], ...]:
    """setup.cfg's import-linter layers, the top first: a module may import only those below it."""
    config = configparser.ConfigParser()
    config.read(REPO / "setup.cfg")
    lines = config["importlinter:contract:layers"]["layers"].split("\n")
    return tuple(tuple(name.strip() for name in line.split("|")) for line in lines if line.strip())


def _within(module: str, package: str) -> bool:
    return f"{module}.".startswith(f"{package}.")


def code_of(package: str) -> list[str]:
    """`package` and every package the layers let it import (homemodel.cli: all of them), and
    the parents whose `__init__` runs on its import."""
    layers = _layers()
    inside = [i for i, layer in enumerate(layers) for name in layer if _within(name, package) or _within(package, name)]
    if not inside:
        raise RuntimeError(f"package {package} is in no layer of setup.cfg's import-linter contract")
    names = [package, *(name for layer in layers[min(inside) + 1 :] for name in layer)]
    return names + sorted({".".join(name.split(".")[:n]) + ".__init__" for name in names for n in range(1, name.count(".") + 1)})


def _module_files(name: str) -> dict[str, Path]:
    """The files of a package (or of one module, `pkg.__init__`) by their path from the import root."""
    package = name.removesuffix(".__init__")
    spec = importlib.util.find_spec(package)  # found without importing it
    if spec is None or not spec.submodule_search_locations or spec.origin is None and package != name:
        raise RuntimeError(f"package {package} not found")
    folder = Path(next(iter(spec.submodule_search_locations)))
    root = folder.parents[package.count(".")]
    files = [Path(spec.origin)] if package != name else _files(folder)
    return {path.relative_to(root).as_posix(): path for path in files}


@functools.cache
def environment() -> str:
    """The Python and every installed distribution's version but the project's own."""
    dists = importlib.metadata.distributions()
    versions = sorted({f"{d.metadata['Name']}=={d.version}" for d in dists if d.metadata["Name"] != PROJECT})
    return "\n".join([sys.version, *versions])


def content_key(*, inputs: Iterable[Path] = (), packages: Iterable[str] = (), settings: str = "") -> str:
    """A hash of `settings`, every input file's path and bytes (folders walked), every file of
    `packages` and of what they may import (code_of; found without importing them), and the
    environment (the Python and every installed distribution's version)."""
    digest = hashlib.sha256(settings.encode())
    digest.update(environment().encode())
    for item in inputs:
        for path in _files(Path(item)):
            digest.update(path.relative_to(REPO).as_posix().encode() if path.is_relative_to(REPO) else path.name.encode())
            digest.update(path.read_bytes())
    code: dict[str, Path] = {}
    for name in {module for package in packages for module in code_of(package)}:
        code.update(_module_files(name))
    for relative in sorted(code):
        digest.update(relative.encode())
        digest.update(code[relative].read_bytes())
    return digest.hexdigest()[:20]


@contextmanager
def locked(name: str) -> Iterator[Path]:
    """The folder `name` of the cache, held by this process (others wait)."""
    folder = CACHE_ROOT / name
    folder.mkdir(parents=True, exist_ok=True)
    with _lock(folder / ".lock"):
        yield folder


@contextmanager
def _lock(path: Path) -> Iterator[None]:
    with open(path, "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def cached_folder(name: str, key: str, make: Callable[[Path], None]) -> Path:
    """The folder `make(folder)` fills, made once per key: later calls (other runs, other
    workers) get the same folder. Treat it as read-only; copy what a test changes."""
    root = CACHE_ROOT / name
    root.mkdir(parents=True, exist_ok=True)
    entry = root / key
    with _lock(root / f".lock-{key}"):  # only this key: other checkouts make theirs meanwhile
        if (entry / DONE).is_file():
            (entry / DONE).touch()
            return entry
        for dead in root.glob(f"{MAKING}{key}-*"):  # a make of this key that died half-way
            shutil.rmtree(dead, ignore_errors=True)
        work = Path(tempfile.mkdtemp(prefix=f"{MAKING}{key}-", dir=root))
        make(work)
        (work / DONE).touch()
        work.rename(entry)
    with _lock(root / ".lock"):
        _prune(root)
    return entry


def _prune(root: Path) -> None:
    """Remove entries unused for KEEP_UNUSED_S and the least recently used beyond KEEP_ENTRIES,
    but none used in the last IN_USE_S; and makes, and the locks of gone keys, as old as
    KEEP_UNUSED_S (no one waits that long: opening a lock touches it)."""
    now, entries = time.time(), []
    for path in root.iterdir():
        if (path / DONE).is_file():
            entries.append(((path / DONE).stat().st_mtime, path))
        elif now - path.stat().st_mtime > KEEP_UNUSED_S and path.name.startswith((MAKING, ".lock-")):
            if path.is_dir():
                shutil.rmtree(path, ignore_errors=True)
            elif not (root / path.name.removeprefix(".lock-")).exists():
                path.unlink(missing_ok=True)
    entries.sort(reverse=True)
    for rank, (used, folder) in enumerate(entries):
        if now - used > IN_USE_S and (rank >= KEEP_ENTRIES or now - used > KEEP_UNUSED_S):
            shutil.rmtree(folder, ignore_errors=True)
