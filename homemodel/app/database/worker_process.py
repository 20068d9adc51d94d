"""One worker process of a local `db build`, started by `local_workers.LocalWorkers` the moment
the build knows its entries.

It imports the build's pipelines (on its main thread, where bpy is at home and ends cleanly),
says it is ready, then runs the tasks it reads from stdin one at a time, each a pickled
(function, arguments), and writes each outcome, ("ok", result) or ("error", exception),
pickled, to the pipe whose descriptor it was given. End of stdin (the build closing it, or the
build's process gone) ends the process. Ctrl-C is the build's to handle: this process ignores
SIGINT.

Run as `python -c BOOT SYS_PATH_JSON RESULTS_FD SOURCE...` (see `local_workers`).
"""

from __future__ import annotations

import logging
import os
import pickle
import signal
import sys

from homemodel.app.database.local_workers import READY, read_message, write_message

log = logging.getLogger(__name__)


def _outcome(message: bytes) -> bytes:
    """The pickled outcome of the pickled task `message`."""
    try:
        function, args = pickle.loads(message)
        outcome = ("ok", function(*args))
    except Exception as exc:  # noqa: BLE001 (the task's failure is the build's to record)
        outcome = ("error", exc)
    try:
        return pickle.dumps(outcome, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception as exc:  # noqa: BLE001 (an exception or result that cannot be pickled)
        return pickle.dumps(("error", RuntimeError(f"the task's outcome cannot be pickled: {type(exc).__name__}: {exc}")))


def main(results_fd: int, sources: list[str]) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    from homemodel.app.database.warm_up import warm_up

    results = os.fdopen(results_fd, "wb")
    try:
        if sources:  # (a pool given none builds no entries)
            warm_up(tuple(sources))
    except Exception as exc:  # noqa: BLE001 (the entries then fail with their own error)
        log.warning("warming up failed: %s", exc)
    write_message(results, READY)
    while (message := read_message(sys.stdin.buffer)) is not None:
        write_message(results, _outcome(message))
