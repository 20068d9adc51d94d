"""`homemodel db build`: every entry of a manifest through its pipeline, on local worker
processes or on Dask.

By default the build runs on this machine: single-threaded worker processes (bpy is not
thread-safe), one per core but one, fed through pipes without Dask (`local_workers`), with
this process building small entries too from the start, while the workers start (`dispatch`).
Given a scheduler address it runs on that Dask cluster (`cluster`), whose workers see the
database folder (a shared file system) and run the same homemodel. Workers build and store
model folders; this process alone writes the index, one committed row per finished entry.

Only entries whose content key changed are built. A killed worker's entries are rebuilt
elsewhere; an interrupted build leaves whole folders and whole rows, and the next build picks
up what is missing.
"""

from __future__ import annotations

import contextlib
import fcntl
import logging
import math
import os
import shutil
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from homemodel.app.database.content_key import content_key
from homemodel.app.database.index import MODELS_DIR, EntryRow, ModelIndex
from homemodel.app.database.manifest import Job, RepairSpec, load_manifest
from homemodel.app.database.build_request import BuildRequest
from homemodel.app.database.cluster import ClusterStart
from homemodel.app.database.dispatch import Dispatch, Workers, crashed_here
from homemodel.app.database.local_workers import LocalWorkers
from homemodel.app.database.tasks import SMALL_SOURCES
from homemodel.core.checks import require_at_least
from homemodel.core.errors import InputError

log = logging.getLogger(__name__)

LOCK_FILE = ".build.lock"
COMMIT_EVERY_S = 0.5  # the index's rows are committed at most this often during a build
# A build of no more small entries than this (and nothing else) runs in this process alone:
# a worker's start (its imports: about 2 s of CPU for specs) would take longer than they do
# (a cup 0.15 s, a cabinet 0.5 s).
HERE_ALONE_ENTRIES = 16


@dataclass(kw_only=True)
class DatabaseBuildOptions:
    workers: int | None = None  # local processes that build (this one and N - 1 worker processes); None: one per core
    scheduler: str | None = None  # an existing Dask scheduler, e.g. tcp://host:8786
    repair: bool = False  # repair every imported asset that lacks only what the gate needs (else: entries with `repair: true`)
    retry_failed: bool = False  # build failed entries again even when their key is unchanged

    def check(self) -> None:
        if self.workers is not None:
            require_at_least("workers", self.workers, 1)
        if self.workers is not None and self.scheduler is not None:
            raise InputError("workers: give either a number of local workers or a scheduler, not both")
        if self.scheduler is not None and "://" not in self.scheduler:
            raise InputError(f"scheduler: {self.scheduler!r} is not an address like tcp://host:8786")


@dataclass(kw_only=True)
class DatabaseBuild:
    db_dir: Path
    built: list[EntryRow] = field(default_factory=list)  # this run's rows (valid, invalid or failed)
    cached: list[str] = field(default_factory=list)  # ids whose key had not changed
    dashboard: str | None = None
    seconds: float = 0.0

    def count(self, status: str) -> int:
        return sum(row.status == status for row in self.built)


# Called as each entry finishes (built now, or found cached).
EntryDone = Callable[[EntryRow, bool], None]
# Called once the jobs are known: (entries to build, entries cached, None: the dashboard's link
# is known only once the cluster is up, and given to `on_dashboard`).
BuildStarts = Callable[[int, int, str | None], None]


@contextlib.contextmanager
def build_lock(db_dir: Path) -> Iterator[None]:
    db_dir.mkdir(parents=True, exist_ok=True)
    with open(db_dir / LOCK_FILE, "w") as lock:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise InputError(f"{db_dir}: another `homemodel db build` is running on this database") from None
        yield


def _remove_leftovers(db_dir: Path) -> None:
    """Temporary folders of builds that were killed (atomic writes clean up after themselves
    unless the process dies): safe to remove while this build holds the lock."""
    models = db_dir / MODELS_DIR
    if models.is_dir():
        for path in models.iterdir():
            if path.name.startswith(".") and path.name.endswith((".tmp", ".old")):
                shutil.rmtree(path, ignore_errors=True)


def _settle(index: ModelIndex, row: EntryRow, commit: bool) -> None:
    """Record a finished entry; a failed one keeps no folder of an earlier build (its row is
    committed first, so the old row never points to a removed folder)."""
    folder = index.db_dir / MODELS_DIR / row.id
    removes_folder = row.path is None and folder.exists()
    index.put(row, commit=commit or removes_folder)
    if removes_folder:
        shutil.rmtree(folder)


def repair_for(job: Job, repair_spec: RepairSpec, repair_all: bool) -> RepairSpec | None:
    """The repair settings an entry is built with: None unless `--repair` or its manifest entry
    (`repair: true`) asks for repairs."""
    return repair_spec if job.source == "urdf" and (repair_all or job.repair) else None


def plan(jobs: list[Job], repairs: dict[str, RepairSpec | None], index: ModelIndex, retry_failed: bool) -> tuple[dict[str, str], list[Job], list[Job]]:
    """Every job's key, the jobs to build and the jobs whose stored build is still current."""
    keys = {}
    for job in jobs:
        repair = repairs[job.id]
        keys[job.id] = content_key(job, repair.model_dump_json() if repair is not None else "", index.cached_hash, index.store_hash)
    index.commit()
    stored = index.keys()
    todo, cached = [], []
    for job in jobs:
        key, status, folder = stored.get(job.id, (None, None, None))
        # A stored build is current if its key matches and its folder is still there.
        present = folder is None or (index.db_dir / folder / "model.urdf").is_file()
        current = key == keys[job.id] and present and not (retry_failed and status == "failed")
        (cached if current else todo).append(job)
    return keys, todo, cached


def largest_first(jobs: list[Job], last_build_s: dict[str, float]) -> list[Job]:
    """`jobs` by their last build's time, longest first; those never built before them all (any
    of them may be long), in the manifest's order. A build ends with its last entry while the
    other processes idle: that entry had better be a short one."""
    return sorted(jobs, key=lambda job: -last_build_s.get(job.id, math.inf))


def build_database(
    manifest_path: Path,
    db_dir: Path,
    options: DatabaseBuildOptions | None = None,
    *,
    on_start: BuildStarts | None = None,
    on_entry: EntryDone | None = None,
    on_dashboard: Callable[[str], None] | None = None,
) -> DatabaseBuild:
    """Build every entry of the manifest whose key changed into the database at `db_dir`."""
    options = options or DatabaseBuildOptions()
    options.check()
    start = time.perf_counter()
    db_dir = Path(db_dir)
    jobs, repair_spec = load_manifest(manifest_path)
    repairs = {job.id: repair_for(job, repair_spec, options.repair) for job in jobs}
    result = DatabaseBuild(db_dir=db_dir)
    with build_lock(db_dir), ModelIndex(db_dir, create=True) as index:
        _remove_leftovers(db_dir)
        keys, todo, cached = plan(jobs, repairs, index, options.retry_failed)
        for job in cached:
            row = index.require(job.id)
            category, properties = job.category or row.category, {**row.properties, **job.properties}
            if (category, properties) != (row.category, row.properties):
                index.set_labels(job.id, category, properties)
            result.cached.append(job.id)
        if on_start:
            on_start(len(todo), len(cached), None)
        if on_entry:
            for job in cached:
                on_entry(index.require(job.id), True)
        if todo:
            todo = largest_first(todo, dict(index.columns(("id", "build_s"))))
            requests = [BuildRequest(job=job, key=keys[job.id], db_dir=db_dir.resolve(), repair=repairs[job.id]) for job in todo]
            _run(options, requests, index, result, on_entry, on_dashboard)
            _remove_leftovers(db_dir)  # of a worker killed during this build
    result.seconds = time.perf_counter() - start
    return result


def _run(options: DatabaseBuildOptions, requests: list[BuildRequest], index: ModelIndex, result: DatabaseBuild,
         on_entry: EntryDone | None, on_dashboard: Callable[[str], None] | None) -> None:  # fmt: skip
    """Build `requests` on the workers (and here, on a local build), recording each row as it lands."""
    processes = options.workers or os.cpu_count() or 1
    workers_only = crashed_here(index.db_dir)
    # This process builds small entries too on a local build of 2 or more processes, and alone a few of them.
    small = {r.job.id for r in requests if r.job.source in SMALL_SOURCES and r.job.id not in workers_only}
    here = options.scheduler is None and processes > 1 and bool(small)
    alone = here and len(small) == len(requests) <= HERE_ALONE_ENTRIES
    # What the workers import as they start: with this process building the small entries, what
    # only the workers build, if anything (a worker given a small entry imports its pipeline
    # then); else everything.
    theirs = {r.job.source for r in requests if not (here and r.job.id in small)}
    sources = tuple(sorted(theirs or {r.job.source for r in requests}))
    cluster: Workers | None = None
    if options.scheduler is not None:
        cluster = ClusterStart(options.scheduler, sources)
    elif not alone:
        cluster = LocalWorkers(processes - 1 if here else processes, sources)
    last_commit = time.monotonic()

    def settle(rows: list[EntryRow]) -> None:
        nonlocal last_commit
        if result.dashboard is None and cluster is not None and cluster.dashboard:
            result.dashboard = cluster.dashboard
            if on_dashboard:
                on_dashboard(cluster.dashboard)
        for row in rows:
            # Rows are committed in batches: a commit (its fsyncs) took 16 ms on the development
            # machine against 0.7 ms a row in a batch, and a shared file system is slower.
            commit = time.monotonic() - last_commit > COMMIT_EVERY_S
            _settle(index, row, commit)
            last_commit = time.monotonic() if commit else last_commit
            result.built.append(row)
            if on_entry:
                on_entry(row, False)

    try:
        Dispatch(cluster, requests, here=here, processes=processes, db_dir=index.db_dir, workers_only=workers_only).run(settle)
    finally:
        # On Ctrl-C: nothing more is started; finished entries are committed.
        index.commit()
        if cluster is not None:
            cluster.close()
