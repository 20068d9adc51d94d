"""Run a `homemodel` command as a user would, in a child process under a memory and a time
limit, and check the README's promise for bad input: the exit code, one line on stderr that
names the file, no traceback, and no output left behind."""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import traceback
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
MEMORY_LIMIT_BYTES = 4 * 1024**3  # the independent check's machine
TIME_LIMIT_S = 120.0


@dataclass
class Run:
    args: list[str]
    returncode: int
    stdout: str
    stderr: str

    @property
    def stderr_lines(self) -> list[str]:
        return [line for line in self.stderr.splitlines() if line.strip()]


def run_cli(*args: object, memory_bytes: int = MEMORY_LIMIT_BYTES, timeout_s: float = TIME_LIMIT_S,
            env: dict[str, str] | None = None, cwd: Path | None = None, file_size_bytes: int | None = None) -> Run:
    """`python -m homemodel ARGS` with RLIMIT_AS at `memory_bytes` (and RLIMIT_FSIZE at
    `file_size_bytes`: a disk that fills up); a run past `timeout_s` fails the test
    (subprocess.TimeoutExpired)."""

    def limit_memory() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (memory_bytes, memory_bytes))
        if file_size_bytes is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (file_size_bytes, file_size_bytes))

    argv = [str(a) for a in args]
    child_env = {**os.environ, "PYTHONPATH": str(REPO), **(env or {})}
    done = subprocess.run(
        [sys.executable, "-m", "homemodel", *argv], capture_output=True, text=True, timeout=timeout_s,
        preexec_fn=limit_memory, env=child_env, cwd=cwd,
    )
    return Run(argv, done.returncode, done.stdout, done.stderr)


def run_here(*args: object) -> Run:
    """`homemodel ARGS` in this process (typer's CliRunner): the same command code and messages
    without a child's 2-3 CPU-s of imports, for checks that need no process of their own. An
    unexpected exception's traceback is put in stderr, as the command line would not print it."""
    from typer.testing import CliRunner

    from homemodel.cli import app

    argv = [str(a) for a in args]
    result = CliRunner().invoke(app, argv)
    stderr = result.stderr
    if result.exc_info is not None and not isinstance(result.exception, SystemExit):
        stderr += "".join(traceback.format_exception(*result.exc_info))
    return Run(argv, result.exit_code, result.stdout, stderr)


def listing(folder: Path) -> set[str]:
    """Every path under `folder` (hidden ones too), to compare before and after a run."""
    return {str(p.relative_to(folder)) for p in Path(folder).rglob("*")}


def assert_refused(run: Run, *, names: object | None, exit_code: int = 2, out: Path | None = None,
                   watch: Path | None = None, before: set[str] | None = None) -> None:
    """The promise for a refused input: `exit_code`, exactly one line on stderr, starting
    `error:`, naming `names` (a path or text), no traceback; `out` not created; and nothing
    new under `watch` (compared with `before`, its `listing` before the run)."""
    context = f"homemodel {' '.join(run.args)}\nstdout: {run.stdout[-2000:]}\nstderr: {run.stderr[-3000:]}"
    assert run.returncode == exit_code, context
    assert "Traceback" not in run.stderr and "Traceback" not in run.stdout, context
    assert len(run.stderr_lines) == 1, context
    assert run.stderr_lines[0].startswith("error: "), context
    if names is not None:
        assert str(names) in run.stderr_lines[0], context
    if out is not None:
        assert not Path(out).exists(), context
    if watch is not None:
        assert listing(watch) == (before or set()), context
