"""Benchmark: turntable reconstruction of a simulated 200-frame 640x480 capture, per stage,
beside a baseline run in the same process on the same frames and poses: Open3D's TSDF
integration (UniformTSDFVolume) of the segmented depth, marching cubes.

    .venv/bin/python benchmarks/bench_turntable.py [--object mug] [--frames 200] [--noise-m 0.0015]

The capture is rendered once (Blender, Cycles; minutes) into build/bench_turntable/ and
reused until the rendering code changes; rendering is not part of the timed reconstruction.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import trimesh

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))


def capture_for(name: str, frames: int, noise_m: float) -> Path:
    from test_turntable_accuracy import make_mesh

    from homemodel.geometry.cycles_scene import rendering_code_digest
    from turntable import blender_render, simulate
    from turntable.simulate import SimulationOptions, resimulate_depth, simulate_capture

    cache = ROOT / "build" / "bench_turntable"
    # Rendered again when the code that renders changes.
    clean = cache / f"{name}_{frames}_{rendering_code_digest(blender_render.__file__, simulate.__file__)}"
    if not (clean / "simulation.json").is_file():
        cache.mkdir(parents=True, exist_ok=True)
        mesh_path = cache / f"{name}.ply"
        make_mesh(name).export(mesh_path)
        options = SimulationOptions(
            frames=frames, width_px=640, height_px=480, samples=8, camera_distance_m=0.4, camera_height_m=0.5
        )
        print(f"rendering {frames} frames of {name} into {clean} (once)...", flush=True)
        simulate_capture(mesh_path, clean, options, force=True)
    if noise_m <= 0:
        return clean
    noisy = cache / f"{clean.name}_noise{noise_m:g}"
    if not (noisy / "simulation.json").is_file():
        resimulate_depth(clean, noisy, depth_noise_m=noise_m, random_state=1, force=True)
    return noisy


def tsdf_baseline(capture_dir: Path, result) -> tuple[trimesh.Trimesh, float]:  # noqa: ANN001
    """Open3D TSDF fusion of the same frames, poses and object cylinder; (mesh, seconds)."""
    import open3d as o3d

    from turntable.capture import load_capture, read_color, read_depth

    capture = load_capture(capture_dir)
    camera = capture.camera
    start = time.perf_counter()
    cylinder = result.cylinder
    voxel = 0.0015
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
    rays = camera.pixel_rays()
    for frame in capture.frames:
        if frame.stem not in result.poses:
            continue
        camera_from_table = result.poses[frame.stem].camera_from_table
        depth = read_depth(frame.depth, camera)
        # The same segmentation as the pipeline: above the table top, inside the cylinder.
        points = rays * depth.reshape(-1, 1)
        table = points @ np.linalg.inv(camera_from_table)[:3, :3].T + np.linalg.inv(camera_from_table)[:3, 3]
        radial = np.hypot(table[:, 0] - cylinder.axis_xy_m[0], table[:, 1] - cylinder.axis_xy_m[1])
        keep = (table[:, 2] > cylinder.z_min_m) & (radial < cylinder.radius_m)
        depth = np.where(keep.reshape(depth.shape), depth, 0.0).astype(np.float32)
        rgbd = o3d.geometry.RGBDImage.create_from_color_and_depth(
            o3d.geometry.Image(np.ascontiguousarray(read_color(frame.color, camera))),
            o3d.geometry.Image(np.nan_to_num(depth)),
            depth_scale=1.0,
            depth_trunc=5.0,
            convert_rgb_to_intensity=False,
        )
        volume.integrate(rgbd, intrinsic, camera_from_table)
    o3d_mesh = volume.extract_triangle_mesh()
    seconds = time.perf_counter() - start
    mesh = trimesh.Trimesh(np.asarray(o3d_mesh.vertices), np.asarray(o3d_mesh.triangles))
    return mesh, seconds


def pose_error_mm_deg(result, capture_dir: Path) -> tuple[float, float]:  # noqa: ANN001
    from homemodel.evaluation import camera_pose_errors
    from turntable.poses_io import read_poses

    estimated = {stem: pose.camera_from_table for stem, pose in result.poses.items()}
    centres, angles = camera_pose_errors(estimated, read_poses(capture_dir / "true_poses.json"))
    return float(np.median(centres) * 1000), float(np.median(angles))


def main() -> None:
    from homemodel.evaluation import mean_surface_distance_m, voxel_iou
    from turntable.capture import load_capture
    from turntable.reconstruct import reconstruct_capture

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--object", default="mug", choices=["box", "cylinder", "mug"])
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--noise-m", type=float, default=0.0, help="depth noise std at 0.7 m (0: noise-free)")
    args = parser.parse_args()

    capture_dir = capture_for(args.object, args.frames, args.noise_m)
    truth = trimesh.load(capture_dir / "ground_truth.ply", force="mesh")
    start = time.perf_counter()
    result = reconstruct_capture(load_capture(capture_dir))
    total = time.perf_counter() - start
    baseline, baseline_s = tsdf_baseline(capture_dir, result)

    ours_msd = mean_surface_distance_m(result.mesh, truth) * 1000
    base_msd = mean_surface_distance_m(baseline, truth) * 1000
    ours_iou = voxel_iou(result.mesh, truth, voxel_size_m=0.002)
    base_iou = voxel_iou(baseline, truth, voxel_size_m=0.002)
    centre_mm, angle_deg = pose_error_mm_deg(result, capture_dir)
    summary = result.summary()
    print(
        f"\n{args.object}: {summary['frames_used']} of {summary['frames_total']} frames, 640x480, depth noise {args.noise_m * 1000:g} mm at 0.7 m"
    )
    print(f"{'stage':<28}{'seconds':>10}")
    for stage, seconds in summary["times_s"].items():
        print(f"{'  ' + stage:<28}{seconds:>10.2f}")
    print(f"{'turntable total':<28}{total:>10.2f}")
    print(f"{'TSDF baseline (same poses)':<28}{baseline_s:>10.2f}")
    print(f"\n{'':<26}{'turntable':>12}{'TSDF':>12}{'ratio':>10}")
    print(f"{'time (s)':<26}{total:>12.2f}{baseline_s:>12.2f}{total / baseline_s:>10.2f}")
    print(f"{'mean surface dist (mm)':<26}{ours_msd:>12.3f}{base_msd:>12.3f}{ours_msd / base_msd:>10.2f}")
    print(f"{'VoxelIOU at 2 mm':<26}{ours_iou:>12.3f}{base_iou:>12.3f}{ours_iou / max(base_iou, 1e-9):>10.2f}")
    print(f"{'watertight':<26}{str(result.mesh.is_watertight):>12}{str(baseline.is_watertight):>12}")
    print(f"{'triangles':<26}{len(result.mesh.faces):>12}{len(baseline.faces):>12}")
    print(f"pose error (median): {centre_mm:.3f} mm, {angle_deg:.4f} deg")


if __name__ == "__main__":
    main()
