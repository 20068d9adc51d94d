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


_interrupted = False


def _on_interrupt(signum: int, frame: object) -> None:
    global _interrupted
    _interrupted = True
    raise KeyboardInterrupt


def remember_interrupts() -> None:
    """Make Ctrl-C also set a flag that stays set. Libraries that probe optional imports with
    `except BaseException` (trimesh does) swallow a KeyboardInterrupt raised inside them; the
    flag still stops the run at the next `raise_if_interrupted`, before any output is put in
    place. The command line calls this first; a library user keeps Python's default."""
    signal.signal(signal.SIGINT, _on_interrupt)


def raise_if_interrupted() -> None:
    """KeyboardInterrupt if a Ctrl-C was pressed (and swallowed) since `remember_interrupts`."""
    if _interrupted:
        raise KeyboardInterrupt
