"""`homemodel db build`: every entry of a manifest through its pipeline, on Dask.

The build runs on Dask's `distributed` scheduler: by default an in-process `LocalCluster`
with one worker process per core and one thread each (bpy is not thread-safe); given a
scheduler address, on an existing cluster whose workers see the database folder (a shared
file system) and run the same homemodel. Workers build and store model folders; this process
alone writes the index, one committed row per finished entry.

Only entries whose content key changed are built. A killed worker's entries are rebuilt by
Dask elsewhere; an interrupted build leaves whole folders and whole rows, and the next build
picks up what is missing.
"""

from __future__ import annotations

import contextlib
import fcntl
import importlib.util
import logging
import os
import shutil
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from homemodel.app.database.content_key import content_key
from homemodel.app.database.index import MODELS_DIR, EntryRow, ModelIndex
from homemodel.app.database.manifest import Job, RepairSpec, load_manifest
from homemodel.app.database.build_request import BuildRequest
from homemodel.app.database.tasks import batches, build_batch, task_key
from homemodel.core.checks import require_at_least
from homemodel.core.errors import InputError

log = logging.getLogger(__name__)

LOCK_FILE = ".build.lock"
# Dask starts its workers with MALLOC_TRIM_THRESHOLD_=65536, so that freed memory goes back
# to the OS at once for its memory monitor. An entry allocates and frees many mid-sized arrays
# (meshes, the gate's checks): with it, a cup's gate took 85 ms instead of 55 in one process,
# and more with two side by side. The workers keep glibc's own, adaptive threshold.
WORKER_CONFIG = {"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}
# What Dask's processes do while the workers build, made rarer: an idle local cluster of 2
# workers used 13-15 % of a core with Dask's defaults (each event loop's tick every 20 ms,
# each worker's profiler sampling every 10 ms, the system and memory monitors), 1.6-1.8 %
# with these; on a 2-core machine that share came out of the entries. The dashboard's
# profile and resource plots go with them; a killed worker is still noticed at once.
QUIET_CONFIG = {
    "distributed.admin.tick.interval": "1s",
    "distributed.worker.profile.enabled": False,
    "distributed.admin.system-monitor.interval": "2s",
    "distributed.worker.memory.monitor-interval": "1s",
    "distributed.scheduler.work-stealing-interval": "1s",
}
COMMIT_EVERY_S = 0.5  # the index's rows are committed at most this often during a build


@dataclass(kw_only=True)
class DatabaseBuildOptions:
    workers: int | None = None  # local worker processes; None: one per core
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
# Called once the jobs are known: (entries to build, entries cached, dashboard link or None).
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


@contextlib.contextmanager
def _without_blender_paths() -> Iterator[None]:
    """sys.path without the folders importing bpy added (Blender's scripts). Worker processes
    start with the parent's sys.path; with those folders first they would import Blender's
    Python `bpy` package instead of the bpy module, and fail ("No module named '_bpy'")."""
    bpy = sys.modules.get("bpy")
    saved = list(sys.path)
    if bpy is not None and getattr(bpy, "__file__", None):
        wheel = next((p for p in reversed(Path(bpy.__file__).parents) if p.name == "bpy"), None)
        sys.path[:] = [
            p for p in saved
            if not ((wheel is not None and Path(p).is_relative_to(wheel)) or f"{os.sep}blender{os.sep}" in p)
        ]  # fmt: skip
    try:
        yield
    finally:
        sys.path[:] = saved


@contextlib.contextmanager
def _client(options: DatabaseBuildOptions, sources: tuple[str, ...] = ()) -> Iterator:
    """A Dask client: of the scheduler given, or of a LocalCluster of this machine's cores,
    whose workers each import what `sources` need as they start (see `worker_setup`)."""
    import dask
    from distributed import Client, LocalCluster

    from homemodel.app.database.worker_setup import PLUGIN_NAME, DatabaseWorker

    if options.scheduler is not None:
        try:
            client = Client(options.scheduler, timeout="20s")
        except (OSError, TimeoutError) as exc:
            raise InputError(f"scheduler: cannot reach {options.scheduler}: {exc}") from None
        with client:
            if sources:
                client.register_plugin(DatabaseWorker(sources), name=PLUGIN_NAME)
            try:
                yield client
            finally:
                # A shared cluster's later workers need not warm up for this build.
                with contextlib.suppress(OSError, TimeoutError, ValueError):
                    client.unregister_worker_plugin(PLUGIN_NAME)
        return
    dashboard = ":0" if importlib.util.find_spec("bokeh") is not None else None
    # The plugin goes with the workers' arguments: each starts importing as soon as its
    # process is up, while the others start, not once this process has them all.
    with _without_blender_paths(), dask.config.set({**WORKER_CONFIG, **QUIET_CONFIG}), LocalCluster(
        n_workers=options.workers or os.cpu_count() or 1,
        threads_per_worker=1,  # bpy is not thread-safe
        processes=True,
        dashboard_address=dashboard,
        silence_logs=logging.ERROR,  # Dask's own INFO lines would bury the build's
        plugins=(DatabaseWorker(sources),) if sources else (),
    ) as cluster, Client(cluster) as client:
        yield client


def _dashboard(client) -> str | None:  # noqa: ANN001 (distributed.Client)
    services = client.scheduler_info().get("services", {})
    return client.dashboard_link if "dashboard" in services else None


def _worker_lost(job: Job, key: str, exc: BaseException) -> EntryRow:
    """An entry whose task killed every worker that tried it (a crash in C, say)."""
    return EntryRow(
        id=job.id, category=job.category or "", source=job.source, key=key, status="failed",
        error=f"{type(exc).__name__}: {' '.join(str(exc).split())}", inputs={r: str(p) for r, p in job.inputs.items()},
        properties=dict(job.properties),
    )  # fmt: skip


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


def build_database(
    manifest_path: Path,
    db_dir: Path,
    options: DatabaseBuildOptions | None = None,
    *,
    on_start: BuildStarts | None = None,
    on_entry: EntryDone | None = None,
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
        with _client(options, tuple(job.source for job in todo)) if todo else contextlib.nullcontext() as client:
            result.dashboard = _dashboard(client) if todo else None
            if on_start:
                on_start(len(todo), len(cached), result.dashboard)
            if on_entry:
                for job in cached:
                    on_entry(index.require(job.id), True)
            if todo:
                _run(client, todo, keys, db_dir, repairs, index, result, on_entry)
                _remove_leftovers(db_dir)  # of a worker killed during this build
    result.seconds = time.perf_counter() - start
    return result


def _workers(client) -> int:  # noqa: ANN001 (distributed.Client)
    return len(client.scheduler_info().get("workers", {})) or 1


def _run(client, todo: list[Job], keys: dict[str, str], db_dir: Path, repairs: dict[str, RepairSpec | None],  # noqa: ANN001
         index: ModelIndex, result: DatabaseBuild, on_entry: EntryDone | None) -> None:  # fmt: skip
    from distributed import as_completed

    requests = [BuildRequest(job=job, key=keys[job.id], db_dir=db_dir.resolve(), repair=repairs[job.id]) for job in todo]
    futures = {}

    def submit(batch: list[BuildRequest]):  # noqa: ANN202 (distributed.Future)
        future = client.submit(build_batch, batch, key=task_key(batch))
        futures[future.key] = (future, batch)
        return future

    pending = as_completed([submit(batch) for batch in batches(requests, _workers(client))])
    last_commit = time.monotonic()
    try:
        for future in pending:
            batch = futures[future.key][1]
            try:
                rows = future.result()
            except Exception as exc:  # noqa: BLE001 (KilledWorker and the like: recorded, the build goes on)
                if len(batch) > 1:  # which of them killed the worker is unknown: each on its own
                    for request in batch:
                        pending.add(submit([request]))
                    continue
                rows = [_worker_lost(batch[0].job, batch[0].key, exc)]
            for row in rows:
                # Rows are committed in batches: a commit (its fsyncs) took 16 ms on the development
                # machine against 0.7 ms a row in a batch, and a shared file system is slower.
                commit = time.monotonic() - last_commit > COMMIT_EVERY_S
                _settle(index, row, commit)
                last_commit = time.monotonic() if commit else last_commit
                result.built.append(row)
                if on_entry:
                    on_entry(row, False)
    finally:
        # On Ctrl-C: nothing more is started; finished entries are committed.
        index.commit()
        client.cancel([f for f, _ in futures.values()])
