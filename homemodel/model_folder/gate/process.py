"""Run an external checker with a time bound, killing everything it started on timeout."""

from __future__ import annotations

import os
import signal
import subprocess
from collections.abc import Mapping, Sequence


def run_bounded(argv: Sequence[str], timeout_s: float, env: Mapping[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    """Run `argv` capturing its output; raises `subprocess.TimeoutExpired` after `timeout_s`.

    The child gets its own session so a timeout kills its children too (cmeel's
    `check_urdf` is a Python wrapper that spawns the real binary).
    """
    proc = subprocess.Popen(
        list(argv),
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        errors="replace",
        start_new_session=True,
        env=env,
    )
    try:
        out, err = proc.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        raise
    return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)


def last_lines(text: str, count: int = 3) -> str:
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    return " | ".join(lines[-count:])
