"""Benchmark: shape completion's training time, query time and accuracy (D3.1 Table 1's protocol).

Generates the procedural library (3 classes by default: bottle, cup, spoon; 15 training and
5 unseen instances each), trains at 40 views per mesh, completes rendered depth images of
the unseen instances, and prints per class the VoxelIOU of every stage. The targets of the
issue are printed beside the figures: training of 3 classes x 15 instances x 40 views in
under 3 minutes, one query in under 2 s.

Baselines in the same run (the machines are shared and noisy, so ratios matter): the full
pipeline's IoU over retrieval only's, and a query's time over one ray-cast render of the
same depth image.

Run: .venv/bin/python benchmarks/bench_completion.py [--classes bottle,cup,spoon] [--queries 2]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from homemodel.geometry.raycast import RayCaster
from shape_completion.benchmark import STAGES, BenchmarkOptions, run_benchmark
from shape_completion.library import load_library, write_procedural_library
from shape_completion.queries import FILLER_CAMERA, random_query_pose

TRAINING_TARGET_S = 180.0
QUERY_TARGET_S = 2.0


def render_seconds(library) -> float:
    """The baseline: one ray-cast render of a query-sized depth image, best of 5."""
    mesh = library.meshes[0].mesh
    pose = random_query_pose(mesh, np.random.default_rng(0))
    times = []
    for _ in range(5):
        started = time.perf_counter()
        RayCaster(mesh).depth(FILLER_CAMERA, pose)
        times.append(time.perf_counter() - started)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--classes", default="bottle,cup,spoon")
    parser.add_argument("--train", type=int, default=15)
    parser.add_argument("--test", type=int, default=5)
    parser.add_argument("--views", type=int, default=40)
    parser.add_argument("--queries", type=int, default=2, help="query views per unseen instance")
    args = parser.parse_args()
    console = Console(width=140)
    with tempfile.TemporaryDirectory() as tmp:
        classes = args.classes.split(",")
        write_procedural_library(Path(tmp), classes=classes, per_class=args.train + args.test)
        library = load_library(Path(tmp))
        options = BenchmarkOptions(
            train_per_class=args.train, test_per_class=args.test, n_views=args.views, queries_per_instance=args.queries
        )
        result = run_benchmark(library, options)
        baseline = render_seconds(library)
    table = Table(title=f"shape completion: {args.train} train / {args.test} unseen per class, {args.views} views")
    table.add_column("class")
    for stage in STAGES:
        table.add_column(f"IoU {stage}", justify="right")
    table.add_column("filling / retrieval", justify="right")
    table.add_column("dist filling", justify="right")
    means = result.class_means()
    for class_name, row in means.items():
        table.add_row(
            class_name,
            *(f"{row[f'iou_{s}']:.3f}" for s in STAGES),
            f"{row['iou_filling'] / row['iou_retrieval']:.2f}",
            f"{row['distance_filling']:.4f}",
        )
    mean_iou = {s: float(np.mean([r[f"iou_{s}"] for r in means.values()])) for s in STAGES}
    table.add_row(
        "mean", *(f"{mean_iou[s]:.3f}" for s in STAGES), f"{mean_iou['filling'] / mean_iou['retrieval']:.2f}", ""
    )
    console.print(table)
    timing = Table(title="times (2-core machine, shared)")
    for column in ("figure", "seconds", "target", "ratio to one render"):
        timing.add_column(column, justify="right")
    timing.add_row("training", f"{result.training_seconds:.1f}", f"< {TRAINING_TARGET_S:.0f}", "")
    timing.add_row(
        "query, mean",
        f"{result.mean_query_seconds:.2f}",
        f"< {QUERY_TARGET_S:.0f}",
        f"{result.mean_query_seconds / baseline:.0f}x",
    )
    timing.add_row("query, max", f"{result.max_query_seconds:.2f}", "", f"{result.max_query_seconds / baseline:.0f}x")
    timing.add_row("one render (baseline)", f"{baseline:.4f}", "", "1x")
    console.print(timing)


if __name__ == "__main__":
    main()
