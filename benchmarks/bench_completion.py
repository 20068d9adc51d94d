"""Benchmark: shape completion's training time, query time and accuracy (D3.1 Table 1's protocol).

Generates the procedural library (3 classes by default: bottle, cup, spoon; 15 training and
5 unseen instances each), trains at 40 views per mesh, completes rendered depth images of
the unseen instances, and prints per class the VoxelIOU of every stage. With `--real-test
DIR` (a library folder of real meshes, e.g. from `benchmarks/real_meshes.py`) those meshes,
never trained on, are completed and scored too; `--real-train DIR` adds real meshes to the
training library. Times: training, a query in-process (mean and max), and one whole
`homemodel completion run` in a fresh process (imports, model loading and export included).

Baselines in the same run (the machines are shared and noisy, so ratios matter): the full
pipeline's IoU over retrieval only's, and a query's time over one ray-cast render of the
same depth image.

With `--model MODEL.npz` nothing is trained: the model completes unseen generated instances
(`--test` per class, drawn with another seed than the default library's) and `--real-test`
meshes, and with `--baseline-src DIR` (another source tree of the project, e.g.
`git archive COMMIT | tar -x -C DIR`) the same queries and the same CLI run are done by that
code in a subprocess, so the previous implementation is measured beside this one in one run.

Run: .venv/bin/python benchmarks/bench_completion.py [--classes bottle,cup,spoon] [--queries 2]
     [--real-train REAL_TRAIN] [--real-test REAL_TEST]
     .venv/bin/python benchmarks/bench_completion.py --model MODEL.npz [--real-test REAL_TEST]
     [--baseline-src DIR] [--classes ...] [--test 3] [--queries 1]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from homemodel.evaluation import rock_voxel_iou
from homemodel.geometry.camera import save_camera
from homemodel.geometry.depth_io import write_depth
from homemodel.geometry.raycast import RayCaster
from shape_completion.benchmark import (
    STAGES,
    BenchmarkOptions,
    BenchmarkResult,
    benchmark_split,
    complete_random_view,
    split_library,
)
from shape_completion.library import Library, load_library, write_procedural_library
from shape_completion.model_io import load_model, save_model
from shape_completion.pipeline import ShapeCompleter
from shape_completion.queries import FILLER_CAMERA, random_query_pose

TRAINING_TARGET_S = 180.0
QUERY_TARGET_S = 0.5  # in-process
CLI_TARGET_S = 1.5  # a whole `homemodel completion run`, imports included


def render_seconds(library: Library) -> float:
    """The baseline: one ray-cast render of a query-sized depth image, best of 5."""
    mesh = library.meshes[0].mesh
    pose = random_query_pose(mesh, np.random.default_rng(0))
    times = []
    for _ in range(5):
        started = time.perf_counter()
        RayCaster(mesh).depth(FILLER_CAMERA, pose)
        times.append(time.perf_counter() - started)
    return min(times)


def cli_seconds(completer: ShapeCompleter, library: Library, folder: Path, runs: int = 3) -> float:
    """Best wall time of `homemodel completion run` in a fresh process on one rendered query."""
    save_model(completer, folder / "model.npz")
    return cli_run_seconds(folder / "model.npz", library.meshes[-1].mesh, folder, runs=runs)[0]


def children_cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def cli_run_seconds(model: Path, mesh, folder: Path, *, runs: int, source: Path | None = None) -> tuple[float, float]:
    """Best wall time and best CPU time (user + sys, with the glTF validator's process) of
    `homemodel completion run MODEL` on a rendered depth image of `mesh`, each in a fresh
    process; with `source`, that source tree's code is run."""
    write_depth(folder / "depth.png", RayCaster(mesh).depth(FILLER_CAMERA, random_query_pose(mesh, np.random.default_rng(1))),
                depth_scale_m=FILLER_CAMERA.depth_scale_m)  # fmt: skip
    save_camera(FILLER_CAMERA, folder / "camera.yaml")
    command = [str(Path(sys.executable).parent / "homemodel"), "completion", "run", str(model),
               str(folder / "depth.png"), "--camera", str(folder / "camera.yaml"), "--force"]  # fmt: skip
    env = os.environ | ({"PYTHONPATH": str(source)} if source is not None else {})
    times, cpu = [], []
    for run in range(runs):
        started, cpu_started = time.perf_counter(), children_cpu_seconds()
        done = subprocess.run([*command, "--out", str(folder / f"out{run}")], capture_output=True, text=True, env=env)
        if done.returncode != 0:  # reported, not fatal: the in-process figures still stand
            print(f"CLI run failed ({source or 'this code'}): {done.stderr.strip().splitlines()[-1:]}", file=sys.stderr)
            return float("nan"), float("nan")
        times.append(time.perf_counter() - started)
        cpu.append(children_cpu_seconds() - cpu_started)
    return min(times), min(cpu)


def scored_queries(completer: ShapeCompleter, test: Library, real_names: set[str], queries: int) -> list[dict]:
    """Each test mesh completed from `queries` random views: class, whether real, IoU, seconds."""
    rng = np.random.default_rng(7)
    rows = []
    for entry in test.meshes:
        for _ in range(queries):
            cpu_started = time.process_time()  # here, not in complete_random_view: a baseline tree may lack it
            view = complete_random_view(completer, entry.mesh, rng)
            cpu = time.process_time() - cpu_started  # the completion and its query's one render
            rows.append({"class": entry.class_name, "instance": entry.name, "real": entry.name in real_names,
                         "iou": rock_voxel_iou(view.completion.mesh, view.truth), "seconds": view.seconds,
                         "cpu_seconds": cpu})  # fmt: skip
    return rows


def model_scores(args: argparse.Namespace, folder: Path) -> dict:
    """The trained model's scores on unseen generated instances and the real test meshes, and a CLI run's time."""
    completer = load_model(args.model)
    write_procedural_library(folder / "unseen", classes=args.classes.split(","), per_class=args.test, seed=11)
    test = load_library(folder / "unseen", min_per_class=1)
    real_names: set[str] = set()
    if args.real_test is not None:
        real = load_library(args.real_test, min_per_class=1)
        real_names = {m.name for m in real.meshes}
        test = Library(meshes=test.meshes + real.meshes, fingerprint=test.fingerprint)
    rows = scored_queries(completer, test, real_names, args.queries)
    cli, cli_cpu = cli_run_seconds(args.model, test.meshes[-1].mesh, folder, runs=2)
    return {"queries": rows, "cli_seconds": cli, "cli_cpu_seconds": cli_cpu}


def comparison_table(current: dict, baseline: dict | None) -> Table:
    """Mean IoU and query CPU seconds per group (real classes apart, generated ones together)."""
    table = Table(title="this code" + ("" if baseline is None else " against the baseline source, same queries"))
    for column in ("queries", "group", "IoU", "IoU baseline", "query CPU s mean", "max", "baseline mean", "max",
                   "ratio", "query wall s mean"):  # fmt: skip
        table.add_column(column, justify="right")
    groups: dict[str, list[int]] = {}
    for i, row in enumerate(current["queries"]):
        for key in [f"real {row['class']}", "real, all"] if row["real"] else ["generated"]:
            groups.setdefault(key, []).append(i)
    for name, members in sorted(groups.items()):
        now = [current["queries"][i] for i in members]
        then = [baseline["queries"][i] for i in members] if baseline else []
        cells = [str(len(now)), name, f"{np.mean([r['iou'] for r in now]):.3f}"]
        cells.append(f"{np.mean([r['iou'] for r in then]):.3f}" if then else "")
        cells += [f"{np.mean([r['cpu_seconds'] for r in now]):.2f}", f"{np.max([r['cpu_seconds'] for r in now]):.2f}"]
        if then:
            ratio = np.mean([r["cpu_seconds"] for r in now]) / np.mean([r["cpu_seconds"] for r in then])
            cells += [f"{np.mean([r['cpu_seconds'] for r in then]):.2f}", f"{np.max([r['cpu_seconds'] for r in then]):.2f}",
                      f"{ratio:.2f}"]  # fmt: skip
        else:
            cells += ["", "", ""]
        table.add_row(*cells, f"{np.mean([r['seconds'] for r in now]):.2f}")
    cli = f"{current['cli_seconds']:.2f} wall, {current['cli_cpu_seconds']:.2f} CPU"
    if baseline is not None:
        cli += f" (baseline {baseline['cli_seconds']:.2f} wall, {baseline['cli_cpu_seconds']:.2f} CPU)"
    table.caption = (f"homemodel completion run, fresh process, best of 2: {cli} s (target < {CLI_TARGET_S} s wall);"
                     f" load average {os.getloadavg()[0]:.1f}")  # fmt: skip
    return table


def iou_table(title: str, result: BenchmarkResult) -> Table:
    table = Table(title=title)
    table.add_column("class")
    for stage in STAGES:
        table.add_column(f"IoU {stage}", justify="right")
    table.add_column("filling / retrieval", justify="right")
    table.add_column("dist filling", justify="right")
    table.add_column("queries", justify="right")
    means = result.class_means()
    for class_name, row in means.items():
        table.add_row(
            class_name,
            *(f"{row[f'iou_{s}']:.3f}" for s in STAGES),
            f"{row['iou_filling'] / row['iou_retrieval']:.2f}",
            f"{row['distance_filling']:.4f}",
            str(row["queries"]),
        )
    mean_iou = {s: float(np.mean([r[f"iou_{s}"] for r in means.values()])) for s in STAGES}
    table.add_row(
        "mean", *(f"{mean_iou[s]:.3f}" for s in STAGES), f"{mean_iou['filling'] / mean_iou['retrieval']:.2f}", "", ""
    )
    return table


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--classes", default="bottle,cup,spoon")
    parser.add_argument("--train", type=int, default=15)
    parser.add_argument("--test", type=int, default=5)
    parser.add_argument("--views", type=int, default=40)
    parser.add_argument("--queries", type=int, default=2, help="query views per unseen instance")
    parser.add_argument("--real-train", type=Path, help="library folder of real meshes added to training")
    parser.add_argument("--real-test", type=Path, help="library folder of real meshes to score, never trained on")
    parser.add_argument("--model", type=Path, help="a trained model to score instead of training one")
    parser.add_argument("--baseline-src", type=Path, help="with --model: a source tree to run the same queries with")
    parser.add_argument("--scores-out", type=Path, help=argparse.SUPPRESS)  # the baseline's subprocess writes here
    args = parser.parse_args()
    console = Console(width=160)
    if args.model is not None:
        with tempfile.TemporaryDirectory() as tmp:
            current = model_scores(args, Path(tmp))
            if args.scores_out is not None:
                args.scores_out.write_text(json.dumps(current))
                return
            baseline = None
            if args.baseline_src is not None:
                out = Path(tmp) / "baseline.json"
                command = [sys.executable, __file__, *sys.argv[1:], "--scores-out", str(out)]
                subprocess.run(command, check=True, env=os.environ | {"PYTHONPATH": str(args.baseline_src)})
                baseline = json.loads(out.read_text())
        console.print(comparison_table(current, baseline))
        return
    options = BenchmarkOptions(
        train_per_class=args.train, test_per_class=args.test, n_views=args.views, queries_per_instance=args.queries
    )
    with tempfile.TemporaryDirectory() as tmp:
        classes = args.classes.split(",")
        write_procedural_library(Path(tmp) / "library", classes=classes, per_class=args.train + args.test)
        train, test = split_library(load_library(Path(tmp) / "library"), options)
        if args.real_train is not None:
            train = Library(meshes=train.meshes + load_library(args.real_train, min_per_class=1).meshes,
                            fingerprint=train.fingerprint)  # fmt: skip
        if args.real_test is not None:
            real_test = load_library(args.real_test, min_per_class=1)
            test = Library(meshes=test.meshes + real_test.meshes, fingerprint=test.fingerprint)
        completer = ShapeCompleter(n_views=args.views, random_state=options.random_state)
        result = benchmark_split(train, test, options, completer=completer)
        baseline = render_seconds(train)
        cli = cli_seconds(completer, train, Path(tmp))
    real_names = set() if args.real_test is None else {m.name for m in real_test.meshes}
    generated = [s for s in result.scores if s.instance not in real_names]
    console.print(iou_table(f"generated: {args.train} train / {args.test} unseen per class, {args.views} views",
                            BenchmarkResult(options=options, scores=generated, training_seconds=result.training_seconds)))  # fmt: skip
    if real_names:
        real = [s for s in result.scores if s.instance in real_names]
        console.print(iou_table(f"real meshes never trained on ({args.real_test})",
                                BenchmarkResult(options=options, scores=real, training_seconds=result.training_seconds)))  # fmt: skip
    timing = Table(title="times (2-core machine, shared)")
    for column in ("figure", "seconds", "target", "ratio to one render"):
        timing.add_column(column, justify="right")
    timing.add_row("training", f"{result.training_seconds:.1f}", f"< {TRAINING_TARGET_S:.0f}", "")
    timing.add_row("query in-process, mean", f"{result.mean_query_seconds:.2f}", f"< {QUERY_TARGET_S}",
                   f"{result.mean_query_seconds / baseline:.0f}x")  # fmt: skip
    timing.add_row("query in-process, max", f"{result.max_query_seconds:.2f}", "", f"{result.max_query_seconds / baseline:.0f}x")
    timing.add_row("homemodel completion run (fresh process)", f"{cli:.2f}", f"< {CLI_TARGET_S}", f"{cli / baseline:.0f}x")
    timing.add_row("one render (baseline)", f"{baseline:.4f}", "", "1x")
    console.print(timing)


if __name__ == "__main__":
    main()
