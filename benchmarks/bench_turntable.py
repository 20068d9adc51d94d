"""Benchmark: the turntable reconstruction of a simulated 640x480 capture, stage by stage, beside
a baseline run in the same process on the same frames and poses: Open3D's TSDF integration
(UniformTSDFVolume) of the segmented depth, then marching cubes. Run at 40 frames (every fifth
of the capture) and at 200, in one run; ratios, since the machines are shared and noisy.

Times are CPU seconds of the process (all its threads: ours reads frames on two, Open3D's
integration runs OpenMP threads on every core), taken per stage; the ratios compare CPU, as the
machines are shared. Wall seconds per stage are printed beside, for runs on idle cores.

What each column includes. Ours: every stage from the capture folder to the textured mesh:
poses (each frame read once: colour and depth decoded, tags, PnP, the object's pixels kept),
axis (circle and turntable fit), merge, mesh (outliers, normals, the signed-distance surface),
texture. TSDF: it needs poses and the object's cylinder and is GIVEN ours; its own work is
reading each frame's colour and depth, segmenting by our cylinder (with the pipeline's
own `object_pixels`, float32, the height above the table first) and integrating
(UniformTSDFVolume, 1.5 mm voxels, as our merge; `--tsdf-voxel-m`), then marching cubes. Its column also shows
our poses and axis stages (the same seconds) for the runs that charge them. Four ratios: our
whole run against the TSDF's own work given the poses (the issue's comparison, the hardest);
the whole runs with the TSDF charged our poses and axis; the work after the shared poses and
axis (ours: merge, mesh, texture; TSDF: integration and extraction, its reading of the frames
left out, as if it had kept the images from ours); the same without our texture.

    .venv/bin/python benchmarks/bench_turntable.py [--object mug] [--frames 200] [--subsets 40 200]
        [--noise-m 0.0015] [--repeat 1] [--tsdf-voxel-m 0.0015]

The capture is rendered once (Blender, Cycles; minutes) into build/bench_turntable/ and
reused until the rendering code changes; rendering is not part of the timed reconstruction.
The libraries both sides load (Open3D, OpenCV, SciPy, the AprilTag detector) are
imported before the clocks start, so neither side pays for them.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import trimesh

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

SHARED_STAGES = ("poses", "axis")  # TSDF is given ours: charged to both columns


def capture_for(name: str, frames: int, noise_m: float, samples: int) -> Path:
    from test_turntable_accuracy import make_mesh

    from homemodel.geometry.cycles_scene import rendering_code_digest
    from turntable import blender_render, simulate
    from turntable.simulate import SimulationOptions, resimulate_depth, simulate_capture

    cache = ROOT / "build" / "bench_turntable"
    # Rendered again when the code that renders changes.
    digest = rendering_code_digest(blender_render.__file__, simulate.__file__)
    clean = cache / f"{name}_{frames}_s{samples}_{digest}"
    if not (clean / "simulation.json").is_file():
        cache.mkdir(parents=True, exist_ok=True)
        mesh_path = cache / f"{name}.ply"
        make_mesh(name).export(mesh_path)
        options = SimulationOptions(
            frames=frames, width_px=640, height_px=480, samples=samples, camera_distance_m=0.4, camera_height_m=0.5
        )
        print(f"rendering {frames} frames of {name} into {clean} (once)...", flush=True)
        simulate_capture(mesh_path, clean, options, force=True)
    if noise_m <= 0:
        return clean
    noisy = cache / f"{clean.name}_noise{noise_m:g}"
    if not (noisy / "simulation.json").is_file():
        resimulate_depth(clean, noisy, depth_noise_m=noise_m, random_state=1, force=True)
    return noisy


def warm_up() -> None:
    """Import what both sides use, so the first one timed does not pay for the imports."""
    import cv2  # noqa: F401
    import open3d  # noqa: F401
    import pupil_apriltags  # noqa: F401
    import scipy.ndimage  # noqa: F401
    import scipy.optimize  # noqa: F401
    import scipy.spatial  # noqa: F401
    import skimage.measure  # noqa: F401


def tsdf_baseline(capture, result, voxel: float) -> tuple[trimesh.Trimesh, dict[str, float]]:  # noqa: ANN001
    """Open3D TSDF fusion of the same frames, poses and object cylinder; (mesh, CPU seconds of
    reading the frames, of segmenting and integrating them, and of the marching cubes)."""
    import open3d as o3d

    from turntable.capture import read_color, read_depth
    from turntable.fusion import object_pixels

    camera = capture.camera
    start, wall_start = time.process_time(), time.perf_counter()
    reading = reading_wall = 0.0
    cylinder = result.cylinder
    side = 2 * (max(np.ptp(result.mesh.bounds[:, :2], axis=0)) / 2 + 0.02)
    resolution = int(np.ceil(side / voxel))
    origin = np.array([*(result.mesh.bounds[:, :2].mean(axis=0) - side / 2), -0.01])
    volume = o3d.pipelines.integration.UniformTSDFVolume(
        length=side,
        resolution=resolution,
        sdf_trunc=4 * voxel,
        color_type=o3d.pipelines.integration.TSDFVolumeColorType.RGB8,
        origin=origin,
    )
    intrinsic = o3d.camera.PinholeCameraIntrinsic(
        camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy
    )
    rays = camera.pixel_rays().astype(np.float32)
    for frame in capture.frames:
        if frame.stem not in result.poses:
            continue
        camera_from_table = result.poses[frame.stem].camera_from_table
        read_start, read_wall = time.process_time(), time.perf_counter()
        depth = read_depth(frame.depth, camera)
        color = np.ascontiguousarray(read_color(frame.color, camera))
        reading += time.process_time() - read_start
        reading_wall += time.perf_counter() - read_wall
        # The pipeline's own segmentation (above the table top, inside the cylinder), at its
        # cost: a whole-image float64 version of it had cost the TSDF more than its integration.
        pixels, _ = object_pixels(depth, color, rays, np.linalg.inv(camera_from_table), cylinder, drop_flying=False)
        segmented = np.zeros(depth.size, dtype=np.float32)
        segmented[pixels.index] = pixels.depth_m
        rgbd = o3d.geometry.RGBDImage.create_from_color_and_depth(
            o3d.geometry.Image(color),
            o3d.geometry.Image(segmented.reshape(depth.shape)),
            depth_scale=1.0,
            depth_trunc=5.0,
            convert_rgb_to_intensity=False,
        )
        volume.integrate(rgbd, intrinsic, camera_from_table)
    integrated, integrated_wall = time.process_time(), time.perf_counter()
    o3d_mesh = volume.extract_triangle_mesh()
    times = {"read": reading, "integrate": integrated - start - reading, "extract": time.process_time() - integrated}
    walls = {
        "read": reading_wall,
        "integrate": integrated_wall - wall_start - reading_wall,
        "extract": time.perf_counter() - integrated_wall,
    }
    mesh = trimesh.Trimesh(np.asarray(o3d_mesh.vertices), np.asarray(o3d_mesh.triangles))
    return mesh, times, walls


def pose_error_mm_deg(result, capture_dir: Path) -> tuple[float, float]:  # noqa: ANN001
    from homemodel.evaluation import camera_pose_errors
    from homemodel.exchange.cameras import read_cameras, true_cameras_file

    estimated = {stem: pose.camera_from_table for stem, pose in result.poses.items()}
    centres, angles = camera_pose_errors(estimated, read_cameras(true_cameras_file(capture_dir)).poses)
    return float(np.median(centres) * 1000), float(np.median(angles))


@dataclasses.dataclass(kw_only=True)
class Run:
    frames: int
    ours_s: dict[str, float]  # CPU seconds per stage, and "total"
    tsdf_s: dict[str, float]  # CPU seconds: read, integrate, extract
    ours_wall_s: dict[str, float]  # wall seconds, the same keys
    tsdf_wall_s: dict[str, float]
    ours_msd_mm: float
    tsdf_msd_mm: float
    ours_iou: float
    tsdf_iou: float
    pose_mm: float
    pose_deg: float
    watertight: tuple[bool, bool]
    triangles: tuple[int, int]

    def shared_s(self) -> float:
        return sum(self.ours_s.get(stage, 0.0) for stage in SHARED_STAGES)

    def tsdf_total_s(self) -> float:
        return self.shared_s() + sum(self.tsdf_s.values())

    def ratios(self) -> tuple[float, float, float, float]:
        """ours / TSDF: our whole run against the TSDF's own work given our poses (the issue's
        comparison); whole runs, TSDF charged our poses and axis; after the shared stages; the
        same without our texture."""
        ours_after = self.ours_s["total"] - self.shared_s()
        tsdf_after = self.tsdf_s["integrate"] + self.tsdf_s["extract"]
        texture = self.ours_s.get("texture", 0.0)
        return (
            self.ours_s["total"] / sum(self.tsdf_s.values()),
            self.ours_s["total"] / self.tsdf_total_s(),
            ours_after / tsdf_after,
            (ours_after - texture) / tsdf_after,
        )

    def wall_ratio(self) -> float:
        """The issue's comparison in wall seconds: what a user waits for, on idle cores only."""
        return self.ours_wall_s["total"] / sum(self.tsdf_wall_s.values())


class StageCPU:
    """A progress callback noting the process's CPU seconds per stage (the pipeline's own
    `times_s` are wall seconds), and the wall seconds beside."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}
        self.wall: dict[str, float] = {}
        self._stage: str | None = None
        self._start, self._wall = time.process_time(), time.perf_counter()

    def __call__(self, stage: str, done: int, total: int | None) -> None:
        if stage != self._stage:
            self.stop()
            self._stage = stage

    def stop(self) -> None:
        now, wall = time.process_time(), time.perf_counter()
        if self._stage is not None:
            self.seconds[self._stage] = self.seconds.get(self._stage, 0.0) + now - self._start
            self.wall[self._stage] = self.wall.get(self._stage, 0.0) + wall - self._wall
        self._start, self._wall = now, wall


def run_once(capture, capture_dir: Path, truth: trimesh.Trimesh, tsdf_voxel_m: float) -> Run:  # noqa: ANN001
    from threadpoolctl import threadpool_limits

    from homemodel.evaluation import mean_surface_distance_m, voxel_iou
    from turntable.reconstruct import reconstruct_capture

    clock = StageCPU()
    result = reconstruct_capture(capture, progress=clock)
    clock.stop()
    ours = {**clock.seconds, "total": sum(clock.seconds.values())}
    ours_wall = {**clock.wall, "total": sum(clock.wall.values())}
    # One BLAS thread, as the turntable runs: the baseline's per-frame numpy is the same kind
    # of small product, which OpenBLAS's threads slow down many times on a busy machine.
    with threadpool_limits(1, user_api="blas"):
        baseline, tsdf, tsdf_wall = tsdf_baseline(capture, result, tsdf_voxel_m)
    centre_mm, angle_deg = pose_error_mm_deg(result, capture_dir)
    return Run(
        frames=len(result.poses),
        ours_s=ours,
        tsdf_s=tsdf,
        ours_wall_s=ours_wall,
        tsdf_wall_s=tsdf_wall,
        ours_msd_mm=mean_surface_distance_m(result.mesh, truth) * 1000,
        tsdf_msd_mm=mean_surface_distance_m(baseline, truth) * 1000,
        ours_iou=voxel_iou(result.mesh, truth, voxel_size_m=0.002),
        tsdf_iou=voxel_iou(baseline, truth, voxel_size_m=0.002),
        pose_mm=centre_mm,
        pose_deg=angle_deg,
        watertight=(bool(result.mesh.is_watertight), bool(baseline.is_watertight)),
        triangles=(len(result.mesh.faces), len(baseline.faces)),
    )


def median_run(runs: list[Run]) -> Run:
    """Of repeated runs, the one with the median whole-run ratio (the machine's other load makes
    single runs noisy)."""
    return sorted(runs, key=lambda r: r.ratios()[0])[len(runs) // 2]


def _row(label: str, cells: list[str], width: int = 11) -> None:
    print(f"{label:<42}" + "".join(f"{cell:>{width}}" for cell in cells))


def _stage_rows(runs: list[Run], ours_of: Callable[[Run], dict], tsdf_of: Callable[[Run], dict]) -> None:
    def shared(r: Run) -> float:
        return sum(ours_of(r).get(stage, 0.0) for stage in SHARED_STAGES)

    rows = (
        ("poses: read, tags, PnP (shared)", lambda r: ours_of(r).get("poses", 0.0), lambda r: ours_of(r).get("poses", 0.0)),
        ("axis: circle, fit (shared)", lambda r: ours_of(r).get("axis", 0.0), lambda r: ours_of(r).get("axis", 0.0)),
        ("TSDF: reading the frames", None, lambda r: tsdf_of(r)["read"]),
        ("merge | segment + integrate", lambda r: ours_of(r).get("merge", 0.0), lambda r: tsdf_of(r)["integrate"]),
        ("mesh | marching cubes", lambda r: ours_of(r).get("mesh", 0.0), lambda r: tsdf_of(r)["extract"]),
        ("texture (TSDF: none)", lambda r: ours_of(r).get("texture", 0.0), None),
        ("total (TSDF: with our poses and axis)", lambda r: ours_of(r)["total"], lambda r: shared(r) + sum(tsdf_of(r).values())),
    )
    for label, ours, tsdf in rows:
        _row("  " + label, [f"{f(r):.2f}" if f else "-" for r in runs for f in (ours, tsdf)])
    _row("  TSDF given the poses (read+integ+extr)", [c for r in runs for c in ("", f"{sum(tsdf_of(r).values()):.2f}")])


def print_table(runs: list[Run]) -> None:
    heads = [head for r in runs for head in (f"{r.frames} ours", f"{r.frames} TSDF")]
    _row("CPU seconds", heads)
    print("-" * (42 + 11 * len(heads)))
    _stage_rows(runs, lambda r: r.ours_s, lambda r: r.tsdf_s)
    print()
    # Both sides run threads (our frame reading, Open3D's OpenMP integration): on idle cores
    # wall seconds are below CPU seconds; on a loaded machine they say little.
    _row("wall seconds", heads)
    _stage_rows(runs, lambda r: r.ours_wall_s, lambda r: r.tsdf_wall_s)
    print()
    names = (
        "ours whole, TSDF given the poses",
        "whole runs, TSDF charged poses",
        "after poses and axis",
        "the same, ours untextured",
    )
    for i, name in enumerate(names):
        _row(f"ours / TSDF, {name}", [c for r in runs for c in ("", f"{r.ratios()[i]:.2f}")])
    _row("  the first in wall seconds (idle cores)", [c for r in runs for c in ("", f"{r.wall_ratio():.2f}")])
    print()
    _row("accuracy", heads)
    _row("  mean surface dist (mm)", [f"{v:.3f}" for r in runs for v in (r.ours_msd_mm, r.tsdf_msd_mm)])
    _row("  VoxelIOU at 2 mm", [f"{v:.3f}" for r in runs for v in (r.ours_iou, r.tsdf_iou)])
    _row("  watertight", [str(v) for r in runs for v in r.watertight])
    _row("  triangles", [str(v) for r in runs for v in r.triangles])
    # The turntable's poses, which the TSDF integrates too.
    _row("  pose error (median, shared)", [c for r in runs for c in (f"{r.pose_mm:.3f} mm", f"{r.pose_deg:.4f} deg")])


def main() -> None:
    from turntable.capture import load_capture

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--object", default="mug", choices=["box", "cylinder", "mug"])
    parser.add_argument("--frames", type=int, default=200, help="frames rendered (one turn)")
    parser.add_argument("--subsets", type=int, nargs="+", default=[40, 200], help="frames reconstructed, evenly spaced")
    parser.add_argument("--samples", type=int, default=2, help="Cycles samples per pixel of the rendering")
    parser.add_argument("--noise-m", type=float, default=0.0, help="depth noise std at 0.7 m (0: noise-free)")
    parser.add_argument("--repeat", type=int, default=1, help="runs per subset; the median ratio's is shown")
    parser.add_argument(
        "--tsdf-voxel-m", type=float, default=0.0015, help="the TSDF's voxel (default: the merge's; cost ~ 1/voxel^3)"
    )
    parser.add_argument(
        "--capture", type=Path, help="a capture rendered earlier (with true_cameras.json, ground_truth.ply): no rendering"
    )
    args = parser.parse_args()
    if any(n > args.frames or args.frames % n for n in args.subsets):
        parser.error(f"--subsets {args.subsets}: each must divide --frames {args.frames}")
    if not args.tsdf_voxel_m > 0:
        parser.error(f"--tsdf-voxel-m {args.tsdf_voxel_m:g}: must be a positive length in metres")

    capture_dir = args.capture or capture_for(args.object, args.frames, args.noise_m, args.samples)
    truth = trimesh.load(capture_dir / "ground_truth.ply", force="mesh")
    capture = load_capture(capture_dir)
    warm_up()
    runs = []
    for n in args.subsets:
        subset = dataclasses.replace(capture, frames=capture.frames[:: args.frames // n])
        runs.append(median_run([run_once(subset, capture_dir, truth, args.tsdf_voxel_m) for _ in range(args.repeat)]))
    noise_mm = args.noise_m * 1000
    print(f"\n{args.object}, 640x480, depth noise {noise_mm:g} mm at 0.7 m, frames evenly spaced over one turn, "
          f"TSDF voxel {args.tsdf_voxel_m * 1000:g} mm; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    print_table(runs)


if __name__ == "__main__":
    main()
