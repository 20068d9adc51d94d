"""CPU seconds per test phase, for finding where the suite's time goes on a loaded machine
(wall time there says little). Off by default; `HOMEMODEL_CPU_PROFILE=out.json pytest ...`
turns it on (conftest loads this plugin). Each phase (setup, call, teardown) is charged the
user+sys CPU of the process and of its finished child processes (Blender, the CLI in a
subprocess), with its wall time beside; each process also reports what its start-up and
collection cost before the first test. Under pytest-xdist the workers send their records to
the controller, which writes one file.

`python tests/cpu_profile.py out.json [more.json ...]` prints the per-file table in Markdown;
`python tests/cpu_profile.py --durations tests/durations.json out.json` writes each file's wall
seconds, the order conftest.py runs the files in (`make durations` does both, cold)."""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import time
from collections import defaultdict
from collections.abc import Iterator
from pathlib import Path

import pytest

ENV = "HOMEMODEL_CPU_PROFILE"
PHASES = ("setup", "call", "teardown")


def cpu_s() -> float:
    """User+sys CPU of this process and of its children that have been waited for."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


class CpuProfile:
    def __init__(self, out: Path) -> None:
        self.out = out
        self.tests: dict[str, dict[str, float]] = defaultdict(dict)
        self.processes: list[dict[str, object]] = []

    @pytest.hookimpl(trylast=True)
    def pytest_collection_finish(self, session: pytest.Session) -> None:
        # Interpreter start, imports of every test module and collection, before any test.
        self.processes.append({"worker": os.environ.get("PYTEST_XDIST_WORKER", "main"), "startup_cpu_s": round(cpu_s(), 2)})

    def _phase(self, item: pytest.Item, phase: str) -> Iterator[None]:
        cpu0, wall0 = cpu_s(), time.perf_counter()
        yield
        record = self.tests[item.nodeid]
        record[f"{phase}_cpu_s"] = round(cpu_s() - cpu0, 3)
        record[f"{phase}_wall_s"] = round(time.perf_counter() - wall0, 3)

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_setup(self, item: pytest.Item) -> Iterator[None]:
        yield from self._phase(item, "setup")

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_call(self, item: pytest.Item) -> Iterator[None]:
        yield from self._phase(item, "call")

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_teardown(self, item: pytest.Item) -> Iterator[None]:
        yield from self._phase(item, "teardown")

    @pytest.hookimpl(optionalhook=True)
    def pytest_testnodedown(self, node, error) -> None:  # noqa: ANN001 (xdist's WorkerController)
        sent = getattr(node, "workeroutput", {}).get("cpu_profile")
        if sent:
            self.tests.update(sent["tests"])
            self.processes.extend(sent["processes"])

    @pytest.hookimpl(trylast=True)
    def pytest_sessionfinish(self, session: pytest.Session) -> None:
        data = {"tests": dict(self.tests), "processes": self.processes}
        workeroutput = getattr(session.config, "workeroutput", None)
        if workeroutput is not None:  # an xdist worker: the controller writes the file
            workeroutput["cpu_profile"] = data
            return
        self.out.parent.mkdir(parents=True, exist_ok=True)
        tmp = self.out.with_suffix(".tmp")
        tmp.write_text(json.dumps(data, indent=1, sort_keys=True))
        tmp.replace(self.out)


def pytest_configure(config: pytest.Config) -> None:
    out = os.environ.get(ENV)
    if out:
        config.pluginmanager.register(CpuProfile(Path(out)), "homemodel_cpu_profile")


def per_file(tests: dict[str, dict[str, float]]) -> list[tuple[str, int, float, list[tuple[float, str]]]]:
    """(file, tests, CPU-s, [(CPU-s, test::phase)] largest first) per file, the costliest first."""
    files: dict[str, list[tuple[float, str]]] = defaultdict(list)
    counts: dict[str, int] = defaultdict(int)
    for nodeid, record in tests.items():
        path, _, name = nodeid.partition("::")
        counts[path] += 1
        for phase in PHASES:
            files[path].append((record.get(f"{phase}_cpu_s", 0.0), f"{name} {phase}"))
    rows = [(path, counts[path], sum(c for c, _ in phases), sorted(phases, reverse=True)) for path, phases in files.items()]
    return sorted(rows, key=lambda row: -row[2])


def markdown(tests: dict[str, dict[str, float]], top: int = 3, min_cpu_s: float = 1.0) -> str:
    lines = ["| file | tests | CPU-s | costliest phases (CPU-s) |", "| --- | ---: | ---: | --- |"]
    for path, count, total, phases in per_file(tests):
        slow = "; ".join(f"{name} {cpu:.1f}" for cpu, name in phases[:top] if cpu >= min_cpu_s)
        lines.append(f"| {path.removeprefix('tests/')} | {count} | {total:.1f} | {slow} |")
    lines.append(f"| **all** | {len(tests)} | {sum(r[2] for r in per_file(tests)):.1f} | |")
    return "\n".join(lines)


def file_wall_s(tests: dict[str, dict[str, float]]) -> dict[str, float]:
    """Each test file's wall seconds (its tests' phases summed), by its name in tests/, the longest first."""
    files: dict[str, float] = defaultdict(float)
    for nodeid, record in tests.items():
        files[Path(nodeid.partition("::")[0]).name] += sum(record.get(f"{phase}_wall_s", 0.0) for phase in PHASES)
    return {name: round(wall, 1) for name, wall in sorted(files.items(), key=lambda item: (-item[1], item[0]))}


def write_durations(out: Path, tests: dict[str, dict[str, float]]) -> None:
    tmp = out.with_suffix(".tmp")
    tmp.write_text(json.dumps({"file_wall_s": file_wall_s(tests)}, indent=1) + "\n")
    tmp.replace(out)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description="The per-file table of CPU profiles, or the durations list.")
    parser.add_argument("profiles", nargs="+", type=Path)
    parser.add_argument("--durations", type=Path, help="write each file's wall seconds here instead")
    args = parser.parse_args()
    merged: dict[str, dict[str, float]] = {}
    for profile in args.profiles:
        merged.update(json.loads(profile.read_text())["tests"])
    if args.durations:
        write_durations(args.durations, merged)
    else:
        print(markdown(merged))
