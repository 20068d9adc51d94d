"""Benchmark: photos to a textured mesh, time per stage, on 50 rendered photos at 1600 px.

The SfM stages are set against pycolmap's own reconstruction with its defaults (feature
extraction, exhaustive matching, then incremental and global mapping), run in the same
process on the same photos right after ours, as the baselines: the machines are shared and
noisy, so a ratio is what compares, and the load average is printed with it. The accuracy
against the rendered truth (scale error, mean surface distance) is printed too.

    .venv/bin/python benchmarks/bench_photogrammetry.py [--views 50] [--width-px 1600]

The photos are rendered once with Blender into build/bench-cache/ and reused until the
rendering code changes.
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

ROOT = Path(__file__).resolve().parents[1]


def pycolmap_baselines(images: Path, work: Path) -> dict[str, float | int]:
    """pycolmap with its defaults on the same photos: feature extraction, exhaustive matching,
    then incremental mapping and, on a copy of the same matches, global mapping (GLOMAP).
    Seconds per step and the photos each mapper registers."""
    import pycolmap

    database = work / "baseline.db"
    figures: dict[str, float | int] = {}
    start = time.perf_counter()
    pycolmap.extract_features(database, images)
    figures["features"] = time.perf_counter() - start
    start = time.perf_counter()
    pycolmap.match_exhaustive(database)
    figures["matching"] = time.perf_counter() - start
    shutil.copyfile(database, work / "baseline_global.db")
    for mapper, run, db in (
        ("incremental", pycolmap.incremental_mapping, database),
        ("global", pycolmap.global_mapping, work / "baseline_global.db"),
    ):
        (work / mapper).mkdir()
        start = time.perf_counter()
        reconstructions = run(db, images, work / mapper)
        figures[f"mapping {mapper}"] = time.perf_counter() - start
        figures[f"registered {mapper}"] = max((r.num_reg_images() for r in reconstructions.values()), default=0)
    return figures


def cpu_seconds() -> float:
    """User and system CPU time of this process and its waited-for children: on a loaded
    machine the figure that compares (wall times stretch with the load)."""
    import resource

    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


class StageCpu:
    """A progress callback that adds up this process's CPU seconds per stage (the pipeline's
    own times are wall seconds, which stretch with the machine's load)."""

    def __init__(self) -> None:
        self.cpu_s: dict[str, float] = {}
        self._stage: str | None = None
        self._start = 0.0

    def __call__(self, stage: str, done: int, total: int | None) -> None:
        if stage != self._stage:
            self.stop()
            self._stage, self._start = stage, cpu_seconds()

    def stop(self) -> None:
        if self._stage is not None:
            self.cpu_s[self._stage] = self.cpu_s.get(self._stage, 0.0) + cpu_seconds() - self._start
            self._stage = None


def load_average() -> str:
    return " ".join(f"{x:.1f}" for x in os.getloadavg())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--views", type=int, default=50)
    parser.add_argument("--width-px", type=int, default=1600)
    parser.add_argument("--photos", type=Path, help="a real photo folder instead of the rendered set (no accuracy)")
    parser.add_argument("--reference", type=Path, help="with --photos: reference cameras JSON for pose agreement")
    parser.add_argument("--upsample-px", type=int, help="with --photos: photos enlarged to this longer side "
                        "(JPEG, quality 92): a stand-in for a twelve-megapixel set, such as 4272")
    parser.add_argument("--skip-baseline", action="store_true", help="only our pipeline")
    args = parser.parse_args()

    from photogrammetry.photos import list_photos
    from photogrammetry.synthetic_scene import SceneOptions, render_scene

    console = Console(width=120)
    scene = None
    with tempfile.TemporaryDirectory(prefix="bench-photogrammetry-") as chosen:
        if args.photos:
            # The first --views photos by name, linked into a folder of their own.
            images = Path(chosen)
            for path in list_photos(args.photos)[: args.views]:
                if args.upsample_px:
                    _upsampled(path, images / (path.stem + ".jpg"), args.upsample_px)
                else:
                    (images / path.name).symlink_to(path.resolve())
            size = f" enlarged to {args.upsample_px} px" if args.upsample_px else ""
            title = f"{len(list(images.iterdir()))} photos of {args.photos}{size}"
        else:
            height_px = args.width_px * 3 // 4
            cache = ROOT / "build" / "bench-cache" / f"photogrammetry_scene_{args.views}x{args.width_px}"
            start = time.perf_counter()
            scene = render_scene(
                cache, SceneOptions(n_views=args.views, width_px=args.width_px, height_px=height_px, samples=4)
            )
            console.print(f"rendered or loaded in {time.perf_counter() - start:.0f} s")
            images = cache / "images"
            title = f"{len(scene.image_paths)} rendered photos at {args.width_px}x{height_px}"
        run(args, images, title, scene, console)


def _upsampled(path: Path, out: Path, longest_px: int) -> None:
    """The photo enlarged (bicubic) so its longer side is `longest_px`, as a JPEG without EXIF
    (so COLMAP's focal prior is not taken from the original size)."""
    import cv2

    photo = cv2.imread(str(path))
    factor = longest_px / max(photo.shape[:2])
    size = (round(photo.shape[1] * factor), round(photo.shape[0] * factor))
    cv2.imwrite(str(out), cv2.resize(photo, size, interpolation=cv2.INTER_CUBIC), [cv2.IMWRITE_JPEG_QUALITY, 92])


def run(args, images: Path, title: str, scene, console: Console) -> None:
    """Our pipeline, then pycolmap's defaults, on `images`; the table and the figures file."""
    from homemodel.core.atomic import write_json
    from photogrammetry.pipeline import ReconstructOptions, reconstruct_photos

    with tempfile.TemporaryDirectory(prefix="bench-photogrammetry-") as work_name:
        work = Path(work_name)
        ours_work = work / "ours"
        ours_work.mkdir()
        load_before = load_average()
        start, cpu_start = time.perf_counter(), cpu_seconds()
        options = ReconstructOptions()
        if scene is not None:
            options = ReconstructOptions(marker_size_m=scene.marker_size_m, dictionary=scene.dictionary)
        stage_cpu = StageCpu()
        result = reconstruct_photos(images, options, stage_cpu, work_dir=ours_work)
        stage_cpu.stop()
        total_s, total_cpu_s = time.perf_counter() - start, cpu_seconds() - cpu_start
        shutil.rmtree(ours_work, ignore_errors=True)
        load_between = load_average()
        cpu_start = cpu_seconds()
        baseline = {} if args.skip_baseline else pycolmap_baselines(images, work)
        baseline_cpu_s = cpu_seconds() - cpu_start
        load_after = load_average()

    times = result.figures["times_s"]
    sfm_s = sum(times[k] for k in ("features", "matching", "mapping"))
    n_photos = result.figures["photos"]

    table = Table(title=f"photogrammetry: {title}", show_lines=False)
    for column in ("stage", "ours s", "ours CPU s", "pycolmap defaults s", "ratio"):
        table.add_column(column, justify="right" if column != "stage" else "left")
    for stage, seconds in times.items():
        base = baseline.get(stage)
        cpu = stage_cpu.cpu_s.get(stage)
        table.add_row(stage, f"{seconds:.1f}", f"{cpu:.1f}" if cpu is not None else "", f"{base:.1f}" if base else "",
                      f"{seconds / base:.2f}" if base else "")  # fmt: skip
    for mapper in ("incremental", "global"):
        if f"mapping {mapper}" in baseline:
            base = baseline[f"mapping {mapper}"]
            table.add_row(f"mapping (pycolmap {mapper})", "", "", f"{base:.1f}", f"{times['mapping'] / base:.2f}")
    baseline_sfm = {
        mapper: baseline["features"] + baseline["matching"] + baseline[f"mapping {mapper}"]
        for mapper in ("incremental", "global")
        if baseline
    }
    for mapper, seconds in baseline_sfm.items():
        table.add_row(f"SfM vs pycolmap {mapper}", f"{sfm_s:.1f}", "", f"{seconds:.1f}", f"{sfm_s / seconds:.2f}")
    table.add_row("total, photos to textured mesh", f"{total_s:.1f}", f"{total_cpu_s:.1f}", "", "")
    table.add_row("CPU s (user + system), all stages", "", f"{total_cpu_s:.1f}",
                  f"{baseline_cpu_s:.1f}" if baseline else "", "")  # fmt: skip
    # Two idle cores run it in at least half its CPU time, at most all of it (one core busy).
    table.add_row("two idle cores, from CPU s", f"{total_cpu_s / 2:.0f}-{total_cpu_s:.0f}", "", "", "")
    console.print(table)
    figures = {
        "photos": title,
        "load_average_1_5_15_min": {"before": load_before, "between": load_between, "after": load_after},
        "registered": result.figures["registered"],
        "matching": result.figures["matching"],
        "baseline": {k: round(v, 2) for k, v in baseline.items()},
        "times_s": times,
        "cpu_s": {k: round(v, 2) for k, v in stage_cpu.cpu_s.items()},
        "sfm_s": round(sfm_s, 2),
        "sfm_ratio_to_pycolmap": {k: round(sfm_s / v, 3) for k, v in baseline_sfm.items()},
        "total_s": round(total_s, 2),
        "total_cpu_s": round(total_cpu_s, 2),
        "baseline_cpu_s": round(baseline_cpu_s, 2),
        "dense_image_px": result.figures["dense_image_px"],
        "faces": result.figures["faces"],
        "sparse_points": result.figures["sparse_points"],
        "features_per_photo": result.figures["features_per_photo"],
        "support_plane_found": result.figures["support_plane_found"],
    }
    registered_by = ", ".join(f"{k.split()[1]} {v}" for k, v in baseline.items() if k.startswith("registered"))
    console.print(
        f"registered {figures['registered']} of {n_photos} (pycolmap defaults: {registered_by or 'not run'}); "
        f"load average (1, 5, 15 min) before {load_before}, between {load_between}, after {load_after}"
    )
    console.print(
        f"SIFT features per photo (median) {figures['features_per_photo']}; dense views {figures['dense_image_px']} px; "
        f"sparse points {figures['sparse_points']}; support plane found: {figures['support_plane_found']}; "
        f"faces {figures['faces']}"
    )
    if scene is not None:
        from homemodel.evaluation import mean_surface_distance_m

        estimated = np.array([v.centre_world for v in result.views])
        true = np.array([np.linalg.inv(scene.camera_from_world[v.name])[:3, 3] for v in result.views])
        scale = np.sqrt(((true - true.mean(0)) ** 2).sum() / ((estimated - estimated.mean(0)) ** 2).sum())
        distance_m = mean_surface_distance_m(result.mesh, scene.truth_mesh)
        figures |= {
            "scale_error": round(float(abs(scale - 1)), 5),
            "mean_surface_distance_m": round(distance_m, 6),
            "object_size_m": round(scene.object_size_m, 4),
        }
        console.print(
            f"scale error {figures['scale_error'] * 100:.2f}%; mean surface distance {distance_m * 1000:.2f} mm "
            f"({distance_m / scene.object_size_m * 100:.2f}% of the object's {scene.object_size_m * 1000:.0f} mm)"
        )
    if args.reference:
        from photogrammetry.pose_agreement import load_reference_cameras, pose_agreement

        poses = {v.name: v.camera_from_world for v in result.views}
        agreement = pose_agreement(poses, load_reference_cameras(args.reference))
        figures["pose_agreement"] = vars(agreement)
        console.print(f"poses against the reference cameras, up to a similarity: {agreement}")
    out = ROOT / "build" / "bench_photogrammetry.json"
    write_json(out, figures)
    console.print(f"figures: {out}")


if __name__ == "__main__":
    main()
