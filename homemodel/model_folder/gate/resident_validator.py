"""One long-lived Khronos glTF validator (node) per process, asked one file at a time.

Starting node and loading the validator cost about 250 ms, validating a model 3-10 ms: a
batch build validates hundreds of models, so the gate keeps the process and talks to it
over pipes (`validate_gltf.js --lines`, beside this module). A request that times out kills the process;
the next one starts a fresh one. The process ends when this one does: at exit, or by
reading the end of its stdin when this process dies without running its exit handlers.
"""

from __future__ import annotations

import atexit
import json
import os
import select
import signal
import subprocess
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from homemodel.model_folder.gate.process import last_lines


class ValidatorFailed(Exception):
    """The validator process could not answer (it died, or said something that is not a reply)."""


class _Resident:
    def __init__(self, node: str, script: Path, node_path: Path | None) -> None:
        self.argv = [node, str(script), "--lines"]
        self.node_path = node_path
        self.stderr = tempfile.TemporaryFile()
        env = dict(os.environ, NODE_PATH=str(node_path)) if node_path is not None else None
        self.proc = subprocess.Popen(
            self.argv,
            env=env,  # where `require` finds the npm packages, wherever they are installed
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self.stderr,
            start_new_session=True,  # a Ctrl-C in the terminal is this process's to handle
        )
        self.owner = os.getpid()
        self.pending = b""

    def serves(self, node: str, script: Path, node_path: Path | None) -> bool:
        """Whether this process can take a request for `node script` from this process."""
        alive = self.proc.poll() is None
        same = self.argv == [node, str(script), "--lines"] and self.node_path == node_path
        return alive and self.owner == os.getpid() and same

    def ask(self, glb: Path, timeout_s: float) -> dict[str, Any]:
        """The reply to one request; raises TimeoutError or ValidatorFailed."""
        request = json.dumps({"file": str(Path(glb).resolve())}) + "\n"
        try:
            self.proc.stdin.write(request.encode())
            self.proc.stdin.flush()
        except OSError:  # it ended before reading the request
            raise self._exited() from None
        line = self._read_line(time.monotonic() + timeout_s)
        try:
            reply = json.loads(line)
        except json.JSONDecodeError:
            raise ValidatorFailed(f"the validator answered {line[:200]!r}") from None
        if not isinstance(reply, dict):
            raise ValidatorFailed(f"the validator answered {line[:200]!r}")
        return reply

    def _read_line(self, deadline: float) -> str:
        fd = self.proc.stdout.fileno()
        while b"\n" not in self.pending:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([fd], [], [], left)[0]:
                raise TimeoutError
            chunk = os.read(fd, 1 << 20)
            if not chunk:
                raise self._exited()
            self.pending += chunk
        line, _, self.pending = self.pending.partition(b"\n")
        return line.decode("utf-8", errors="replace")

    def _exited(self) -> ValidatorFailed:
        self.proc.wait()
        self.stderr.seek(0)
        said = last_lines(self.stderr.read().decode("utf-8", errors="replace"))
        return ValidatorFailed(f"the validator exited with status {self.proc.returncode}" + (f": {said}" if said else ""))

    def stop(self) -> None:
        if self.owner != os.getpid():  # a forked child's copy: the process is its parent's
            return
        try:
            self.proc.stdin.close()  # the validator ends at the end of its input
            self.proc.wait(timeout=2)
        except (OSError, subprocess.TimeoutExpired):
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait()
        self.stderr.close()


_lock = threading.Lock()
_resident: _Resident | None = None


def validate_resident(
    node: str, script: Path, glb: Path, timeout_s: float, *, node_path: Path | None = None
) -> dict[str, Any]:
    """The validator's reply for `glb`: {"report": ...} or {"error": "..."}; `node_path` is the
    node_modules folder its `require` looks in.

    Raises TimeoutError (the process is killed) or ValidatorFailed (it is dropped); either
    way the next call starts a new process.
    """
    with _lock:
        resident = _serving(node, script, node_path)
        try:
            return resident.ask(glb, timeout_s)
        except (TimeoutError, ValidatorFailed):
            _stop_resident(kill=True)
            raise


def start_resident(node: str, script: Path, *, node_path: Path | None = None) -> None:
    """Start the validator process now, unless one already serves: node loads the validator
    while this process goes on working, and the next `validate_resident` call finds it ready."""
    with _lock:
        _serving(node, script, node_path)


def _serving(node: str, script: Path, node_path: Path | None) -> _Resident:
    """The process that serves `node script` here, started if there is none (hold `_lock`)."""
    global _resident
    if _resident is not None and not _resident.serves(node, script, node_path):
        _stop_resident()
    if _resident is None:
        _resident = _Resident(node, script, node_path)
    return _resident


def _stop_resident(kill: bool = False) -> None:
    global _resident
    if _resident is not None:
        if kill and _resident.owner == os.getpid() and _resident.proc.poll() is None:
            os.killpg(_resident.proc.pid, signal.SIGKILL)
        _resident.stop()
        _resident = None


atexit.register(_stop_resident)
