"""The first code the `homemodel` command runs: a Ctrl-C while the command line's modules are
still being imported ends quietly too (exit code 130), as it does once a command runs.

The command ends without the interpreter's teardown: once the exit handlers have run (the
resident glTF validator stopped, logs flushed, temporary folders removed), freeing the objects
of 1,300 modules one by one is work for nothing (0.20 CPU-s of a completion query's 2.6,
at load 20). A program that calls `main` and goes on after it (tests, benchmarks) gets
the usual SystemExit instead.
"""

from __future__ import annotations

import atexit
import ctypes
import gc
import os
import sys
import threading
from pathlib import Path
from typing import NoReturn

# The cyclic garbage collector's first generation is collected after this many allocations
# (Python's default: 700). A command makes millions of objects as it starts (its modules'), few
# of them cyclic garbage: at 700 the collector took 0.12 CPU-s of a completion query (287
# collections, the full ones going through every module's objects), at 7,000 0.06 (28, none full).
GC_FIRST_GENERATION = 7000

# glibc's malloc hands a freed block over 128 KiB back to the kernel (unmapped, or the heap's
# top trimmed), so the next array of that size faults in fresh zeroed pages. Its threshold grows
# with the blocks freed, but a command's arrays keep growing past it. With blocks up to 16 MiB
# kept on the heap and up to 32 MiB of free top kept, a completion query takes 60,000 page faults
# instead of 90,000 and about 0.05 CPU-s less (system time 0.26-0.29 -> 0.19-0.24 s; 16
# alternating runs at load 9-11), its peak memory the same.
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3  # mallopt's parameters (malloc.h)
MMAP_THRESHOLD_BYTES = 16 << 20
TRIM_THRESHOLD_BYTES = 32 << 20


def keep_freed_memory() -> None:
    """Let glibc's malloc reuse large freed blocks instead of returning them to the kernel at
    once (not glibc: nothing to do)."""
    try:
        mallopt = ctypes.CDLL("libc.so.6").mallopt
    except (OSError, AttributeError):
        return
    mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)
    mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES)


def main() -> None:
    gc.set_threshold(GC_FIRST_GENERATION, *gc.get_threshold()[1:])
    keep_freed_memory()
    try:
        from homemodel.core.deferred_imports import defer_networkx
        from homemodel.core.interrupts import raise_if_interrupted, remember_interrupts
        from homemodel.core.scipy_doc_notes import skip_scipy_doc_notes

        remember_interrupts()
        defer_networkx()  # trimesh's import without networkx's 0.08 CPU-s, for what never uses it
        skip_scipy_doc_notes()  # SciPy's import without parsing 147 docstrings nobody reads
        from homemodel.cli.commands import main as run_command_line

        raise_if_interrupted()
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        sys.exit(130)
    try:
        run_command_line()
    except SystemExit as done:
        if _run_as_the_command():
            _end_without_teardown(done.code)
        raise


def _run_as_the_command() -> bool:
    """Whether this process is the `homemodel` command itself (its console script, or `python -m
    homemodel`) rather than a program that called `main`."""
    program = sys.modules.get("__main__")
    spec = getattr(program, "__spec__", None)
    if spec is not None and spec.name == "homemodel.__main__":
        return True
    return Path(getattr(program, "__file__", None) or "").name == "homemodel"


def _end_without_teardown(code: object) -> NoReturn:
    """End as `sys.exit(code)` ends a process, up to the module teardown, which is skipped."""
    threading._shutdown()  # what the interpreter does first: wait for the threads not daemonic
    atexit._run_exitfuncs()
    if code is None or isinstance(code, int):
        status = code or 0
    else:
        print(code, file=sys.stderr)
        status = 1
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe: Python's own exit says 120 then
            status = status or 120
    os._exit(status)
