"""A local `db build`'s worker processes (no Dask): tasks run in them with one thread per numeric
library and glibc's own malloc settings; a worker that dies is replaced and its task run again,
a task that kills every worker fails after Dask's allowed failures, a worker that cannot start
stops the build, and all of them end with the pool."""

from __future__ import annotations

import os
import signal
import time

import pytest

from homemodel.app.database import local_workers
from homemodel.app.database.local_workers import ALLOWED_FAILURES, LocalWorkers, WorkerLost


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def test_tasks_run_in_the_workers_with_one_numeric_thread_and_glibcs_malloc() -> None:
    """Dask's nanny default MALLOC_TRIM_THRESHOLD_=65536 made a cup's gate 55 -> 85 ms: not set here."""
    workers = LocalWorkers(2, ())  # no sources: nothing to warm up
    try:
        pids = {workers.submit(os.getpid, key=f"pid{i}").result(timeout=60) for i in range(4)}
        assert pids <= set(workers.pids()) and os.getpid() not in pids
        assert workers.submit(os.getenv, "OMP_NUM_THREADS", key="threads").result(timeout=60) == "1"
        trim = workers.submit(os.getenv, "MALLOC_TRIM_THRESHOLD_", key="trim").result(timeout=60)
        assert trim == os.environ.get("MALLOC_TRIM_THRESHOLD_")
        with pytest.raises(ZeroDivisionError):  # a task's exception reaches its future
            workers.submit(divmod, 1, 0, key="fails").result(timeout=60)
    finally:
        workers.close()
    assert not any(_alive(pid) for pid in pids)


def test_a_worker_that_dies_is_replaced_and_its_task_run_again() -> None:
    workers = LocalWorkers(1, ())
    try:
        [first] = workers.pids()
        assert workers.submit(sum, [1, 2], key="a").result(timeout=60) == 3
        held = workers.submit(time.sleep, 0.5, key="held")  # handed to the idle worker at once
        os.kill(first, signal.SIGKILL)  # a crash in C, say
        assert held.result(timeout=60) is None
        [second] = workers.pids()
        assert second != first and workers.submit(os.getpid, key="pid").result(timeout=60) == second
    finally:
        workers.close()
    assert not _alive(second)


def test_a_task_that_kills_every_worker_fails_and_the_rest_go_on() -> None:
    workers = LocalWorkers(1, ())
    try:
        crash = workers.submit(os._exit, 9, key="crash")
        with pytest.raises(WorkerLost, match=rf"crash: its worker process died {ALLOWED_FAILURES + 1} times \(last exit code 9\)"):
            crash.result(timeout=120)
        assert workers.submit(sum, [3, 4], key="after").result(timeout=60) == 7
    finally:
        workers.close()


def test_a_worker_that_ends_before_it_is_ready_stops_the_build(monkeypatch) -> None:
    monkeypatch.setattr(local_workers, "BOOT", "raise SystemExit(3)")  # a broken environment
    workers = LocalWorkers(1, ())
    try:
        deadline = time.monotonic() + 60
        while workers.error is None and time.monotonic() < deadline:
            time.sleep(0.05)
        with pytest.raises(RuntimeError, match=r"ended \(exit code 3\) before it was ready"):
            workers.client()
    finally:
        workers.close()
