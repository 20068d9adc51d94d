"""Benchmark: photos to a textured mesh, time per stage, on 50 rendered photos at 1600 px.

The SfM stage is set against pycolmap's own reconstruction with its defaults (feature
extraction, exhaustive matching, incremental mapping), run in the same process on the same
photos, as the baseline: the machines are shared and noisy, a ratio is what compares. The
accuracy against the rendered truth (scale error, mean surface distance) is printed too.

    .venv/bin/python benchmarks/bench_photogrammetry.py [--views 50] [--width-px 1600]

The photos are rendered once with Blender into build/bench-cache/ and reused until the
rendering code changes.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

ROOT = Path(__file__).resolve().parents[1]


def pycolmap_baseline(images: Path, work: Path) -> tuple[float, int, dict]:
    """pycolmap's reconstruction with its defaults: seconds, registered images, per-step times."""
    import pycolmap

    database = work / "baseline.db"
    times = {}
    start = time.perf_counter()
    pycolmap.extract_features(database, images)
    times["features"] = time.perf_counter() - start
    step = time.perf_counter()
    pycolmap.match_exhaustive(database)
    times["matching"] = time.perf_counter() - step
    step = time.perf_counter()
    (work / "baseline").mkdir()
    reconstructions = pycolmap.incremental_mapping(database, images, work / "baseline")
    times["mapping"] = time.perf_counter() - step
    registered = max((r.num_reg_images() for r in reconstructions.values()), default=0)
    return time.perf_counter() - start, registered, times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--views", type=int, default=50)
    parser.add_argument("--width-px", type=int, default=1600)
    parser.add_argument("--skip-baseline", action="store_true", help="only our pipeline")
    args = parser.parse_args()

    from homemodel.evaluation import mean_surface_distance_m
    from homemodel.core.atomic import write_json
    from photogrammetry.pipeline import ReconstructOptions, reconstruct_photos
    from photogrammetry.synthetic_scene import SceneOptions, render_scene

    height_px = args.width_px * 3 // 4
    cache = ROOT / "build" / "bench-cache" / f"photogrammetry_scene_{args.views}x{args.width_px}"
    console = Console(width=120)
    start = time.perf_counter()
    scene = render_scene(
        cache, SceneOptions(n_views=args.views, width_px=args.width_px, height_px=height_px, samples=4)
    )
    console.print(
        f"photos: {len(scene.image_paths)} at {args.width_px}x{height_px} ({time.perf_counter() - start:.0f} s to render or load)"
    )
    images = cache / "images"

    with tempfile.TemporaryDirectory(prefix="bench-photogrammetry-") as work_name:
        work = Path(work_name)
        baseline_s, baseline_registered, baseline_times = (None, 0, {})
        if not args.skip_baseline:
            baseline_s, baseline_registered, baseline_times = pycolmap_baseline(images, work)
        ours_work = work / "ours"
        ours_work.mkdir()
        start = time.perf_counter()
        options = ReconstructOptions(marker_size_m=scene.marker_size_m, dictionary=scene.dictionary)
        result = reconstruct_photos(images, options, work_dir=ours_work)
        total_s = time.perf_counter() - start
        shutil.rmtree(ours_work / "undistorted", ignore_errors=True)

    times = result.summary["times_s"]
    sfm_s = sum(times[k] for k in ("features", "matching", "mapping"))
    estimated = np.array([v.centre_world for v in result.views])
    true = np.array([np.linalg.inv(scene.camera_from_world[v.name])[:3, 3] for v in result.views])
    scale = np.sqrt(((true - true.mean(0)) ** 2).sum() / ((estimated - estimated.mean(0)) ** 2).sum())
    distance_m = mean_surface_distance_m(result.mesh, scene.truth_mesh)

    table = Table(title=f"photogrammetry: {len(scene.image_paths)} photos at {args.width_px} px", show_lines=False)
    for column in ("stage", "ours s", "pycolmap defaults s", "ratio"):
        table.add_column(column, justify="right" if column != "stage" else "left")
    for stage, seconds in times.items():
        base = baseline_times.get(stage)
        table.add_row(stage, f"{seconds:.1f}", f"{base:.1f}" if base else "", f"{seconds / base:.2f}" if base else "")
    if baseline_s:
        table.add_row(
            "SfM (features+matching+mapping)", f"{sfm_s:.1f}", f"{baseline_s:.1f}", f"{sfm_s / baseline_s:.2f}"
        )
    table.add_row("total, photos to textured mesh", f"{total_s:.1f}", "", "")
    console.print(table)
    figures = {
        "photos": len(scene.image_paths),
        "width_px": args.width_px,
        "registered": result.summary["registered"],
        "baseline_registered": baseline_registered,
        "times_s": times,
        "sfm_s": round(sfm_s, 2),
        "baseline_sfm_s": round(baseline_s, 2) if baseline_s else None,
        "sfm_ratio": round(sfm_s / baseline_s, 3) if baseline_s else None,
        "total_s": round(total_s, 2),
        "scale_error": round(float(abs(scale - 1)), 5),
        "mean_surface_distance_m": round(distance_m, 6),
        "object_size_m": round(scene.object_size_m, 4),
        "faces": result.summary["faces"],
    }
    console.print(
        f"registered {figures['registered']} (pycolmap defaults: {baseline_registered}); scale error "
        f"{figures['scale_error'] * 100:.2f}%; mean surface distance {distance_m * 1000:.2f} mm "
        f"({distance_m / scene.object_size_m * 100:.2f}% of the object's {scene.object_size_m * 1000:.0f} mm)"
    )
    out = ROOT / "build" / "bench_photogrammetry.json"
    write_json(out, figures)
    console.print(f"figures: {out}")


if __name__ == "__main__":
    main()
