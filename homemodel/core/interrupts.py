"""Ctrl-C that is honoured even while a library that cannot be interrupted starts up.

A SIGINT that lands while bpy is being imported, or while Blender resets its scene, is
swallowed inside its start-up (the command then ran on and exited 0) or crashes it. Holding
the signal for that moment and delivering it afterwards turns it into the KeyboardInterrupt
every other moment gives. Inside any other import the command line's handler only takes
note, and the run stops at its next stage: an exception thrown into a C extension's start-up
crashed the process (SIGSEGV).
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from types import FrameType


@contextlib.contextmanager
def interrupts_deferred() -> Iterator[None]:
    """Hold Ctrl-C for the block, then raise it as KeyboardInterrupt right after.

    Two holds, since either alone leaks: the main thread blocks SIGINT, but the kernel then
    hands it to any other thread (OpenBLAS's, started with numpy), whose trip still runs Python's
    handler in the main thread; so the handler only takes note meanwhile. Python's handler is
    put back afterwards: a library may have replaced it."""
    if threading.current_thread() is not threading.main_thread():
        yield  # only the main thread runs Python's signal handlers
        return
    handler = signal.getsignal(signal.SIGINT)
    pressed: list[int] = []
    signal.signal(signal.SIGINT, lambda signum, frame: pressed.append(signum))
    previous_mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        restored = handler if handler is not None else signal.default_int_handler
        signal.signal(signal.SIGINT, restored)
        signal.pthread_sigmask(signal.SIG_SETMASK, previous_mask)  # a held SIGINT arrives here
        if pressed and callable(restored):
            restored(signal.SIGINT, None)


_interrupted = False


def _inside_an_import(frame: FrameType | None) -> bool:
    while frame is not None:
        if frame.f_code.co_filename.startswith("<frozen importlib._bootstrap"):
            return True
        frame = frame.f_back
    return False


def _on_interrupt(signum: int, frame: FrameType | None) -> None:
    """Raise at once, except inside an import: an exception thrown into a C extension's start-up
    can leave it half-initialised and crash the process (seen: SIGSEGV). There the flag alone
    stops the run at the next `raise_if_interrupted`, moments later."""
    global _interrupted
    _interrupted = True
    if not _inside_an_import(frame):
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
