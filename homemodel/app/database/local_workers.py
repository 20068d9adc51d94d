"""The Dask worker processes of a local `db build`, started the moment the build knows its
entries: each imports Dask and the build's pipelines (about 3.5 s of CPU for spec entries) on
the core the build's own process leaves free, while that process imports what its own first
entry needs. Only then does the build's process import Dask and start the scheduler (see
`cluster`), whose address each worker is given on its stdin.

Dask's LocalCluster would start them only once the scheduler is up, through a nanny in this
process and multiprocessing's spawn: Dask's import and the scheduler's start here came first
(a second on an idle 2-core machine), and the workers' imports after that. These processes
play the nanny's part themselves: one that dies after it joined (a crash in C, the OOM
killer) is started again, and its task goes back to Dask, which gives up on a task after
`distributed.scheduler.allowed-failures` deaths (KilledWorker, recorded as a failed entry).
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import subprocess
import sys
import threading
from pathlib import Path

log = logging.getLogger(__name__)

BOOT = (
    "import json, sys; sys.path[:] = json.loads(sys.argv[1]); "
    "from homemodel.app.database.worker_process import main; main(sys.argv[2:])"
)
# One thread per numeric library, as Dask's nanny gives its workers: the cores are the
# processes'. (Not the nanny's MALLOC_TRIM_THRESHOLD_=65536: with it a cup's gate took 85 ms
# instead of 55, since an entry allocates and frees many mid-sized arrays.)
ONE_THREAD = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
READY = "joined"  # what a worker process prints once its worker has joined the scheduler
CLOSE_WAIT_S = 30.0  # a closing worker ends its entry first (Dask cancels the rest)


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


class LocalWorkers:
    """`count` worker processes warming up for `sources`; `connect` gives them the scheduler,
    `close` ends them. `error` says why the build cannot go on (a worker that ended before it
    joined: a broken environment would only end the same way again)."""

    def __init__(self, count: int, sources: tuple[str, ...]) -> None:
        self.count = count
        self.error: str | None = None
        self._command = [
            sys.executable, *subprocess._args_from_interpreter_flags(), "-c", BOOT, json.dumps(sys_path_without_blender()), *sources,
        ]  # fmt: skip
        self._lock = threading.Lock()
        self._address: str | None = None
        self._closing = False
        self._processes: list[subprocess.Popen] = []
        self._watchers: list[threading.Thread] = []
        for _ in range(count):
            self._start_one()

    def _start_one(self) -> None:
        """A new worker process, told the scheduler's address if it is known (none once closing)."""
        with self._lock:
            if self._closing:
                return
            process = subprocess.Popen(
                self._command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env={**os.environ, **ONE_THREAD}
            )
            self._processes.append(process)
            if self._address is not None:
                self._tell(process, self._address)
            watcher = threading.Thread(target=self._watch, args=(process,), name="homemodel-db-worker-watch", daemon=True)
            self._watchers.append(watcher)
            watcher.start()

    @staticmethod
    def _tell(process: subprocess.Popen, line: str) -> None:
        with contextlib.suppress(OSError):  # it has ended: its watcher sees to it
            process.stdin.write(line + "\n")
            process.stdin.flush()

    def _watch(self, process: subprocess.Popen) -> None:
        """Reads what the process prints (C libraries' lines go to the debug log) until it
        ends; then starts another in its place, unless the build is closing."""
        joined = False
        for line in process.stdout:
            joined = joined or line.strip() == READY
            log.debug("worker %d: %s", process.pid, line.rstrip())
        code = process.wait()
        with self._lock:
            if self._closing:
                return
            self._processes.remove(process)
            if not joined:
                self.error = f"a local Dask worker ended (exit code {code}) before it joined the scheduler"
                return
        log.warning("a local Dask worker ended (exit code %d): starting another", code)
        self._start_one()

    def connect(self, address: str) -> None:
        with self._lock:
            self._address = address
            for process in self._processes:
                self._tell(process, address)

    def close(self) -> None:
        """End of stdin for each: it closes its worker and ends; killed if it has not in time."""
        with self._lock:
            self._closing = True
            processes = list(self._processes)
        for process in processes:
            with contextlib.suppress(OSError):
                process.stdin.close()
        for process in processes:
            try:
                process.wait(CLOSE_WAIT_S)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        for watcher in self._watchers:
            watcher.join()
