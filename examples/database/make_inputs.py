"""How the generated inputs of examples/database/manifest.yaml were made (they are kept in the
repository, under inputs/, so the example builds on a fresh clone with no prior step): a
simulated turntable capture of a cup (Blender, Cycles on the CPU), and a small shape-completion
model with one depth-image query of a cup it has never seen.

    python examples/database/make_inputs.py                 # rewrites examples/database/inputs/

Both are kept small (12 frames of 320x240; a forest trained on 12 procedural shapes) so the
repository stays light; make your own larger ones with `homemodel turntable simulate` and
`homemodel completion train`. The PartNet-Mobility-style cabinet is kept in the repository too
(partnet_cabinet/, written by tests/partnet_sample.py); the photos are the shared Kermit set.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

from homemodel.geometry.camera import Camera, save_camera
from homemodel.geometry.depth_io import write_depth
from homemodel.geometry.raycast import RayCaster
from shape_completion.library import load_library, write_procedural_library
from shape_completion.model_io import save_model
from shape_completion.pipeline import ShapeCompleter
from shape_completion.procedural import generate_instances
from shape_completion.queries import random_query_pose
from turntable.simulate import SimulationOptions, simulate_capture

INPUTS = Path(__file__).resolve().parent / "inputs"
QUERY_CAMERA = Camera(width=320, height=240, fx=290.0, fy=290.0, cx=159.5, cy=119.5, depth_scale_m=0.0001)


def make_capture(out: Path, work: Path) -> None:
    cup = generate_instances("cup", 1, seed=7)[0]
    mesh_path = work / "cup_for_turntable.ply"
    cup.export(mesh_path)
    options = SimulationOptions(frames=12, width_px=320, height_px=240, horizontal_fov_deg=45.0, samples=8)
    simulate_capture(mesh_path, out / "capture", options, force=True)
    (out / "capture" / "ground_truth.ply").unlink()  # the truth's mesh is not an input (and is large)


def make_completion(out: Path, work: Path) -> None:
    write_procedural_library(work / "library", classes=["bowl", "cup", "glass"], per_class=4, seed=0)
    completer = ShapeCompleter(n_views=8, n_trees=20, filler_queries_per_class=4, random_state=0)
    save_model(completer.fit(load_library(work / "library")), out / "completer.npz")
    unseen = generate_instances("cup", 1, seed=99)[0]
    camera_from_object = random_query_pose(unseen, np.random.default_rng(3))
    unseen.apply_transform(camera_from_object)  # the query's frame is the camera's
    depth = RayCaster(unseen).depth(QUERY_CAMERA, np.eye(4))
    (out / "query").mkdir(parents=True, exist_ok=True)
    write_depth(out / "query" / "depth.png", depth, depth_scale_m=QUERY_CAMERA.depth_scale_m)
    save_camera(QUERY_CAMERA, out / "query" / "camera.yaml")


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else INPUTS
    target.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="db-inputs-") as tmp:
        make_completion(target, Path(tmp))
        make_capture(target, Path(tmp))
    print(f"inputs written to {target}")
