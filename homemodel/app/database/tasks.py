"""What `db build` hands Dask: its entries as tasks, several small entries to a task.

Light on purpose (no trimesh, no pipelines): the process that runs the build imports this to
submit the tasks, and imports `entry_build` and what it needs only when it builds entries
itself (on a local cluster), never for a remote one.

A task costs Dask about 12 ms of CPU over its processes (scheduler, client, worker; measured
with 400 empty tasks on 2 local workers), much of a 100 ms cup. Entries of the sources
that take a fraction of a second (specs, imports) go up to MAX_BATCH to a task, and only
when there are enough of them to keep TASKS_PER_WORKER tasks per worker, so the workers
still finish together. A batch whose worker died is split into single entries, so one entry
that crashes its process never takes the others down with it.
"""

from __future__ import annotations

import hashlib

from homemodel.app.database.build_request import BuildRequest
from homemodel.app.database.index import EntryRow

SMALL_SOURCES = frozenset({"spec", "urdf"})  # entries of about 0.1-0.5 s
MAX_BATCH = 4
TASKS_PER_WORKER = 8


def batch_size(small_left: int, processes: int) -> int:
    """How many of the small entries still to build go to Dask's next task: up to MAX_BATCH,
    while each building process can still get TASKS_PER_WORKER tasks, so all end together."""
    return max(1, min(MAX_BATCH, small_left // (max(processes, 1) * TASKS_PER_WORKER)))


def task_key(batch: list[BuildRequest]) -> str:
    """The task's name carries its entries' keys: a rerun after a change never reuses an old result."""
    digest = hashlib.sha256("\n".join(f"{r.job.id}={r.key}" for r in batch).encode()).hexdigest()[:16]
    more = f"+{len(batch) - 1}" if len(batch) > 1 else ""
    return f"homemodel-db-{batch[0].job.id}{more}-{digest}"


def build_batch(batch: list[BuildRequest]) -> list[EntryRow]:
    """Build each entry of `batch` in turn (in a worker); one row each, never raises for a bad entry."""
    from homemodel.app.database.entry_build import build_entry

    return [build_entry(request) for request in batch]
