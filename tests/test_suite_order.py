"""The suite's order under pytest-xdist: the longest test files first by their measured wall
time (durations.json), each kept whole, unmeasured files first; one worker more than cores."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest
from conftest import DURATIONS, bytecode_is_cold, longest_files_first, pytest_xdist_auto_num_workers
from cpu_profile import file_wall_s

TESTS = Path(__file__).resolve().parent


def test_the_durations_list_is_what_the_profiler_writes_and_names_test_files() -> None:
    """`make durations` writes it (tests/cpu_profile.py --durations): each test file's wall seconds."""
    wall = json.loads(DURATIONS.read_text())["file_wall_s"]
    assert len(wall) > 50 and all(name.startswith("test_") and name.endswith(".py") for name in wall)
    assert all(isinstance(s, float) and s >= 0 for s in wall.values())
    measured = [name for name in wall if (TESTS / name).is_file()]
    assert len(measured) >= 0.9 * len(wall), "most listed files are gone: run `make durations`"


def test_files_are_timed_by_summing_their_tests_phases() -> None:
    profile = {
        "tests/test_a.py::one": {"setup_wall_s": 5.0, "call_wall_s": 1.0, "setup_cpu_s": 9.0},
        "tests/test_a.py::two[x]": {"call_wall_s": 2.0, "teardown_wall_s": 0.5},
        "tests/test_b.py::three": {"call_wall_s": 30.0},
    }
    assert file_wall_s(profile) == {"test_b.py": 30.0, "test_a.py": 8.5}
    assert list(file_wall_s(profile)) == ["test_b.py", "test_a.py"]


def test_the_longest_files_go_first_unmeasured_ones_before_them_and_every_file_stays_whole() -> None:
    wall = {"test_short.py": 1.0, "test_long.py": 90.0, "test_mid.py": 20.0}
    names = ["test_mid.py", "test_long.py", "test_new.py", "test_short.py", "test_long.py", "test_mid.py"]
    items = [SimpleNamespace(path=TESTS / name, index=i) for i, name in enumerate(names)]
    longest_files_first(items, wall)
    assert [(item.path.name, item.index) for item in items] == [
        ("test_new.py", 2),
        ("test_long.py", 1),
        ("test_long.py", 4),
        ("test_mid.py", 0),
        ("test_mid.py", 5),
        ("test_short.py", 3),
    ]


def test_auto_gives_one_worker_more_than_cores_unless_told(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("PYTEST_XDIST_AUTO_NUM_WORKERS", raising=False)
    assert pytest_xdist_auto_num_workers(None) == len(os.sched_getaffinity(0)) + 1
    monkeypatch.setenv("PYTEST_XDIST_AUTO_NUM_WORKERS", "1")
    assert pytest_xdist_auto_num_workers(None) is None  # xdist's own hook reads the variable


def test_a_module_is_cold_until_its_bytecode_is_written(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The sign the workers wait on: a source without bytecode; never where none is written."""
    import importlib

    (tmp_path / "suite_order_fresh_module.py").write_text("VALUE = 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(sys, "dont_write_bytecode", False)
    assert bytecode_is_cold("suite_order_fresh_module")
    importlib.import_module("suite_order_fresh_module")
    monkeypatch.delitem(sys.modules, "suite_order_fresh_module")
    assert not bytecode_is_cold("suite_order_fresh_module")
    (tmp_path / "suite_order_other_module.py").write_text("VALUE = 2\n")
    monkeypatch.setattr(sys, "dont_write_bytecode", True)
    assert not bytecode_is_cold("suite_order_other_module")  # no worker would ever find its bytecode
    assert not bytecode_is_cold("math")  # built in: nothing to compile


def test_without_the_shared_data_its_tests_are_skipped_under_one_line(tmp_path: Path) -> None:
    """A checkout with no ../shared/data: every test that reads it (marked, or using the
    fixture) is skipped, none fails, and the summary says why in one line."""
    absent = tmp_path / "no-shared-data"
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTEST_", "HOMEMODEL_CPU_PROFILE"))}
    # The files that name the marker or the fixture (collecting all of them would cost 18 CPU-s, not 8).
    readers = [str(p) for p in sorted(TESTS.glob("test_*.py")) if p.name != Path(__file__).name and "shared_data" in p.read_text()]
    run = subprocess.run(
        [sys.executable, "-m", "pytest", *readers, "-m", "shared_data", "-q", "-rs", "-p", "no:xdist", "-p", "no:cacheprovider"],
        env={**env, "HOMEMODEL_SHARED_DATA": str(absent)}, cwd=TESTS.parent, capture_output=True, text=True, timeout=300,
    )
    output = run.stdout + run.stderr
    assert run.returncode == 0, output
    skipped = re.search(r"(\d+) skipped", output)
    assert skipped and int(skipped.group(1)) >= 10 and " passed" not in output and "failed" not in output, output
    lines = [line for line in output.splitlines() if line.startswith("SKIPPED")]
    assert len(lines) == 1 and f"needs the shared data folder {absent}" in lines[0] and "absent" in lines[0], output
    assert f"[{skipped.group(1)}]" in lines[0], output
