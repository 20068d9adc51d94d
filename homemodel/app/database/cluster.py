"""The Dask cluster of a database build: an existing scheduler's, or a local one started on a
thread while this process builds entries of its own (see `dispatch`), so that no core waits
for the workers' start-up: the scheduler, the worker processes and their imports of the
build's pipelines (4 s of CPU for a spec worker) overlap this process's own imports and
first entries.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

from homemodel.core.errors import InputError

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


def sys_path_without_blender() -> list[str]:
    """sys.path without the folders importing bpy added (Blender's scripts). Local workers are
    given it: they start with this process's sys.path, and with those folders first they would
    import Blender's Python `bpy` package instead of the bpy module, and fail ("No module named
    '_bpy'"). Taken before this process imports bpy for its own entries, or without them."""
    bpy = sys.modules.get("bpy")
    if bpy is None or not getattr(bpy, "__file__", None):
        return list(sys.path)
    wheel = next((p for p in reversed(Path(bpy.__file__).parents) if p.name == "bpy"), None)
    return [
        p for p in sys.path
        if not ((wheel is not None and Path(p).is_relative_to(wheel)) or f"{os.sep}blender{os.sep}" in p)
    ]  # fmt: skip


@contextlib.contextmanager
def dask_client(scheduler: str | None, workers: int, sources: tuple[str, ...] = ()) -> Iterator:
    """A Dask client: of the scheduler given, or of a LocalCluster of `workers` single-threaded
    processes, whose workers each import what `sources` need as they start (`worker_setup`)."""
    import dask
    from distributed import Client, LocalCluster

    from homemodel.app.database.worker_setup import PLUGIN_NAME, DatabaseWorker

    if scheduler is not None:
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError) as exc:
            raise InputError(f"scheduler: cannot reach {scheduler}: {exc}") from None
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
    # The plugin goes with the workers' arguments: each starts importing as soon as its
    # process is up, while the others start, not once this process has them all.
    plugin = DatabaseWorker(sources, sys_path=sys_path_without_blender())
    with dask.config.set({**WORKER_CONFIG, **QUIET_CONFIG}), LocalCluster(
        n_workers=workers,
        threads_per_worker=1,  # bpy is not thread-safe
        processes=True,
        dashboard_address=":0",  # any free port: with None, Dask's 8787, and a warning when it is taken
        silence_logs=logging.ERROR,  # Dask's own INFO lines would bury the build's
        plugins=(plugin,),
    ) as cluster, Client(cluster) as client:
        yield client


def _has_bokeh() -> bool:
    import importlib.util

    return importlib.util.find_spec("bokeh") is not None


class ClusterStart:
    """A Dask client made on a thread of its own: `client()` is None until it is ready (and
    raises what the start raised); `close()` has that thread end it (Dask's client must be
    left on the thread, and in the context, that entered it)."""

    def __init__(self, scheduler: str | None, workers: int, sources: tuple[str, ...]) -> None:
        # Imported here, on the calling thread, which goes on to import the pipelines: two
        # threads importing the same package at once can see it half-initialised.
        import distributed  # noqa: F401

        import homemodel.app.database.worker_setup  # noqa: F401

        self._client = None
        self.dashboard: str | None = None  # the dashboard's link, once the cluster is up (with bokeh)
        self._error: BaseException | None = None
        self._ready = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(
            target=self._start, args=(scheduler, workers, sources), name="homemodel-db-cluster", daemon=True
        )
        self._thread.start()

    def _start(self, scheduler: str | None, workers: int, sources: tuple[str, ...]) -> None:
        try:
            with dask_client(scheduler, workers, sources) as client:
                # The HTTP server is always there; the dashboard's pages only with bokeh.
                if "dashboard" in client.scheduler_info().get("services", {}) and (scheduler or _has_bokeh()):
                    self.dashboard = client.dashboard_link
                self._client = client
                self._ready.set()
                self._stop.wait()
        except BaseException as exc:  # noqa: BLE001 (handed to the build's thread)
            self._error = exc
        finally:
            self._ready.set()

    def client(self, wait_s: float = 0.0):  # noqa: ANN201 (distributed.Client or None)
        """The client once the cluster is up (waiting up to `wait_s`), else None."""
        self._ready.wait(wait_s)
        if self._error is not None:
            raise self._error
        return self._client if self._ready.is_set() else None

    def close(self) -> None:
        self._stop.set()  # a cluster half started is closed once it is up
        self._thread.join()
