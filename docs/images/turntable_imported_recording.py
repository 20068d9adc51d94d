"""Draw `turntable_imported_recording.png`: a box recorded as a ROS 1 bag with a real camera's
faults (the tests' recording simulator, tests/recording_sim.py), imported and reconstructed with
the README's two commands, beside its truth.

    .venv/bin/python docs/images/turntable_imported_recording.py
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

import matplotlib
import numpy as np
import trimesh

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
OUT = Path(__file__).with_name("turntable_imported_recording.png")
BOX_M = (0.12, 0.08, 0.15)
CAPTURE = dict(
    frames=36, width_px=640, height_px=360, horizontal_fov_deg=69.0, renderer="raycast",
    camera_distance_m=0.4, camera_height_m=0.6, tag_size_m=0.04,
)
LIGHT = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])


def _homemodel(*args: object) -> None:
    subprocess.run([sys.executable, "-m", "homemodel", *map(str, args)], cwd=REPO, check=True, capture_output=True)


def _record(root: Path) -> Path:
    """The clean capture, then its ROS 1 bag with the faults the caption lists."""
    sys.path.insert(0, str(REPO / "tests"))
    import recording_sim as rsim
    from homemodel.geometry.camera import load_camera
    from turntable.simulate import SimulationOptions, simulate_capture

    box = trimesh.creation.box(BOX_M)
    box = trimesh.Trimesh(*trimesh.remesh.subdivide_to_size(box.vertices, box.faces, 0.012))
    box.visual.vertex_colors = np.column_stack(
        [(0.5 + 2 * box.vertices).clip(0, 1) * 255, np.full(len(box.vertices), 255)]
    ).astype(np.uint8)
    box.export(root / "box.ply")
    clean = simulate_capture(root / "box.ply", root / "clean", SimulationOptions(**CAPTURE)).out_dir
    camera = load_camera(clean / "camera.yaml")
    rig = rsim.Rig(
        color_camera=rsim.distorted(camera, distortion=(0.04, -0.01, 0.001, -0.001, 0.0)),
        depth_camera=rsim.depth_camera_for(camera, width=320, height=240, hfov_deg=80.0),
        color_from_depth=rsim.baseline(),
        depth_scale_m=0.001,
        period_s=1.0,
    )
    rsim.write_rosbag(rsim.record(clean, rig, blurred=(4, 15)), root / "recording.bag", ros_version=1)
    return clean


def _panel(fig: plt.Figure, k: int, mesh: trimesh.Trimesh, title: str, limits: np.ndarray) -> None:
    ax = fig.add_subplot(1, 2, k, projection="3d")
    shade = 0.35 + 0.6 * np.abs(mesh.face_normals @ LIGHT)
    ax.add_collection3d(
        Poly3DCollection(1000 * mesh.vertices[mesh.faces], facecolors=np.repeat(shade[:, None], 3, 1), linewidths=0)
    )
    for set_lim, (lo, hi) in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), limits):
        set_lim(lo, hi)
    ax.set_box_aspect(limits[:, 1] - limits[:, 0])
    ax.set_xlabel("x mm")
    ax.set_ylabel("y mm")
    ax.set_zlabel("z mm")
    ax.set_title(title, fontsize=9)


def main() -> None:
    from homemodel.evaluation import mean_surface_distance_m

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        clean = _record(root)
        _homemodel("turntable", "import", root / "recording.bag", "--board", clean / "board.yaml", "--out", root / "scan")
        _homemodel("turntable", "reconstruct", root / "scan", "--out", root / "model")
        truth = trimesh.load(clean / "ground_truth.ply", force="mesh")
        result = trimesh.load(root / "model" / "mesh.ply", force="mesh")
    distance_mm = 1000 * mean_surface_distance_m(result, truth)
    both = np.vstack([truth.vertices, result.vertices]) * 1000
    centre, half = (both.min(0) + both.max(0)) / 2, (both.max(0) - both.min(0)).max() / 2 + 5
    limits = np.array([[centre[0] - half, centre[0] + half], [centre[1] - half, centre[1] + half], [0, 2 * half]])
    fig = plt.figure(figsize=(9, 4.6))
    fig.suptitle(
        f"A {' x '.join(str(round(1000 * s)) for s in BOX_M)} mm box. The ROS 1 bag: 640x360 Brown-Conrady colour, "
        "320x240 depth in its own frame (15 mm, 0.6 deg away), 1 mm units,\nstructured-light noise, flying pixels, "
        "3 % dropped frames, 20 ms jitter, 2 blurred frames",
        fontsize=8,
    )
    _panel(fig, 1, truth, "truth (ground_truth.ply)", limits)
    _panel(fig, 2, result, f"imported ROS 1 bag, reconstructed: {distance_mm:.2f} mm mean distance", limits)
    fig.savefig(OUT, dpi=100)
    print(f"wrote {OUT} ({distance_mm:.3f} mm)")


if __name__ == "__main__":
    main()
