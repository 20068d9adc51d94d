"""Make the inputs of examples/database/manifest.yaml that are too large to keep in the
repository: a simulated turntable capture of a cup (Blender, Cycles on the CPU), and a small
shape-completion model with one depth-image query of a cup it has never seen.

    python examples/database/make_inputs.py build/db_inputs      # about 2 minutes, once

The PartNet-Mobility-style cabinet is kept in the repository (partnet_cabinet/, written by
tests/partnet_sample.py); the photos are the shared Kermit set.
"""

from __future__ import annotations

import sys
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

QUERY_CAMERA = Camera(width=320, height=240, fx=290.0, fy=290.0, cx=159.5, cy=119.5, depth_scale_m=0.0001)


def make_capture(out: Path) -> None:
    cup = generate_instances("cup", 1, seed=7)[0]
    mesh_path = out / "cup_for_turntable.ply"
    mesh_path.parent.mkdir(parents=True, exist_ok=True)
    cup.export(mesh_path)
    simulate_capture(mesh_path, out / "capture", SimulationOptions(frames=24, width_px=480, height_px=360, samples=8), force=True)


def make_completion(out: Path) -> None:
    write_procedural_library(out / "library", classes=["bowl", "cup", "glass"], per_class=6, seed=0)
    completer = ShapeCompleter(n_views=16, filler_queries_per_class=6, random_state=0).fit(load_library(out / "library"))
    save_model(completer, out / "completer.npz")
    unseen = generate_instances("cup", 1, seed=99)[0]
    camera_from_object = random_query_pose(unseen, np.random.default_rng(3))
    unseen.apply_transform(camera_from_object)  # the query's frame is the camera's
    depth = RayCaster(unseen).depth(QUERY_CAMERA, np.eye(4))
    (out / "query").mkdir(parents=True, exist_ok=True)
    write_depth(out / "query" / "depth.png", depth, depth_scale_m=QUERY_CAMERA.depth_scale_m)
    save_camera(QUERY_CAMERA, out / "query" / "camera.yaml")


if __name__ == "__main__":
    target = Path(sys.argv[1] if len(sys.argv) > 1 else "build/db_inputs")
    make_completion(target)
    make_capture(target)
    print(f"inputs written to {target}")
