"""One Dask worker process of a local `db build`, started by `local_workers.LocalWorkers` the
moment the build knows its entries, before the build's own process has imported Dask or
started the scheduler.

It imports Dask, then the build's pipelines on the thread that will run its entries (its
executor's one thread), while it waits for the scheduler's address on stdin; it joins the
scheduler with that thread still warming up (the entries Dask gives it wait behind the
imports). End of stdin (the build closing it, or the build's process gone) closes the worker
and ends the process. Ctrl-C is the build's to handle: this process ignores SIGINT.

Run as `python -c BOOT SYS_PATH_JSON SOURCE...` (see `local_workers`).
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import logging
import contextlib
import signal
import sys
import threading

from homemodel.app.database.local_workers import READY

log = logging.getLogger(__name__)


def _warmed(future: concurrent.futures.Future) -> None:
    if future.exception() is not None:  # the entries then fail with their own error
        log.warning("warming up failed: %s", future.exception())


async def _serve(address: str, executor: concurrent.futures.Executor) -> None:
    from distributed import Worker

    loop = asyncio.get_running_loop()
    # memory_limit=0: no memory monitor (this worker has no nanny to restart it; the build's
    # LocalWorkers does that when the process dies).
    async with Worker(address, nthreads=1, executor=executor, memory_limit=0, dashboard=False) as worker:
        print(READY, flush=True)
        stdin_closed = loop.create_future()

        def wait_for_end_of_stdin() -> None:
            sys.stdin.read()
            with contextlib.suppress(RuntimeError):  # the loop has ended already
                loop.call_soon_threadsafe(stdin_closed.set_result, None)

        # A daemon thread: a worker ended by its scheduler must not wait for it.
        threading.Thread(target=wait_for_end_of_stdin, daemon=True).start()
        await asyncio.wait([stdin_closed, asyncio.ensure_future(worker.finished())], return_when=asyncio.FIRST_COMPLETED)
        await worker.close(reason="the build closed its workers")


def main(sources: list[str]) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    import dask
    import distributed  # noqa: F401

    from homemodel.app.database.cluster import QUIET_CONFIG

    # The modules a task's arguments unpickle into, imported here on the main thread before
    # the executor's thread imports the pipelines: no module is imported by two threads at once.
    import homemodel.app.database.tasks  # noqa: F401
    from homemodel.app.database.blender_exit import bpy_ran_off_main_thread, end_without_teardown
    from homemodel.app.database.warm_up import warm_up

    dask.config.set(QUIET_CONFIG)
    logging.getLogger("distributed").setLevel(logging.ERROR)  # Dask's INFO lines would bury the build's
    executor = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="homemodel-db-entries")
    warming = executor.submit(warm_up, tuple(sources))
    warming.add_done_callback(_warmed)
    address = sys.stdin.readline().strip()  # "": the build ended before its scheduler started
    if address:
        asyncio.run(_serve(address, executor))
    concurrent.futures.wait([warming])  # bpy half imported would not end cleanly either
    if bpy_ran_off_main_thread():
        end_without_teardown()
