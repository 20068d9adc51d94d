"""An entry's content key: a hash of its input files' bytes, its settings and the version of
the code that builds it. A rebuild builds only the entries whose key changed.

File hashes are remembered by (path, size, mtime) in the index, so a rerun with nothing
changed reads no input file again: it takes seconds whatever the database's size.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.metadata
import importlib.util
from collections.abc import Callable
from pathlib import Path

from homemodel.app.database.manifest import Job
from homemodel.core.content_hash import content_files, file_sha256

# The packages whose code builds each source (all of them export through articulation and
# end in the database's own entry build, thumbnail and the core helpers).
SHARED_PACKAGES = ("articulation", "homemodel.exchange", "homemodel.core", "homemodel.geometry", "homemodel.app.database")
SOURCE_PACKAGES = {
    "spec": ("modeller",),
    "turntable": ("turntable",),
    "photos": ("photogrammetry",),
    "completion": ("shape_completion",),
    "urdf": (),
}

# (path, size, mtime_ns) -> sha256 hex, or None when not remembered: the index's file cache.
HashLookup = Callable[[str, int, int], str | None]
HashStore = Callable[[str, int, int, str], None]


def _package_folder(name: str) -> Path:
    spec = importlib.util.find_spec(name)  # finds the folder without importing (bpy stays unloaded)
    if spec is None or not spec.submodule_search_locations:
        raise RuntimeError(f"package {name} not found")
    return Path(next(iter(spec.submodule_search_locations)))


@functools.cache
def code_version(source: str) -> str:
    """A hash of homemodel's version and the source of every module that builds `source`."""
    # The installed distribution's version: the package root is imported by nothing.
    digest = hashlib.sha256(importlib.metadata.version("homemodel").encode())
    for package in (*SOURCE_PACKAGES[source], *SHARED_PACKAGES):
        folder = _package_folder(package)
        for path in sorted(folder.rglob("*")):
            if path.suffix in (".py", ".js", ".html", ".css") and "__pycache__" not in path.parts:
                digest.update(path.relative_to(folder).as_posix().encode())
                digest.update(path.read_bytes())
    return digest.hexdigest()


def inputs_digest(job: Job, lookup: HashLookup | None = None, store: HashStore | None = None) -> str:
    """The input files' hashes, remembered through `lookup`/`store` when given (the index's cache)."""
    digest = hashlib.sha256()
    for role in sorted(job.inputs):
        root = job.inputs[role]
        digest.update(role.encode())
        if not root.exists():
            digest.update(b"missing")  # the build will fail and say so; the key still changes when it appears
            continue
        for path in content_files(root):
            stat = path.stat()
            name = str(path)
            sha = lookup(name, stat.st_size, stat.st_mtime_ns) if lookup is not None else None
            if sha is None:
                sha = file_sha256(path)
                if store is not None:
                    store(name, stat.st_size, stat.st_mtime_ns, sha)
            digest.update(path.relative_to(root).as_posix().encode() if root.is_dir() else b"")
            digest.update(sha.encode())
    return digest.hexdigest()


def content_key(job: Job, repair_settings: str = "", lookup: HashLookup | None = None, store: HashStore | None = None) -> str:
    """The entry's key; `repair_settings` is "" unless the build repairs imported assets."""
    digest = hashlib.sha256()
    for part in (code_version(job.source), job.settings(), repair_settings if job.source == "urdf" else "", inputs_digest(job, lookup, store)):
        digest.update(part.encode())
        digest.update(b"\0")
    return digest.hexdigest()


def spec_content_key(name: str, spec_path: Path) -> str:
    """The key of the spec at `spec_path` built as model `name`, the same as a manifest's entry
    (`source: spec`, `options: {name}`) gets, without the index's hash cache (a home's build)."""
    return content_key(Job(id=name, source="spec", inputs={"path": spec_path}, options={"name": name}))
