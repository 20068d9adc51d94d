"""The command ends without the interpreter's teardown (0.20 CPU-s of a completion query's 2.6):
its exit handlers still run, its output is all written, its exit code is kept."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from cli_promise import REPO

# Imported by site at start-up: an exit handler registered before any of the command's, so it
# runs last, and an object that only the teardown would delete.
_SITECUSTOMIZE = """
import atexit, os
marks = os.environ["EXIT_MARKS"]
atexit.register(lambda: open(os.path.join(marks, "exit_handlers_ran"), "w").close())

class _Teardown:
    # What it calls is bound now: the teardown clears the modules' names before it deletes this.
    def __del__(self, touch=os.open, close=os.close, mark=os.path.join(marks, "teardown_ran"),
                flags=os.O_CREAT | os.O_WRONLY):
        close(touch(mark, flags))

kept_until_the_teardown = _Teardown()
"""


def _run(tmp_path: Path, *args: object) -> tuple[subprocess.CompletedProcess, list[str]]:
    site = tmp_path / "site"
    marks = tmp_path / "marks"
    site.mkdir(parents=True)
    marks.mkdir()
    (site / "sitecustomize.py").write_text(_SITECUSTOMIZE)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(site), str(REPO)]), "EXIT_MARKS": str(marks)}
    done = subprocess.run([sys.executable, "-m", "homemodel", *map(str, args)], capture_output=True, text=True,
                          cwd=REPO, env=env, timeout=120)
    return done, sorted(p.name for p in marks.iterdir())


def test_the_command_ends_after_its_exit_handlers_without_the_teardown(tmp_path: Path) -> None:
    done, marks = _run(tmp_path, "turntable", "board", "--out", tmp_path / "board")
    assert done.returncode == 0, done.stderr
    assert marks == ["exit_handlers_ran"]
    assert str(tmp_path / "board") in done.stdout  # its last line, written before the end
    refused, marks = _run(tmp_path / "again", "turntable", "board", "--out", tmp_path / "board")
    assert refused.returncode == 2 and "not empty" in refused.stderr, refused.stderr
    assert marks == ["exit_handlers_ran"]
