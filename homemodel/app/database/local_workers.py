"""The worker processes of a local `db build` (`--workers N`, the default): plain Python
processes fed through pipes, no Dask. Each starts the moment the build knows its entries and
imports the build's pipelines on the core the build's own process leaves free, while that
process imports what its own first entry needs.

A local Dask cluster cost what two plain processes side by side do not pay: Dask's import in
every process (half a second of CPU each), the scheduler's start and its event loops in the
build's process (about a second of CPU over a 100-entry build, on a 2-core machine taken from
the entries), and about 12 ms of CPU a task. Here a task is a pickle written to the worker's
stdin and its result a pickle on a pipe of its own (its stdout carries what C libraries
print, logged at debug level); each worker holds one task at a time, and the next is written
to it from the thread that read its result, so it never waits for the build's thread.

What Dask's nanny and scheduler did, done here: a worker that dies after it was ready (a crash
in C, the OOM killer) is started again, and its task is given to a worker again, up to
ALLOWED_FAILURES deaths (Dask's default), after which the task fails with `WorkerLost`
(recorded as a failed entry). A worker that dies before it was ready means a broken
environment, which would only end the same way again: `error` says so and the build stops.
"""

from __future__ import annotations

import collections
import concurrent.futures
import contextlib
import json
import logging
import os
import pickle
import subprocess
import sys
import threading
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

log = logging.getLogger(__name__)

BOOT = (
    "import json, sys; sys.path[:] = json.loads(sys.argv[1]); "
    "from homemodel.app.database.worker_process import main; main(int(sys.argv[2]), sys.argv[3:])"
)
# One thread per numeric library, as Dask's nanny gave its workers: the cores are the
# processes'. (Not the nanny's MALLOC_TRIM_THRESHOLD_=65536: with it a cup's gate took 85 ms
# instead of 55, since an entry allocates and frees many mid-sized arrays.)
ONE_THREAD = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
READY = b"ready"  # a worker's first message: its imports are done, it takes tasks
ALLOWED_FAILURES = 3  # a task may kill this many workers and be tried again (Dask's default)
CLOSE_WAIT_S = 30.0  # a closing worker ends its entry first
LENGTH_BYTES = 8  # a message's length, before it (big-endian)


class WorkerLost(RuntimeError):
    """A task whose workers all died while they ran it."""


def write_message(stream: IO[bytes], data: bytes) -> None:
    stream.write(len(data).to_bytes(LENGTH_BYTES, "big") + data)
    stream.flush()


def read_message(stream: IO[bytes]) -> bytes | None:
    """The next message, or None at the end of the stream (its writer ended)."""
    head = stream.read(LENGTH_BYTES)
    if len(head) < LENGTH_BYTES:
        return None
    length = int.from_bytes(head, "big")
    data = stream.read(length)
    return data if len(data) == length else None


def sys_path_without_blender() -> list[str]:
    """sys.path without the folders importing bpy added (Blender's scripts): the workers are
    given this process's sys.path, and with those folders first they would import Blender's
    Python `bpy` package instead of the bpy module, and fail ("No module named '_bpy'")."""
    bpy = sys.modules.get("bpy")
    if bpy is None or not getattr(bpy, "__file__", None):
        return list(sys.path)
    wheel = next((p for p in reversed(Path(bpy.__file__).parents) if p.name == "bpy"), None)
    return [
        p for p in sys.path
        if not ((wheel is not None and Path(p).is_relative_to(wheel)) or f"{os.sep}blender{os.sep}" in p)
    ]  # fmt: skip


class TaskFuture(concurrent.futures.Future):
    """A task's result to come, named by its key (as Dask's futures are)."""

    def __init__(self, key: str) -> None:
        super().__init__()
        self.key = key


@dataclass
class _Task:
    future: TaskFuture
    payload: bytes  # the pickled (function, arguments)
    deaths: int = 0  # workers that died running it


@dataclass(eq=False)
class _Worker:
    process: subprocess.Popen
    results: IO[bytes]
    ready: bool = False
    task: _Task | None = None


class LocalWorkers:
    """`count` worker processes warming up for `sources`, started at once; `submit` queues a
    task for the first free one, `close` ends them. The build's `Dispatch` uses it as it uses
    a Dask cluster (`cluster.ClusterStart`): `client()` is this pool, ready from the start."""

    dashboard: str | None = None  # no Dask, no dashboard
    tasks_in_flight = 1  # per worker: the next task is handed over as the last one's result is read

    def __init__(self, count: int, sources: tuple[str, ...]) -> None:
        self.count = count
        self.error: str | None = None
        self._sources = sources
        self._lock = threading.Lock()
        self._closing = False
        self._workers: list[_Worker] = []
        self._readers: list[threading.Thread] = []
        self._pending: collections.deque[_Task] = collections.deque()
        for _ in range(count):
            self._start_one()

    def _start_one(self) -> None:
        """A new worker process (none once closing); under the lock or before any thread runs."""
        if self._closing:
            return
        results_read, results_write = os.pipe()
        command = [sys.executable, *subprocess._args_from_interpreter_flags(), "-c", BOOT,
                   json.dumps(sys_path_without_blender()), str(results_write), *self._sources]  # fmt: skip
        try:
            process = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, pass_fds=(results_write,),
                                       env={**os.environ, **ONE_THREAD})  # fmt: skip
        finally:
            os.close(results_write)  # the worker's end: its results reach EOF when it ends
        worker = _Worker(process, os.fdopen(results_read, "rb"))
        self._workers.append(worker)
        reader = threading.Thread(target=self._read, args=(worker,), name="homemodel-db-worker", daemon=True)
        self._readers.append(reader)
        reader.start()
        threading.Thread(target=self._log_output, args=(process,), name="homemodel-db-worker-output", daemon=True).start()

    @staticmethod
    def _log_output(process: subprocess.Popen) -> None:
        """What the worker's C libraries print, to the debug log."""
        for line in process.stdout:
            log.debug("worker %d: %s", process.pid, line.decode(errors="replace").rstrip())

    def _read(self, worker: _Worker) -> None:
        """The worker's messages until it ends: ready, then one result per task."""
        while (message := read_message(worker.results)) is not None:
            done: tuple[_Task, bytes] | None = None
            with self._lock:
                if not worker.ready:
                    worker.ready = message == READY
                else:
                    done, worker.task = (worker.task, message), None
                self._hand_out()
            if done is not None:  # outside the lock: the future's callbacks submit more
                _resolve(*done)
        worker.results.close()
        self._ended(worker, worker.process.wait())

    def _ended(self, worker: _Worker, code: int) -> None:
        """A worker process ended: its task goes to another (or fails), another takes its place."""
        lost = None
        with self._lock:
            self._workers.remove(worker)
            if self._closing:
                if worker.task is not None:  # killed on closing: nobody waits for it
                    worker.task.future.cancel()
                return
            if not worker.ready:
                self.error = f"a local worker process ended (exit code {code}) before it was ready"
                return
            task = worker.task
            if task is not None:
                task.deaths += 1
                if task.deaths > ALLOWED_FAILURES:
                    lost = task
                else:
                    self._pending.appendleft(task)
            log.warning("a local worker process ended (exit code %d): starting another", code)
            self._start_one()
        if lost is not None:
            with contextlib.suppress(concurrent.futures.InvalidStateError):  # cancelled meanwhile
                lost.future.set_exception(
                    WorkerLost(f"{lost.future.key}: its worker process died {lost.deaths} times (last exit code {code})")
                )

    def _hand_out(self) -> None:
        """Each ready, idle worker gets the next pending task (under the lock)."""
        for worker in self._workers:
            if not self._pending:
                return
            if worker.ready and worker.task is None and worker.process.poll() is None:
                worker.task = self._pending.popleft()
                try:
                    write_message(worker.process.stdin, worker.task.payload)
                except OSError:  # it has ended: its reader gives the task to another
                    pass

    def submit(self, function: Callable, *args: Any, key: str) -> TaskFuture:
        """Run `function(*args)` in a worker (it and its arguments pickled)."""
        task = _Task(TaskFuture(key), pickle.dumps((function, args), protocol=pickle.HIGHEST_PROTOCOL))
        with self._lock:
            self._pending.append(task)
            self._hand_out()
        return task.future

    def cancel(self, futures: Iterable[TaskFuture]) -> None:
        """Tasks not yet handed out are dropped (a running one ends with its entry)."""
        dropped = set(futures)
        with self._lock:
            self._pending = collections.deque(t for t in self._pending if t.future not in dropped)
        for future in dropped:
            future.cancel()

    # What `Dispatch` asks of its cluster.
    def start(self) -> None:
        """Nothing more to start: the processes started with the pool."""

    def client(self, wait_s: float = 0.0) -> LocalWorkers:  # noqa: ARG002 (ready at once)
        if self.error is not None:
            raise RuntimeError(self.error)
        return self

    def workers(self, client: LocalWorkers) -> int:  # noqa: ARG002
        return self.count

    def pids(self) -> list[int]:
        with self._lock:
            return [worker.process.pid for worker in self._workers]

    def close(self) -> None:
        """End of stdin for each: it ends its entry and exits; killed if it has not in time.
        Tasks never handed out are cancelled."""
        with self._lock:
            self._closing = True
            workers, pending = list(self._workers), list(self._pending)
            self._pending.clear()
        for task in pending:
            task.future.cancel()
        for worker in workers:
            with contextlib.suppress(OSError):
                worker.process.stdin.close()
        for worker in workers:
            try:
                worker.process.wait(CLOSE_WAIT_S)
            except subprocess.TimeoutExpired:
                worker.process.kill()
                worker.process.wait()
        for reader in self._readers:
            reader.join()


def _resolve(task: _Task, message: bytes) -> None:
    """The task's future from the worker's reply: ("ok", result) or ("error", exception)."""
    try:
        outcome, value = pickle.loads(message)
    except Exception as exc:  # noqa: BLE001 (a result that cannot be read is the task's failure)
        outcome, value = "error", RuntimeError(f"{task.future.key}: its result could not be read: {exc}")
    if task.future.set_running_or_notify_cancel():
        if outcome == "ok":
            task.future.set_result(value)
        else:
            task.future.set_exception(value)
