"""A local `db build`'s Dask workers: started before Dask is imported in the build's process,
given the scheduler once it is up, a worker that dies replaced (as a nanny would), and all of
them ended with the cluster."""

from __future__ import annotations

import os
import signal
import time

from homemodel.app.database.cluster import ClusterStart


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def _pids(client) -> set[int]:  # noqa: ANN001 (distributed.Client)
    """The process ids of the workers that answer now (a dead one, not yet noticed, does not)."""
    return set(client.run(os.getpid, on_error="ignore").values())


def test_a_worker_that_dies_is_replaced_and_all_end_with_the_cluster() -> None:
    cluster = ClusterStart(None, 1, ())  # no sources: nothing to warm up
    try:
        cluster.start()
        client = cluster.client(wait_s=60)
        assert client is not None
        client.wait_for_workers(1, timeout=60)
        [first] = _pids(client)
        assert client.submit(sum, [1, 2], pure=False).result(timeout=60) == 3
        os.kill(first, signal.SIGKILL)  # a crash in C, say
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and _pids(client) in (set(), {first}):
            time.sleep(0.2)
        [second] = _pids(client)
        assert second != first and client.submit(sum, [3, 4], pure=False).result(timeout=60) == 7
    finally:
        cluster.close()
    assert not _alive(second)
