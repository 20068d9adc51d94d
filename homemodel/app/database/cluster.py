"""The Dask cluster of a database build given `--scheduler ADDRESS`: an existing scheduler's,
whose workers see the database folder. (A local build runs on plain worker processes, no
Dask: `local_workers`.) Its client is made on a thread of its own once the build's process
has started its own work, so that Dask's import never delays it.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Iterator

from homemodel.core.errors import InputError


@contextlib.contextmanager
def dask_client(scheduler: str, sources: tuple[str, ...] = ()) -> Iterator:
    """A Dask client of the scheduler given, whose workers import what `sources` need as they
    join (`worker_setup`)."""
    from distributed import Client

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


class ClusterStart:
    """A Dask client made on a thread of its own once `start()` is called: `client()` is None
    until it is ready (and raises what the start raised); `close()` has that thread end it
    (Dask's client must be left on the thread, and in the context, that entered it)."""

    tasks_in_flight = 2  # per worker: one running, one waiting, so a worker never idles for a round trip

    def __init__(self, scheduler: str, sources: tuple[str, ...]) -> None:
        self._client = None
        self.dashboard: str | None = None  # the dashboard's link, once connected (if the scheduler serves one)
        self._error: BaseException | None = None
        self._ready = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(
            target=self._start, args=(scheduler, sources), name="homemodel-db-cluster", daemon=True
        )
        self._started = False

    def start(self) -> None:
        """Connect to the scheduler, on the thread; once is enough."""
        if not self._started:
            self._started = True
            self._thread.start()

    def _start(self, scheduler: str, sources: tuple[str, ...]) -> None:
        try:
            with dask_client(scheduler, sources) as client:
                if "dashboard" in client.scheduler_info().get("services", {}):
                    self.dashboard = client.dashboard_link
                self._client = client
                self._ready.set()
                self._stop.wait()
        except BaseException as exc:  # noqa: BLE001 (handed to the build's thread)
            self._error = exc
        finally:
            self._ready.set()

    def workers(self, client) -> int:  # noqa: ANN001 (distributed.Client)
        """The workers the build can count on: those the scheduler has now."""
        return len(client.scheduler_info().get("workers", {}))

    def client(self, wait_s: float = 0.0):  # noqa: ANN201 (distributed.Client or None)
        """The client once the cluster is up (waiting up to `wait_s`), else None."""
        self._ready.wait(wait_s)
        if self._error is not None:
            raise self._error
        return self._client if self._ready.is_set() else None

    def close(self) -> None:
        self._stop.set()  # a client half made is closed once it is up
        if self._started:
            self._thread.join()
