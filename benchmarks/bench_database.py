"""Benchmark: `homemodel db build` on Dask against a plain serial loop, cached rebuilds, and a
mixed manifest of every source.

1. Throughput: N generated spec entries (a cup swept over heights and diameters) built by the
   database with 2 local workers, against the same entries in a plain serial loop of
   `modeller.build` (the sweep's spec written, then built), in the same run. The overhead per
   entry is (workers x database time - serial time) / N: what the database adds per entry
   (the scheduler, the thumbnail, the entry record, the index) beyond perfect parallelism.
2. A rebuild with nothing changed, and after one spec file changed (only that entry built).
3. The mixed manifest of examples/database (specs, a sweep, a simulated turntable capture, the
   shared Kermit photos, a completion query, an imported PartNet-style URDF): every entry
   built or recorded as failed, and the time per source. Needs its inputs:
   `python examples/database/make_inputs.py build/db_inputs`.

Run: .venv/bin/python benchmarks/bench_database.py [--entries 200] [--skip-mixed | --only-mixed]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import yaml
from rich.console import Console
from rich.table import Table

from homemodel.app.database import DatabaseBuildOptions, build_database
from homemodel.app.database.manifest import load_manifest

ROOT = Path(__file__).resolve().parent.parent
CUP = ROOT / "examples" / "catalogue" / "cup.yaml"
MIXED = ROOT / "examples" / "database" / "manifest.yaml"
WORKERS = 2


def _cup_manifest(folder: Path, entries: int) -> Path:
    spec = folder / "cup.yaml"
    spec.write_text(CUP.read_text())
    per_side = 20
    heights = [round(0.075 + 0.002 * i, 4) for i in range(per_side)]
    diameters = [round(0.08 + 0.002 * i, 4) for i in range(entries // per_side)]
    manifest = folder / "manifest.yaml"
    sweep = {"height_m": heights, "outer_diameter_m": diameters}
    manifest.write_text(yaml.safe_dump({"entries": [{"id": "cup", "source": "spec", "path": "cup.yaml", "sweep": sweep}]}))
    return manifest


def _serial_loop(manifest: Path, out: Path) -> float:
    """The same entries, one after the other, in this process: write the swept spec, build it."""
    from modeller import BuildOptions, build

    jobs, _ = load_manifest(manifest)
    base = yaml.safe_load(jobs[0].inputs["path"].read_text())
    start = time.perf_counter()
    for job in jobs:
        spec = out / f"{job.id}.yaml"
        spec.write_text(yaml.safe_dump({**base, **job.overrides}))
        build(spec, out / job.id, BuildOptions(name=job.id))
    return time.perf_counter() - start


def _warm_bpy() -> None:
    """Import bpy and build once, as each Dask worker does before its first entry."""
    from modeller import BuildOptions, build

    with tempfile.TemporaryDirectory() as tmp:
        build(CUP, Path(tmp) / "warm", BuildOptions(name="warm"))


def throughput(entries: int, console: Console) -> None:
    with tempfile.TemporaryDirectory(prefix="bench-db-") as tmp:
        folder = Path(tmp)
        manifest = _cup_manifest(folder, entries)
        _warm_bpy()
        (folder / "serial").mkdir()
        serial_s = _serial_loop(manifest, folder / "serial")
        db = folder / "db"
        result = build_database(manifest, db, DatabaseBuildOptions(workers=WORKERS))
        db_s = result.seconds
        problems = [f"{r.id}: {r.status}: {r.error or '; '.join(r.failed_checks)}" for r in result.built if r.status != "valid"]
        nothing = build_database(manifest, db, DatabaseBuildOptions(workers=WORKERS))
        # One more entry with a spec file of its own, built once; then only its file changes.
        single = folder / "single.yaml"
        single.write_text(CUP.read_text())
        data = yaml.safe_load(manifest.read_text())
        data["entries"].append({"id": "lonely", "source": "spec", "path": "single.yaml"})
        manifest.write_text(yaml.safe_dump(data))
        build_database(manifest, db, DatabaseBuildOptions(workers=WORKERS))
        single.write_text(CUP.read_text().replace("colour: white", "colour: red"))
        one = build_database(manifest, db, DatabaseBuildOptions(workers=WORKERS))

    table = Table(title=f"{entries} cup entries: database on {WORKERS} Dask workers vs a serial loop")
    table.add_column("figure")
    table.add_column("value", justify="right")
    table.add_row("serial loop (modeller.build)", f"{serial_s:.1f} s  ({1000 * serial_s / entries:.0f} ms/entry)")
    table.add_row(f"db build, {WORKERS} workers (with start-up)", f"{db_s:.1f} s  ({1000 * db_s / entries:.0f} ms/entry)")
    table.add_row("entries valid / built", f"{entries - len(problems)} / {len(result.built)}")
    table.add_row("speed-up (serial / db)", f"{serial_s / db_s:.2f}x")
    table.add_row("overhead per entry (workers x db - serial) / N", f"{1000 * (WORKERS * db_s - serial_s) / entries:.0f} ms")
    table.add_row("rebuild, nothing changed", f"{nothing.seconds:.2f} s  (built {len(nothing.built)}, cached {len(nothing.cached)})")
    table.add_row("rebuild, one spec changed", f"{one.seconds:.1f} s  (built {[r.id for r in one.built]}, cached {len(one.cached)})")
    console.print(table)
    for problem in problems[:10]:
        console.print(problem)


def mixed(console: Console) -> None:
    with tempfile.TemporaryDirectory(prefix="bench-db-mixed-") as tmp:
        result = build_database(MIXED, Path(tmp) / "db", DatabaseBuildOptions(workers=WORKERS, repair=True))
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
    parser.add_argument("--skip-mixed", action="store_true", help="only the throughput and rebuild figures")
    parser.add_argument("--only-mixed", action="store_true", help="only the mixed manifest")
    args = parser.parse_args()
    console = Console(width=120)
    if not args.only_mixed:
        throughput(args.entries, console)
    if not args.skip_mixed:
        mixed(console)


if __name__ == "__main__":
    main()
