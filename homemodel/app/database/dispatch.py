"""A build's entries shared between its workers (a Dask cluster's, or a local build's worker
processes) and, on a local build, this process.

On a local build this process builds small entries (specs, imports) itself from the first
moment, while the worker processes start (`local_workers`): its own imports and first entries
overlap the workers' start-up, and with N cores there are N - 1 workers, so N processes build,
no more. The workers get their tasks a few at a time (`tasks_in_flight` per worker: on Dask one
running and one waiting, so a worker never idles for a round trip; a local worker is handed its
next task as its last result is read), topped up from the thread that learns a task ended;
this process takes single entries from the same queue between collecting what the workers
returned, and records every row (the index is this thread's alone).

Long entries (the reconstructions) and entries that crashed this process before are built by
the workers only: a crash in C there costs the build that worker, recorded as a failed entry,
not the build. Before this process builds an entry it writes the entry's id to JOURNAL, and
removes it when done; a build that finds the file at its start knows that entry killed the
process that built it, and gives it to the workers.
"""

from __future__ import annotations

import contextlib
import logging
import queue
import threading
from collections import deque
from collections.abc import Callable, Collection
from pathlib import Path
from typing import Any, Protocol

from homemodel.app.database.build_request import BuildRequest
from homemodel.app.database.index import EntryRow
from homemodel.app.database.tasks import SMALL_SOURCES, batch_size, build_batch, task_key

log = logging.getLogger(__name__)

JOURNAL = ".building-here"
WAIT_S = 0.2  # how long the build waits for the workers' results before looking again

Settle = Callable[[list[EntryRow]], None]


class Workers(Protocol):
    """What the build asks of its workers: a Dask cluster (`cluster.ClusterStart`) or a local
    build's processes (`local_workers.LocalWorkers`). `client()` submits tasks, as Dask's
    client does (`submit(function, *args, key=...)`, `cancel(futures)`), None until it can."""

    dashboard: str | None
    tasks_in_flight: int  # per worker

    def start(self) -> None: ...
    def client(self, wait_s: float = 0.0) -> Any: ...
    def workers(self, client: Any) -> int: ...


def crashed_here(db_dir: Path) -> set[str]:
    """The entry an earlier build was building in its own process when that process died
    (read once: the journal is removed)."""
    path = db_dir / JOURNAL
    try:
        said = path.read_text().strip()
    except OSError:
        return set()
    path.unlink(missing_ok=True)
    return {said} if said else set()


def worker_lost(request: BuildRequest, exc: BaseException) -> EntryRow:
    """An entry whose task killed every worker that tried it (a crash in C, say)."""
    job = request.job
    return EntryRow(
        id=job.id, category=job.category or "", source=job.source, key=request.key, status="failed",
        error=f"{type(exc).__name__}: {' '.join(str(exc).split())}", inputs={r: str(p) for r, p in job.inputs.items()},
        properties=dict(job.properties),
    )  # fmt: skip


def _one_numeric_thread() -> contextlib.AbstractContextManager:
    """One thread for each numeric library loaded (numpy's and scipy's OpenBLAS), as the
    workers have (`local_workers.ONE_THREAD`): by default OpenBLAS starts a thread per core,
    and after each small product (a mesh's points by a rotation, thousands an entry) that
    thread spins on the other core, the one a worker builds on. With it a cup cost this
    process 125 ms of CPU against 103 (the entry's own thread the same)."""
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1)


class Dispatch:
    """Runs `requests` on the workers and, with `here`, in this process; see the module's note."""

    def __init__(self, cluster: Workers | None, requests: list[BuildRequest], *, here: bool, processes: int,
                 db_dir: Path, workers_only: Collection[str] = ()) -> None:  # fmt: skip
        self._cluster = cluster
        self._here = here
        self._processes = max(processes, 1)  # the processes that build: the cluster's, and this one
        self._journal = db_dir / JOURNAL
        shared = [r.job.source in SMALL_SOURCES and not (here and r.job.id in workers_only) for r in requests]
        # The long ones first: they decide when the build ends.
        self._alone = deque([r] for r, s in zip(requests, shared) if not s)
        self._shared = deque(r for r, s in zip(requests, shared) if s)
        self._lock = threading.Lock()
        self._futures: dict[str, tuple[Any, list[BuildRequest]]] = {}  # key: (the task's future, batch)
        self._finished: queue.Queue[str] = queue.Queue()  # keys of ended tasks, from the thread that learnt it
        self._in_flight = 0  # the tasks the workers may hold at once, once the client is up
        self._running = 0  # tasks given to the workers and not ended (ended ones may wait to be collected)
        self._closing = False

    def run(self, settle: Settle) -> None:
        """Every request built and settled (or recorded as failed); on an exception or Ctrl-C
        nothing more is started and the workers' tasks are cancelled."""
        numeric_threads = contextlib.ExitStack()
        try:
            if self._here and self._shared:
                self._warm_up()
                numeric_threads.enter_context(_one_numeric_thread())
            if self._cluster is not None:
                # Only now: Dask's import and its client's start would otherwise come before
                # this process's first entry.
                self._cluster.start()
            while True:
                self._top_up()
                self._collect(settle, wait_s=0.0)
                request = self._next_here()
                if request is not None:
                    settle([self._build_here(request)])
                elif self._all_done():
                    return
                else:
                    self._collect(settle, wait_s=WAIT_S)
        finally:
            numeric_threads.close()
            with self._lock:
                self._closing = True
                futures = [future for future, _ in self._futures.values()]
            if futures:
                with contextlib.suppress(Exception):
                    self._client().cancel(futures)

    def _warm_up(self) -> None:
        """Import what this process's entries need before the first (as a worker does)."""
        from homemodel.app.database.warm_up import warm_up

        try:
            warm_up(tuple(sorted({r.job.source for r in self._shared})))
        except Exception as exc:  # noqa: BLE001 (the entries then fail with their own error)
            log.warning("warming up failed: %s", exc)

    def _next_here(self) -> BuildRequest | None:
        if not self._here:
            return None
        with self._lock:
            return self._shared.popleft() if self._shared else None

    def _build_here(self, request: BuildRequest) -> EntryRow:
        from homemodel.app.database.entry_build import build_entry

        self._journal.write_text(request.job.id)
        try:
            # Only stderr captured: the command's progress display draws on stdout.
            return build_entry(request, c_output_fds=(2,))
        finally:
            self._journal.unlink(missing_ok=True)

    def _all_done(self) -> bool:
        with self._lock:
            return not (self._alone or self._shared or self._futures) and self._finished.empty()

    def _next_task(self) -> list[BuildRequest]:
        """The next task for the workers (under the lock): a long entry, else a few small ones."""
        if self._alone:
            return self._alone.popleft()
        size = batch_size(len(self._shared), self._processes)
        return [self._shared.popleft() for _ in range(min(size, len(self._shared)))]

    def _client(self, wait_s: float = 0.0) -> Any:
        """The workers' client once it is up (None before, and without workers)."""
        return self._cluster.client(wait_s) if self._cluster is not None else None

    def _top_up(self) -> None:
        """Give the workers tasks up to `tasks_in_flight` each (a no-op until the client is up).
        Counted by the tasks not yet ended, not those not yet collected: a worker whose task
        ended gets the next at once, from the thread that learnt it, not once this process
        has finished its own entry."""
        client = self._client()
        if client is None:
            return
        submitted = []
        with self._lock:
            if not self._in_flight:
                self._in_flight = self._cluster.tasks_in_flight * max(self._cluster.workers(client), 1)
            while not self._closing and self._running < self._in_flight:
                batch = self._next_task()
                if not batch:
                    break
                future = client.submit(build_batch, batch, key=task_key(batch))
                self._futures[future.key] = (future, batch)
                self._running += 1
                submitted.append(future)
        # Outside the lock: a task ended already has its callback called here, which takes it.
        for future in submitted:
            future.add_done_callback(self._ended)

    def _ended(self, future: Any) -> None:  # on the thread that learnt the task ended
        with self._lock:
            self._running -= 1
        self._finished.put(future.key)
        with contextlib.suppress(Exception):  # a client closing: the build's thread finds out
            self._top_up()

    def _collect(self, settle: Settle, wait_s: float) -> None:
        """Settle the rows of every task the workers have ended (waiting up to `wait_s` for one)."""
        try:
            key = self._finished.get(timeout=wait_s) if wait_s else self._finished.get_nowait()
        except queue.Empty:
            if wait_s:
                self._client()  # raises if the cluster could not start
            return
        while True:
            with self._lock:
                future, batch = self._futures.pop(key)
            try:
                rows = future.result()
            except Exception as exc:  # noqa: BLE001 (KilledWorker, WorkerLost and the like: recorded, the build goes on)
                if len(batch) > 1:  # which of them killed the worker is unknown: each on its own
                    with self._lock:
                        self._alone.extendleft([r] for r in reversed(batch))
                    self._top_up()
                    rows = []
                else:
                    rows = [worker_lost(batch[0], exc)]
            settle(rows)
            try:
                key = self._finished.get_nowait()
            except queue.Empty:
                return
