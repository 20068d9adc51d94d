"""`python -m homemodel` for the extension's tests without each child's imports.

Every toolkit child the extension starts pays 1.5-2 CPU-s of imports (trimesh pulls in scipy and
networkx, the specs pydantic) before 0.1-1 CPU-s of work. Here a server imports the command line
and those libraries once and forks a worker per command; the worker runs the launcher
`python -m homemodel` runs, on the client's arguments, environment, working folder, stdout and
stderr. The client is the process the extension starts (its HOMEMODEL_COMMAND): it passes
SIGTERM and SIGINT on to its worker and ends as the worker ended (exit code or signal).
Blender (bpy) is never imported before a fork: a worker that builds imports it itself.

    python tests/toolkit_forkserver.py serve SOCKET       # started by `started()`
    python tests/toolkit_forkserver.py SOCKET ARGS...     # as `homemodel ARGS...`
"""

from __future__ import annotations

import json
import os
import select
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PRELOAD = (
    "homemodel.cli.commands", "trimesh", "scipy.spatial", "networkx", "homemodel.exchange.urdf.read",
    "homemodel.app.blender.model_document", "homemodel.app.blender.spec_forms", "homemodel.app.blender.home",
    "homemodel.model_folder.write", "homemodel.exchange.blender_glb", "modeller",
)
STOP = "stop"


def _worker(request: dict, out_fd: int, err_fd: int) -> None:
    """In the forked child: become `homemodel ARGS` of the client and end with its exit code."""
    import atexit

    os.dup2(out_fd, 1)
    os.dup2(err_fd, 2)
    null = os.open(os.devnull, os.O_RDONLY)
    os.dup2(null, 0)
    for fd in (out_fd, err_fd, null):
        os.close(fd)
    os.chdir(request["cwd"])
    os.environ.clear()
    os.environ.update(request["env"])
    sys.argv = ["homemodel", *request["args"]]
    code = 0
    try:
        from homemodel.cli.launcher import main

        main()
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        if not isinstance(exc.code, (int, type(None))):
            print(exc.code, file=sys.stderr)
    except BaseException:  # as Python ends on an uncaught exception
        import traceback

        traceback.print_exc()
        code = 1
    finally:
        atexit._run_exitfuncs()  # the toolkit's own (its resident glTF validator stops)
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)


def serve(path: Path) -> None:
    import importlib

    for name in PRELOAD:
        importlib.import_module(name)
    assert "bpy" not in sys.modules, "bpy must not be imported before a fork"
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    listener.bind(str(path))
    listener.listen(16)
    waiting: dict[int, socket.socket] = {}  # worker pid -> its client's connection
    stopping = False
    while not stopping or waiting:
        ready, _, _ = select.select([] if stopping else [listener], [], [], 0.1)
        while waiting:
            pid, status = os.waitpid(-1, os.WNOHANG)
            if pid == 0:
                break
            with waiting.pop(pid) as conn:
                try:
                    conn.sendall(f"{os.waitstatus_to_exitcode(status)}\n".encode())
                except OSError:  # the client was killed (SIGKILL): nobody to tell
                    pass
        if not ready:
            continue
        conn, _ = listener.accept()
        message, fds, _, _ = socket.recv_fds(conn, 1 << 20, 2)
        request = json.loads(message)
        if request == STOP:
            stopping = True
            conn.close()
            continue
        pid = os.fork()
        if pid == 0:
            listener.close()
            conn.close()
            _worker(request, *fds)
        for fd in fds:
            os.close(fd)
        try:
            conn.sendall(f"{pid}\n".encode())
        except OSError:
            pass
        waiting[pid] = conn
    listener.close()
    path.unlink()


def run(path: Path, args: list[str]) -> None:
    """The client: the worker runs `homemodel ARGS` on this process's output; end as it ended."""
    pending: list[int] = []
    worker: list[int] = []

    def forward(signum: int, _frame) -> None:
        if worker:
            os.kill(worker[0], signum)
        else:
            pending.append(signum)

    signal.signal(signal.SIGTERM, forward)
    signal.signal(signal.SIGINT, forward)
    conn = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    conn.connect(str(path))
    request = {"args": args, "env": dict(os.environ), "cwd": os.getcwd()}
    socket.send_fds(conn, [json.dumps(request).encode()], [1, 2])
    replies = conn.makefile("r")
    worker.append(int(replies.readline()))
    for signum in pending:
        os.kill(worker[0], signum)
    code = int(replies.readline())
    if code < 0:  # killed by a signal: so is this process, as `homemodel` itself would be
        signal.signal(-code, signal.SIG_DFL)
        os.kill(os.getpid(), -code)
    sys.exit(code)


@contextmanager
def started(socket_path: Path) -> Iterator[str]:
    """A server on `socket_path`; yields the HOMEMODEL_COMMAND of its clients. On leaving, the
    server ends once its workers have, and is waited for (so their CPU time is counted)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    server = subprocess.Popen([sys.executable, __file__, "serve", str(socket_path)], env=env)
    try:
        deadline = time.monotonic() + 120
        while not socket_path.exists():
            assert server.poll() is None and time.monotonic() < deadline, "the toolkit's fork server did not start"
            time.sleep(0.05)
        yield f"{sys.executable} {__file__} {socket_path}"
    finally:
        if server.poll() is None:
            with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as conn:
                conn.connect(str(socket_path))
                socket.send_fds(conn, [json.dumps(STOP).encode()], [])
        server.wait(timeout=120)


if __name__ == "__main__":
    if sys.argv[1] == "serve":
        serve(Path(sys.argv[2]))
    else:
        run(Path(sys.argv[1]), sys.argv[2:])
