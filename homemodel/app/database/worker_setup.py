"""What each Dask worker of a build on an existing cluster (`--scheduler`) does once: import the
heavy libraries of the build's sources before its first entry (`warm_up`), and end its process
cleanly when it closes if bpy ran there (see `blender_exit`). A local build's workers are no
Dask workers: they warm up in `worker_process`, and run bpy on their main thread, where its
exit is clean.
"""

from __future__ import annotations

import asyncio
import atexit
import logging

from distributed.diagnostics.plugin import WorkerPlugin

from homemodel.app.database.blender_exit import bpy_ran_off_main_thread, end_without_teardown
from homemodel.app.database.warm_up import warm_up

log = logging.getLogger(__name__)

PLUGIN_NAME = "homemodel-db-worker"


class DatabaseWorker(WorkerPlugin):
    """Warms the worker up for the build's sources; when the worker closes, arranges the clean
    end of its process if bpy ran there. Registered with a running cluster, it runs on each
    worker there and each that joins later."""

    name = PLUGIN_NAME

    def __init__(self, sources: tuple[str, ...]) -> None:
        self.sources = tuple(sorted(set(sources)))

    async def setup(self, worker) -> None:  # noqa: ANN001 (distributed.Worker)
        # On the executor's thread (one per worker), and awaited: the worker takes its first
        # entry, which its event loop unpickles, only once these imports are done (imports of
        # the same modules on two threads at once are what a stalled build was suspected of).
        try:
            await asyncio.wrap_future(worker.executor.submit(warm_up, self.sources))
        except Exception as exc:  # noqa: BLE001 (the entries then fail with their own error)
            log.warning("warming up failed: %s", exc)

    def teardown(self, worker) -> None:  # noqa: ANN001
        if bpy_ran_off_main_thread():
            atexit.unregister(end_without_teardown)  # once, whatever the number of builds
            atexit.register(end_without_teardown)
