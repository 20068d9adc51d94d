"""Benchmark: `homemodel db build` (a local build: its own process and worker processes, no
Dask) against a plain serial loop, cached rebuilds, and a mixed manifest of every source.

1. Throughput: N generated spec entries (a cup swept over heights and diameters; with
   `--spec cupboard`, the catalogue's kitchen base unit with 5 joints, over depths and masses) built by the
   database with 2 processes building (`homemodel db build --workers 2`, the command itself,
   run in the child process: the command's own process from its start, and one worker process
   started beside it), against the same entries built one after the other by a plain loop of
   `modeller.build` (the swept spec written, then built: the pipeline, its export and the
   validation gate, the work each database entry does before its own), in the same run.
   Each side runs in a fresh `python` process and is timed from its start to its exit, so
   each pays its interpreter start and its imports (bpy, the modeller, the gate's clients: once
   in the loop, once in each building process, in parallel), and the database its cluster's
   start. Start-up is the time from the process's start (before the interpreter's) to its
   first entry's start, the entry's imports done; its CPU seconds then are given too (on a
   loaded machine they stand for an idle machine's wall time).
   What the database adds per entry ("overhead") is given three ways:
   - after start-up: a worker's time per entry (workers x the time from the first entry's
     start to the last one's end, / N) minus the loop's time per entry (its loop, / N).
     This is the thumbnail, the entry record, the atomic store, the dispatch to the worker, the index
     row and the two workers' contention for the machine; the thumbnail's share and the
     entries' time outside their stages' clocks are listed too (from the index's times).
     The same figure for the loops side by side is the machine's share (two processes slow
     each other); the database's minus theirs is what the database itself adds;
   - all in: (workers x database wall time - serial wall time) / N, which also spreads the
     database's start-up (the client's imports, the cluster, the workers' imports in
     parallel) over the N entries;
   - in CPU time, all in: (the database's CPU seconds - the loop's) / N, every process
     counted (the command, its worker, the gate's tools). Unlike the wall-time figures it
     barely moves when other jobs share the machine: it is what the database costs, not
     what it was given;
   - in CPU time, after start-up: each side also builds the first SMALL entries alone, and
     (CPU(N) - CPU(SMALL)) / (N - SMALL) is its CPU per further entry, start-up (imports,
     the cluster, the workers' warm-up) cancelled out; the database's minus the loop's is
     what it adds per entry. CPU(SMALL) less SMALL such entries is the start-up's CPU;
   - in CPU time, in one process: the loop's entry and the database's (`build_entry`: the
     pipeline, thumbnail, record, atomic store) built alternately in one warm process, the
     median difference: the steadiest figure (no imports, no Dask, no second process). Both
     with one thread per numeric library, as the database's processes build; the loop's entry
     with OpenBLAS's default (a thread per core, as a plain process has) is given too.
   Each round also runs the database with one process building (`--workers 1`: one
   worker, the command only records): the second process's speed-up is its time over the
   two-process database's, beside two plain loops' over the serial loop.
   The three (serial loop, loops side by side, database) run in interleaved rounds (every
   other round the database before the loops side by side), and the table gives each
   figure's median and each round's speed-up: the machine is a shared host whose speed drifts
   by tens of percent from minute to minute. The database's speed-up over two plain
   processes' is taken within each round (their two runs are next to each other) and given
   as the median of the rounds with its range.
   The same figures are given for 2 plain loops started side by side, each a fresh process
   building half the entries: no Dask, no database, just two processes, so their speed-up
   is what this machine gives two processes at best (on a shared or hyperthreaded machine
   well under 2x), the ceiling to judge the database's against.
2. A rebuild with nothing changed, and after one spec file changed (only that entry built),
   both by the same command.
3. The mixed manifest of examples/database (specs, a sweep, a simulated turntable capture, the
   shared Kermit photos, a completion query, an imported PartNet-style URDF): every entry
   built or recorded as failed, and the time per source.

With `--baseline-src DIR` (another checkout, e.g. `git worktree add /tmp/old HEAD~3`), the
database side is also run, in the same rounds, with that checkout's code: old and new on the
same machine at the same time.

Run: .venv/bin/python benchmarks/bench_database.py [--spec cup|cupboard] [--entries 200] [--rounds 3]
     [--baseline-src DIR] [--skip-mixed | --only-mixed]
"""

from __future__ import annotations

# Only what both sides' child processes need is imported at the top: each child's start-up is
# measured, and neither side may be charged the other's imports (rich; Dask in a baseline's code).
import argparse
import functools
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path
from typing import TYPE_CHECKING

import yaml

if TYPE_CHECKING:
    from rich.console import Console

ROOT = Path(__file__).resolve().parent.parent
CATALOGUE = ROOT / "examples" / "catalogue"
MIXED = ROOT / "examples" / "database" / "manifest.yaml"
WORKERS = 2
# Each generated entry is a catalogue spec with two of its fields swept (name, first value,
# step): PER_SIDE values of the first, entries / PER_SIDE of the second.
SWEEPS = {
    "cup": (("height_m", 0.075, 0.002), ("outer_diameter_m", 0.08, 0.002)),
    "cupboard": (("depth_m", 0.56, 0.002), ("mass_kg", 40.0, 1.0)),
}
PER_SIDE = 20
SMALL = PER_SIDE  # entries of the runs that measure start-up (one row of the sweep)
PER_ENTRY_PAIRS = 16  # entries built by each side, alternating, in one process


def _manifest(folder: Path, kind: str, entries: int) -> tuple[Path, Path]:
    """A manifest of `entries` generated entries of the catalogue's `kind`, and its spec."""
    folder.mkdir(parents=True, exist_ok=True)
    spec = folder / f"{kind}.yaml"
    spec.write_text((CATALOGUE / f"{kind}.yaml").read_text())
    (first, start_1, step_1), (second, start_2, step_2) = SWEEPS[kind]
    sweep = {
        first: [round(start_1 + step_1 * i, 4) for i in range(PER_SIDE)],
        second: [round(start_2 + step_2 * i, 4) for i in range(entries // PER_SIDE)],
    }
    manifest = folder / "manifest.yaml"
    manifest.write_text(yaml.safe_dump({"entries": [{"id": kind, "source": "spec", "path": spec.name, "sweep": sweep}]}))
    return manifest, spec


def _since(t0: float) -> float:
    return time.time() - t0


def serial_loop(manifest: Path, out: Path, t0: float, part: str = "0/1") -> dict:
    """The same entries, one after the other, in this process: write the swept spec, build it
    (with `part` "i/n", only every n-th entry from the i-th). Returns when its imports were
    done and the time of the loop itself (seconds)."""
    from homemodel.app.database.manifest import load_manifest
    from homemodel.app.database.warm_up import warm_up
    from modeller import BuildOptions, build

    warm_up(("spec",))  # what the database's building processes import before their first entry
    ready_s, ready_cpu_s = _since(t0), _own_cpu_s()
    first, step = map(int, part.split("/"))
    jobs = load_manifest(manifest)[0][first::step]
    base = yaml.safe_load(jobs[0].inputs["path"].read_text())
    out.mkdir(parents=True, exist_ok=True)
    for job in jobs:
        spec = out / f"{job.id}.yaml"
        spec.write_text(yaml.safe_dump({**base, **job.overrides}))
        build(spec, out / job.id, BuildOptions(name=job.id))
    return {"startup_s": ready_s, "startup_cpu_s": ready_cpu_s, "entries_s": _since(t0) - ready_s}


def database_build(manifest: Path, db: Path, t0: float, workers: str = str(WORKERS)) -> dict:
    """`homemodel db build MANIFEST --db DB --workers 2` (or `workers`), the command itself, run in this
    process. Returns when its first entry started (with this process's CPU seconds then) and
    the time from then to the last entry's end."""
    from homemodel.cli.launcher import main

    ends: list[tuple[float, str, float]] = []
    here = _note_first_entry_here(t0)
    _note_rows(ends, t0)
    sys.argv = ["homemodel", "db", "build", str(manifest), "--db", str(db), "--workers", workers]
    try:
        main()
    except SystemExit as done:
        if done.code:
            raise
    # The rows of one task (a batch of entries) arrive together: a task started at its end
    # less all of its entries' times.
    starts, group_end, group_worker, group_s = [], None, None, 0.0
    for end, worker, build_s in ends:
        if group_end is None or worker != group_worker or end - group_end > 0.05:
            starts.append(end - build_s)
            group_end, group_worker, group_s = end, worker, build_s
        else:
            group_s += build_s
            starts[-1] = group_end - group_s
    first_start = min(starts)
    return {"startup_s": first_start, "entries_s": max(end for end, _, _ in ends) - first_start, **here}


def per_entry(manifest: Path, out: Path, t0: float, pairs: str = str(PER_ENTRY_PAIRS)) -> dict:
    """CPU seconds of an entry built by the plain loop's code and by the database's
    (`build_entry`: the pipeline, thumbnail, record, atomic store), alternating in this one
    warm process, so that imports, Dask and the machine's load drop out: what the database adds
    to each entry after start-up. Medians of `pairs` pairs, after one of each as warm-up."""
    from homemodel.app.database.build_request import BuildRequest
    from homemodel.app.database.entry_build import build_entry
    from homemodel.app.database.manifest import load_manifest
    from homemodel.app.database.warm_up import warm_up
    from modeller import BuildOptions, build

    warm_up(("spec",))
    jobs = load_manifest(manifest)[0]
    base = yaml.safe_load(jobs[0].inputs["path"].read_text())
    loop_dir, db = out / "loop", (out / "db").resolve()
    loop_dir.mkdir(parents=True, exist_ok=True)

    def loop_entry(job, folder: Path = loop_dir) -> None:  # noqa: ANN001 (a manifest Job)
        folder.mkdir(exist_ok=True)
        spec = folder / f"{job.id}.yaml"
        spec.write_text(yaml.safe_dump({**base, **job.overrides}))
        build(spec, folder / job.id, BuildOptions(name=job.id))

    def db_entry(job) -> None:  # noqa: ANN001
        row = build_entry(BuildRequest(job=job, key="bench", db_dir=db, repair=None), c_output_fds=(2,))
        if row.status != "valid":
            raise RuntimeError(f"{job.id}: {row.status}: {row.error}")

    from threadpoolctl import threadpool_limits

    # Both sides with one thread per numeric library, as the database's building processes
    # have; the loop also as a plain process has it (OpenBLAS's thread per core), for the
    # difference that makes.
    default_threads = functools.partial(loop_entry, folder=out / "loop_default_threads")
    sides = {"loop": (loop_entry, 1), "db": (db_entry, 1), "loop_default_threads": (default_threads, None)}
    cpu: dict[str, list[float]] = {side: [] for side in sides}
    for i, job in enumerate(jobs[: int(pairs) + 1]):
        # Each pair in turn starts with another side: none always runs on a warmer cache.
        for side in list(sides)[i % 3 :] + list(sides)[: i % 3]:
            run, threads = sides[side]
            with threadpool_limits(limits=threads):
                start = time.process_time()
                run(job)
                spent = time.process_time() - start
            if i:  # the first pair warms up (the thumbnail's camera, cv2's first encode)
                cpu[side].append(spent)
    return {side: statistics.median(times) for side, times in cpu.items()} | {"pairs": int(pairs)}


def _own_cpu_s() -> float:
    """CPU seconds (user + system) of this process so far, all its threads."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _note_first_entry_here(t0: float) -> dict:
    """Fills in, when the command's own process starts its first entry (its imports done),
    the seconds since `t0` and its CPU seconds so far: its start-up, which a loaded machine
    stretches in wall time but barely in CPU. (The build imports this module before its first
    entry anyway.) Empty for code whose own process builds nothing."""
    noted: dict = {}
    try:
        from homemodel.app.database.dispatch import Dispatch
    except ImportError:  # a baseline's code: its own process builds nothing
        return noted
    build_here = Dispatch._build_here

    def first_noted(self, request):  # noqa: ANN001, ANN202
        noted.setdefault("startup_s", _since(t0))
        noted.setdefault("startup_cpu_s", _own_cpu_s())
        return build_here(self, request)

    Dispatch._build_here = first_noted
    return noted


def _note_rows(ends: list, t0: float) -> None:
    """Appends (seconds since `t0`, worker, build seconds) to `ends` as each row is recorded."""
    from homemodel.app.database import build

    settle = build._settle

    def noted(index, row, commit):  # noqa: ANN001, ANN202
        ends.append((_since(t0), row.worker, row.build_s))
        return settle(index, row, commit)

    build._settle = noted


def _children_cpu_s() -> float:
    """CPU seconds (user + system) of the child processes waited for so far, and of theirs."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _run_timed(*args: str | Path, source: Path = ROOT) -> tuple[float, str]:
    """Wall seconds of a fresh `python ARGS...` of the code in `source` (this checkout's by
    default), and what it printed."""
    # Another checkout may have no node_modules of its own: the glTF validator is this one's.
    env = {"HOMEMODEL_NODE_MODULES": str(ROOT / "tools" / "node_modules"), **os.environ, "PYTHONPATH": str(source), "COLUMNS": "200"}
    start = time.perf_counter()
    done = subprocess.run([sys.executable, *map(str, args)], env=env, capture_output=True, text=True, check=False)
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"{args} exited {done.returncode}:\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}")
    return seconds, done.stdout + done.stderr


def _reported(said: str) -> dict:
    """The timings a child of this script printed: its last JSON line (Dask's warnings on a
    busy machine, "event loop unresponsive", may follow it on stderr)."""
    return json.loads(next(line for line in reversed(said.splitlines()) if line.startswith("{")))


def _run_child(mode: str, manifest: Path, out: Path, source: Path = ROOT, *more: str) -> tuple[float, dict]:
    """Wall seconds of this script's `mode` in a fresh process (of the code in `source`), and
    the timings it reports, with the CPU seconds of the process and all of its own (its
    workers, the gate's tools)."""
    cpu_before = _children_cpu_s()
    seconds, said = _run_timed(__file__, mode, manifest, out, f"{time.time():.6f}", *more, source=source)
    return seconds, {**_reported(said), "cpu_s": _children_cpu_s() - cpu_before}


def _loops_side_by_side(manifest: Path, out: Path) -> tuple[float, float, float]:
    """Wall and CPU seconds of WORKERS plain loops started together, each a fresh process
    building its share of the entries: what this machine gives WORKERS processes at best; and
    the seconds from the first loop's first entry to the last loop's last."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cpu_before, start, t0 = _children_cpu_s(), time.perf_counter(), time.time()
    loops = [
        subprocess.Popen([sys.executable, __file__, "--serial-loop", manifest, out / str(i), f"{t0:.6f}", f"{i}/{WORKERS}"],
                         env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        for i in range(WORKERS)
    ]  # fmt: skip
    timings = []
    for loop in loops:
        said, complained = loop.communicate()
        if loop.returncode != 0:
            raise RuntimeError(f"a side-by-side loop exited {loop.returncode}:\n{complained[-2000:]}")
        timings.append(_reported(said))
    entries_s = max(t["startup_s"] + t["entries_s"] for t in timings) - min(t["startup_s"] for t in timings)
    return time.perf_counter() - start, _children_cpu_s() - cpu_before, entries_s


def _db_build(manifest: Path, db: Path) -> tuple[float, str]:
    return _run_timed("-m", "homemodel", "db", "build", manifest, "--db", db, "--workers", WORKERS)


def _load() -> str:
    return " ".join(f"{v:.2f}" for v in os.getloadavg())


def _one_round(manifest: Path, small: Path, folder: Path, baseline: Path | None, flip: bool) -> dict:
    """The serial loop, the loops side by side and the database build, one after the other
    (with `flip`, the database before the loops side by side: their ratio is taken within a
    round, and a drifting machine must not favour the one that always runs second); then the
    loop and the database (and the baseline's) on the SMALL entries alone."""
    from homemodel.app.database import ModelIndex

    serial_s, serial = _run_child("--serial-loop", manifest, folder / "serial")
    if flip:
        db_s, built = _run_child("--db-build", manifest, folder / "db")
    side_s, side_cpu_s, side_entries_s = _loops_side_by_side(manifest, folder / "side")
    if not flip:
        db_s, built = _run_child("--db-build", manifest, folder / "db")
    # The database with one process building (`--workers 1`: one worker, the command records).
    one_s = _run_child("--db-build", manifest, folder / "db_one", ROOT, "1")[0]
    with ModelIndex(folder / "db") as index:
        rows = index.rows()
    run = {"serial_s": serial_s, "serial": serial, "serial_cpu": serial["cpu_s"], "side_s": side_s, "side_cpu_s": side_cpu_s,
           "side_entries_s": side_entries_s, "db_s": db_s, "built": built, "db_cpu": built["cpu_s"], "rows": rows,
           "one_s": one_s}  # fmt: skip
    run["serial_small_cpu"] = _run_child("--serial-loop", small, folder / "serial_small")[1]["cpu_s"]
    run["db_small_cpu"] = _run_child("--db-build", small, folder / "db_small")[1]["cpu_s"]
    if baseline is not None:
        run["old_s"], old = _run_child("--db-build", manifest, folder / "old", baseline)
        run["old"], run["old_cpu"] = old, old["cpu_s"]
        run["old_small_cpu"] = _run_child("--db-build", small, folder / "old_small", baseline)[1]["cpu_s"]
    return run


def throughput(kind: str, entries: int, rounds: int, console: Console, baseline: Path | None = None) -> None:
    from rich.table import Table

    with tempfile.TemporaryDirectory(prefix="bench-db-") as tmp:
        folder = Path(tmp)
        manifest, spec = _manifest(folder, kind, entries)
        small, _ = _manifest(folder / "small", kind, SMALL)
        load_before = _load()
        # The rounds interleave the sides: this machine's speed drifts (a shared host), and a
        # side measured only early or only late would gain or lose by it.
        runs = [_one_round(manifest, small, folder / f"round{r}", baseline, flip=r % 2 == 1) for r in range(rounds)]
        load_after = _load()
        db = folder / f"round{rounds - 1}" / "db"
        rows = runs[-1]["rows"]
        problems = [f"{r.id}: {r.status}: {r.error or '; '.join(r.failed_checks)}" for r in rows if r.status != "valid"]
        thumbnail_s = sum(r.times_s["thumbnail"] for r in rows)
        # An entry's time outside its stages' clocks: the swept spec, the record, the atomic
        # store (and the modeller's own steps outside its clock, which the loop does too).
        untimed_s = sum(r.build_s - sum(r.times_s.values()) for r in rows)
        one_process = _run_child("--per-entry", small, folder / "per_entry")[1]
        nothing_s, nothing = _db_build(manifest, db)
        # One more entry with a spec file of its own, built once; then only its file changes.
        single = folder / "single.yaml"
        single.write_text(spec.read_text())
        data = yaml.safe_load(manifest.read_text())
        data["entries"].append({"id": "lonely", "source": "spec", "path": "single.yaml"})
        manifest.write_text(yaml.safe_dump(data))
        _db_build(manifest, db)
        single.write_text(spec.read_text().replace("colour: white", "colour: red"))
        one_s, one = _db_build(manifest, db)

    def median(figure) -> float:  # noqa: ANN001 (a function of one round's figures)
        return statistics.median(figure(run) for run in runs)

    serial_s, side_s, db_s = median(lambda r: r["serial_s"]), median(lambda r: r["side_s"]), median(lambda r: r["db_s"])
    serial_entries_s, db_entries_s = median(lambda r: r["serial"]["entries_s"]), median(lambda r: r["built"]["entries_s"])
    serial_cpu_s, side_cpu_s, db_cpu_s = (median(lambda r, k=k: r[k]) for k in ("serial_cpu", "side_cpu_s", "db_cpu"))
    side_entries_s = median(lambda r: r["side_entries_s"])
    serial_entry_s = serial_entries_s / entries
    side_entry_s, db_entry_s = (WORKERS * span / entries for span in (side_entries_s, db_entries_s))  # a process's time per entry
    title = f"{entries} {kind} entries: the database ({WORKERS} processes: its own and worker processes) vs plain loops, median of {rounds} rounds (load {load_before} -> {load_after})"
    table = Table(title=title)
    table.add_column("figure")
    table.add_column("serial loop", justify="right")
    table.add_column(f"{WORKERS} loops side by side", justify="right")
    table.add_column("database", justify="right")
    table.add_row("wall time, fresh processes to exit", f"{serial_s:.1f} s", f"{side_s:.1f} s", f"{db_s:.1f} s")
    table.add_row("  [bold]start-up: process start to first entry started (wall; aim < 3 s)", f"{median(lambda r: r['serial']['startup_s']):.2f} s", "", f"[bold]{median(lambda r: r['built']['startup_s']):.2f} s")
    here_cpu = [r["built"]["startup_cpu_s"] for r in runs if "startup_cpu_s" in r["built"]]
    table.add_row("  start-up CPU of the process building first, to its first entry (~ idle wall)",
                  f"{median(lambda r: r['serial']['startup_cpu_s']):.2f} s", "", f"{statistics.median(here_cpu):.2f} s" if here_cpu else "-")  # fmt: skip
    table.add_row("  the entries (first start to last end)", f"{serial_entries_s:.1f} s", f"{side_entries_s:.1f} s", f"{db_entries_s:.1f} s")
    table.add_row("time per entry (side by side, database: x processes)", f"{1000 * serial_entry_s:.0f} ms", f"{1000 * side_entry_s:.0f} ms", f"{1000 * db_entry_s:.0f} ms")
    table.add_row("CPU time, every process (user + system)", f"{serial_cpu_s:.1f} s", f"{side_cpu_s:.1f} s", f"{db_cpu_s:.1f} s")
    table.add_row("entries valid / built (last round)", "", "", f"{entries - len(problems)} / {len(rows)}")
    ratios = "  ".join(f"{r['serial_s'] / r['db_s']:.2f}x" for r in runs)
    side_ratios = "  ".join(f"{r['serial_s'] / r['side_s']:.2f}x" for r in runs)
    table.add_row("speed-up, wall time, each round (serial / this)", "", side_ratios, ratios)
    table.add_row("[bold]speed-up, wall time (medians)", "", f"{serial_s / side_s:.2f}x", f"[bold]{serial_s / db_s:.2f}x")
    table.add_row("database with 1 process building (--workers 1), wall, each round", "", "", "  ".join(f"{r['one_s']:.1f} s" for r in runs))
    table.add_row("[bold]the second process's speed-up (database --workers 1 / --workers 2), each round", "",
                  "  ".join(f"{r['serial_s'] / r['side_s']:.2f}x" for r in runs), "[bold]" + "  ".join(f"{r['one_s'] / r['db_s']:.2f}x" for r in runs))  # fmt: skip
    # The aim: the database within 10 % of what two plain processes get on this machine. Each
    # round's two runs are minutes apart at most: their ratio drifts less than either.
    paired = [r["side_s"] / r["db_s"] for r in runs]
    table.add_row("database's speed-up / two plain processes', each round (side by side / database)", "", "",
                  "  ".join(f"{p:.2f}" for p in paired))  # fmt: skip
    table.add_row("[bold]database's speed-up / two plain processes' (median of the rounds; aim >= 0.90)", "", "",
                  f"[bold]{statistics.median(paired):.2f}[/] (range {min(paired):.2f}-{max(paired):.2f})")  # fmt: skip
    table.add_row("[bold]overhead per entry, after start-up", "", f"{1000 * (side_entry_s - serial_entry_s):.0f} ms", f"[bold]{1000 * (db_entry_s - serial_entry_s):.0f} ms")
    table.add_row("  of which beyond two plain processes' (database - side by side)", "", "", f"{1000 * (db_entry_s - side_entry_s):.0f} ms")
    table.add_row("  in the entries: the thumbnail", "", "", f"{1000 * thumbnail_s / entries:.0f} ms")
    table.add_row("  in the entries: outside the stages' clocks", "", "", f"{1000 * untimed_s / entries:.0f} ms")
    table.add_row("overhead per entry, all in: (workers x wall - serial wall) / N", "", f"{1000 * (WORKERS * side_s - serial_s) / entries:.0f} ms", f"{1000 * (WORKERS * db_s - serial_s) / entries:.0f} ms")
    table.add_row("overhead per entry in CPU time, all in: (CPU - CPU serial) / N", "", f"{1000 * (side_cpu_s - serial_cpu_s) / entries:.0f} ms", f"{1000 * (db_cpu_s - serial_cpu_s) / entries:.0f} ms")
    # After start-up, in CPU time: the SMALL-entry runs cancel each side's start-up out.
    serial_per_s = median(lambda r: (r["serial_cpu"] - r["serial_small_cpu"]) / (entries - SMALL))
    db_per_s = median(lambda r: (r["db_cpu"] - r["db_small_cpu"]) / (entries - SMALL))
    table.add_row(f"CPU per further entry: (CPU(N) - CPU({SMALL})) / (N - {SMALL})", f"{1000 * serial_per_s:.0f} ms", "", f"{1000 * db_per_s:.0f} ms")
    table.add_row("[bold]overhead per entry after start-up, CPU (database - loop; aim < 30 ms)", "", "", f"[bold]{1000 * (db_per_s - serial_per_s):.0f} ms")
    table.add_row(f"[bold]overhead per entry after start-up, CPU, in one process (database's entry - loop's, median of {one_process['pairs']} alternating; aim < 30 ms)",
                  f"{1000 * one_process['loop']:.0f} ms", "", f"[bold]{1000 * (one_process['db'] - one_process['loop']):.0f} ms[/] ({1000 * one_process['db']:.0f} ms an entry)")  # fmt: skip
    table.add_row("  the loop's entry with OpenBLAS's default threads (a plain process's; the database's use one)",
                  f"{1000 * one_process['loop_default_threads']:.0f} ms", "", "")  # fmt: skip
    table.add_row(f"start-up CPU: CPU({SMALL}) - {SMALL} x CPU per further entry", f"{median(lambda r: r['serial_small_cpu']) - SMALL * serial_per_s:.1f} s", "",
                  f"{median(lambda r: r['db_small_cpu']) - SMALL * db_per_s:.1f} s")  # fmt: skip
    table.add_row("rebuild, nothing changed (homemodel db build)", "", "", f"{nothing_s:.2f} s  ({_summary(nothing)})")
    table.add_row("rebuild, one spec changed (homemodel db build)", "", "", f"{one_s:.1f} s  ({_summary(one)})")
    console.print(table)
    if baseline is not None:
        _baseline_table(runs, entries, baseline, console)
    for problem in problems[:10]:
        console.print(problem)


def _baseline_table(runs: list[dict], entries: int, baseline: Path, console: Console) -> None:
    from rich.table import Table

    """The database with this checkout's code against the baseline's, in the same rounds."""
    table = Table(title=f"the database, this checkout against {baseline} (same rounds, medians)")
    for header in ("figure", "baseline", "this checkout", "ratio"):
        table.add_column(header, justify="left" if header == "figure" else "right")

    def both(figure) -> tuple[float, float]:  # noqa: ANN001 (a function of (run, prefix))
        return statistics.median(figure(r, "old") for r in runs), statistics.median(figure(r, "db") for r in runs)

    rows = [
        ("CPU time, every process (s)", lambda r, k: r[f"{k}_cpu"], 1),
        ("CPU per further entry (ms)", lambda r, k: 1000 * (r[f"{k}_cpu"] - r[f"{k}_small_cpu"]) / (entries - SMALL), 0),
        ("start-up CPU (s)", lambda r, k: r[f"{k}_small_cpu"] - SMALL * (r[f"{k}_cpu"] - r[f"{k}_small_cpu"]) / (entries - SMALL), 1),
        ("start-up, wall: to the first entry's start (s)", lambda r, k: r["old" if k == "old" else "built"]["startup_s"], 1),
        ("wall time, fresh process to exit (s)", lambda r, k: r[f"{k}_s"], 1),
    ]
    for name, figure, digits in rows:
        old, new = both(figure)
        table.add_row(name, f"{old:.{digits}f}", f"{new:.{digits}f}", f"{new / old:.2f}" if old else "")
    console.print(table)


def _summary(said: str) -> str:
    """The build's last line, without the index path."""
    last = [line for line in said.splitlines() if line.startswith("built ")][-1]
    return last.split(", in ")[0]


def mixed(console: Console) -> None:
    from rich.table import Table

    from homemodel.app.database import DatabaseBuildOptions, build_database

    with tempfile.TemporaryDirectory(prefix="bench-db-mixed-") as tmp:
        result = build_database(MIXED, Path(tmp) / "db", DatabaseBuildOptions(workers=WORKERS))
    by_source: dict[str, list] = defaultdict(list)
    for row in result.built:
        by_source[row.source].append(row)
    table = Table(title=f"examples/database/manifest.yaml: {len(result.built)} entries in {result.seconds:.1f} s on {WORKERS} workers")
    for header in ("source", "entries", "valid", "invalid", "failed", "median s", "max s"):
        table.add_column(header, justify="left" if header == "source" else "right")
    for source, rows in sorted(by_source.items()):
        times = [r.build_s for r in rows]
        counts = [sum(r.status == s for r in rows) for s in ("valid", "invalid", "failed")]
        table.add_row(source, str(len(rows)), *map(str, counts), f"{statistics.median(times):.1f}", f"{max(times):.1f}")
    console.print(table)
    for row in result.built:
        if row.status != "valid":
            console.print(f"{row.id} ({row.source}, {row.status}): {row.error}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--entries", type=int, default=200, help="generated spec entries (a multiple of 20)")
    parser.add_argument("--spec", choices=sorted(SWEEPS), default="cup", help="the catalogue spec the entries are generated from")
    parser.add_argument("--rounds", type=int, default=3, help="rounds of serial loop, loops side by side and database, interleaved")
    parser.add_argument("--baseline-src", type=Path, help="another checkout whose database is run beside this one's")
    parser.add_argument("--skip-mixed", action="store_true", help="only the throughput and rebuild figures")
    parser.add_argument("--only-mixed", action="store_true", help="only the mixed manifest")
    # The two sides of the throughput figure, each run by throughput() in a fresh process.
    parser.add_argument("--serial-loop", nargs="+", metavar="MANIFEST OUT T0 [PART]", help=argparse.SUPPRESS)
    parser.add_argument("--db-build", nargs="+", metavar="MANIFEST DB T0 [WORKERS]", help=argparse.SUPPRESS)
    parser.add_argument("--per-entry", nargs="+", metavar="MANIFEST OUT T0 [PAIRS]", help=argparse.SUPPRESS)
    args = parser.parse_args()
    for child, given in ((serial_loop, args.serial_loop), (database_build, args.db_build), (per_entry, args.per_entry)):
        if given:
            print(json.dumps(child(Path(given[0]), Path(given[1]), float(given[2]), *given[3:])))
            return
    from rich.console import Console

    console = Console(width=120)
    if not args.only_mixed:
        throughput(args.spec, args.entries, args.rounds, console, args.baseline_src)
    if not args.skip_mixed:
        mixed(console)


if __name__ == "__main__":
    main()
