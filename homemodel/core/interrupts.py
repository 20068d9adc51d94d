"""Ctrl-C that is honoured even while a library that cannot be interrupted starts up.

A SIGINT that lands while bpy is being imported is swallowed inside its start-up (the
command then ran on and exited 0) or crashes it. Holding the signal for that moment and
delivering it afterwards turns it into the KeyboardInterrupt every other moment gives.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator


@contextlib.contextmanager
def interrupts_deferred() -> Iterator[None]:
    """Block SIGINT for the block; then restore Python's handler (a library may have replaced
    it) and unblock, so a Ctrl-C pressed meanwhile is raised as KeyboardInterrupt right after."""
    if threading.current_thread() is not threading.main_thread():
        yield  # only the main thread receives SIGINT in Python
        return
    handler = signal.getsignal(signal.SIGINT)
    previous_mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, handler if handler is not None else signal.default_int_handler)
        signal.pthread_sigmask(signal.SIG_SETMASK, previous_mask)
