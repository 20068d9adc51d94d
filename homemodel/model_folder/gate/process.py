"""Run an external checker with a time bound, killing everything it started on timeout."""

from __future__ import annotations

import os
import signal
import subprocess
from collections.abc import Mapping, Sequence


class BoundedRun:
    """An external checker started at once, its output collected later within a time bound, so
    that it runs on another core while the caller goes on. The child gets its own session so a
    timeout kills its children too (cmeel's `check_urdf` is a Python wrapper that spawns the real
    binary). Use as a context manager: leaving it ends a checker whose result was not taken."""

    def __init__(self, argv: Sequence[str], env: Mapping[str, str] | None = None) -> None:
        self._proc = subprocess.Popen(
            list(argv),
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            errors="replace",
            start_new_session=True,
            env=env,
        )

    @property
    def pid(self) -> int:
        """The checker's process id, which is also its process group's."""
        return self._proc.pid

    def result(self, timeout_s: float) -> subprocess.CompletedProcess[str]:
        """Its exit status and output; raises `subprocess.TimeoutExpired` after `timeout_s` more."""
        try:
            out, err = self._proc.communicate(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            self._kill()
            raise
        return subprocess.CompletedProcess(self._proc.args, self._proc.returncode, out, err)

    def _kill(self) -> None:
        os.killpg(self._proc.pid, signal.SIGKILL)
        self._proc.communicate()

    def __enter__(self) -> BoundedRun:
        return self

    def __exit__(self, *exc: object) -> None:
        with self._proc:  # closes its pipes and reaps it, whether its result was taken or not
            if self._proc.poll() is None:  # not taken: the caller stopped early
                self._kill()


def last_lines(text: str, count: int = 3) -> str:
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    return " | ".join(lines[-count:])
