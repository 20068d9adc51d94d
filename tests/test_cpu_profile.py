"""The suite's CPU profiler (tests/cpu_profile.py): a phase is charged the CPU its process and
its finished children spent, and the table sums each file's phases, the costliest first."""

from __future__ import annotations

import subprocess
import sys
import time

from cpu_profile import cpu_s, markdown, per_file


def _spin(seconds: float) -> None:
    end = time.process_time() + seconds
    while time.process_time() < end:
        pass


def test_cpu_counts_this_process_and_finished_children_but_not_sleep() -> None:
    start = cpu_s()
    time.sleep(0.3)
    assert cpu_s() - start < 0.1
    _spin(0.3)
    subprocess.run([sys.executable, "-c", "import time\nend = time.process_time() + 0.4\nwhile time.process_time() < end: pass"], check=True)
    assert 0.65 < cpu_s() - start < 2.0  # 0.3 here, 0.4 in the child, plus its start-up


def test_files_sum_their_phases_and_the_costliest_come_first() -> None:
    tests = {
        "tests/test_a.py::test_one": {"setup_cpu_s": 5.0, "call_cpu_s": 1.0, "teardown_cpu_s": 0.0},
        "tests/test_a.py::test_two": {"call_cpu_s": 2.0},
        "tests/test_b.py::test_three[x]": {"setup_cpu_s": 0.5, "call_cpu_s": 9.0, "teardown_cpu_s": 0.5},
    }
    rows = per_file(tests)
    assert [(path, count, total) for path, count, total, _ in rows] == [("tests/test_b.py", 1, 10.0), ("tests/test_a.py", 2, 8.0)]
    assert rows[1][3][0] == (5.0, "test_one setup")
    table = markdown(tests).splitlines()
    assert table[2].startswith("| test_b.py | 1 | 10.0 | test_three[x] call 9.0 |")
    assert table[-1] == "| **all** | 3 | 18.0 | |"
