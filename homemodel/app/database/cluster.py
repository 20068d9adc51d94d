"""The Dask cluster of a database build: an existing scheduler's, or a local one: its worker
processes start at once (`local_workers`), and the scheduler once this process has started
its own first entry (`ClusterStart.start`), so that no core waits for Dask: the workers'
imports overlap this process's, and Dask's import and the scheduler's start here overlap its
first entries, not its start-up.
"""

from __future__ import annotations

import contextlib
import logging
import threading
from collections.abc import Iterator

from homemodel.app.database.local_workers import LocalWorkers
from homemodel.core.errors import InputError

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


@contextlib.contextmanager
def dask_client(scheduler: str | None, workers: int, sources: tuple[str, ...] = (), local: LocalWorkers | None = None) -> Iterator:
    """A Dask client: of the scheduler given, or of a local scheduler with `workers`
    single-threaded worker processes (`local`, if started already), which import what
    `sources` need as they start."""
    import dask
    from distributed import Client, LocalCluster

    if scheduler is not None:
        from homemodel.app.database.worker_setup import PLUGIN_NAME, DatabaseWorker

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
    local = local or LocalWorkers(workers, sources)
    try:
        with dask.config.set(QUIET_CONFIG), LocalCluster(
            n_workers=0,  # the workers are `local`'s
            processes=True,
            dashboard_address=":0",  # any free port: with None, Dask's 8787, and a warning when it is taken
            silence_logs=logging.ERROR,  # Dask's own INFO lines would bury the build's
        ) as cluster, Client(cluster) as client:
            local.connect(cluster.scheduler_address)
            try:
                yield client
            finally:
                local.close()  # before the scheduler: each worker leaves it in order
    finally:
        local.close()


def _has_bokeh() -> bool:
    import importlib.util

    return importlib.util.find_spec("bokeh") is not None


class ClusterStart:
    """A Dask client made on a thread of its own once `start()` is called (a local cluster's
    workers start at once): `client()` is None until it is ready (and raises what the start
    raised); `close()` has that thread end it (Dask's client must be left on the thread, and
    in the context, that entered it)."""

    def __init__(self, scheduler: str | None, workers: int, sources: tuple[str, ...]) -> None:
        self._local = LocalWorkers(workers, sources) if scheduler is None else None
        self._client = None
        self.dashboard: str | None = None  # the dashboard's link, once the cluster is up (with bokeh)
        self._error: BaseException | None = None
        self._ready = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(
            target=self._start, args=(scheduler, workers, sources), name="homemodel-db-cluster", daemon=True
        )
        self._started = False

    def start(self) -> None:
        """Start the scheduler (or connect to the one given), on the thread; once is enough."""
        if not self._started:
            self._started = True
            self._thread.start()

    def _start(self, scheduler: str | None, workers: int, sources: tuple[str, ...]) -> None:
        try:
            with dask_client(scheduler, workers, sources, self._local) as client:
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

    def workers(self, client) -> int:  # noqa: ANN001 (distributed.Client)
        """The workers the build can count on: a local cluster's, whether they joined yet or not."""
        return self._local.count if self._local is not None else len(client.scheduler_info().get("workers", {}))

    def client(self, wait_s: float = 0.0):  # noqa: ANN201 (distributed.Client or None)
        """The client once the cluster is up (waiting up to `wait_s`), else None."""
        self._ready.wait(wait_s)
        if self._error is not None:
            raise self._error
        if self._local is not None and self._local.error is not None:
            raise RuntimeError(self._local.error)
        return self._client if self._ready.is_set() else None

    def close(self) -> None:
        self._stop.set()  # a cluster half started is closed once it is up
        if self._started:
            self._thread.join()
        elif self._local is not None:  # never started: only the workers to end
            self._local.close()
