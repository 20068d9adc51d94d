"""Capture what C libraries (pybullet, Blender) write straight to file descriptors 1 and 2.

The library never prints; replacing `sys.stdout` cannot silence C code, so the file
descriptors themselves are redirected. Process-wide, so not thread-safe.
"""

from __future__ import annotations

import ctypes
import os
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager


def _flush_c_stdio() -> None:
    ctypes.CDLL(None).fflush(None)


@contextmanager
def captured_c_output(fds: tuple[int, ...] = (1, 2)) -> Iterator[list[str]]:
    """Collect what C code writes to `fds` (stdout and stderr) into the yielded list, not the
    terminal. Capture only fd 2 to leave a progress display on stdout drawing.

    pybullet prints from C, which replacing sys.stdout cannot catch: its build time to
    stderr on import, warnings and errors to stdout while loading. The redirection is
    process-wide, so not thread-safe.
    """
    lines: list[str] = []
    sys.stdout.flush()
    sys.stderr.flush()
    _flush_c_stdio()
    saved = {fd: os.dup(fd) for fd in fds}
    with tempfile.TemporaryFile() as sink:
        try:
            for fd in saved:
                os.dup2(sink.fileno(), fd)
            yield lines
        finally:
            _flush_c_stdio()  # C buffers stdout when it is not a terminal
            for fd, copy in saved.items():
                os.dup2(copy, fd)
                os.close(copy)
            sink.seek(0)
            lines.extend(sink.read().decode("utf-8", "replace").splitlines())
