"""The suite's order under pytest-xdist: the longest test files first, each kept whole (conftest)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

from conftest import LONGEST_FIRST, longest_files_first

TESTS = Path(__file__).resolve().parent


def test_every_file_named_longest_first_is_a_test_file() -> None:
    """A renamed or removed file would silently drop back to name order."""
    missing = [name for name in LONGEST_FIRST if not (TESTS / name).is_file()]
    assert not missing, missing
    assert len(set(LONGEST_FIRST)) == len(LONGEST_FIRST)


def test_the_longest_files_go_first_and_every_file_stays_whole_and_in_order() -> None:
    names = ["test_a.py", "test_a.py", LONGEST_FIRST[1], LONGEST_FIRST[1], "test_b.py", LONGEST_FIRST[0]]
    items = [SimpleNamespace(path=TESTS / name, index=i) for i, name in enumerate(names)]
    longest_files_first(items)
    assert [(item.path.name, item.index) for item in items] == [
        (LONGEST_FIRST[0], 5),
        (LONGEST_FIRST[1], 2),
        (LONGEST_FIRST[1], 3),
        ("test_a.py", 0),
        ("test_a.py", 1),
        ("test_b.py", 4),
    ]


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
