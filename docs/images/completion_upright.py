"""Draw `completion_upright.png`: a robot's depth image of an unseen mug on a table, the mug
`homemodel completion run` completes from it (written upright: +z up, origin on the table
under the mug, from the camera's pose in camera.yaml), and the true mug in the same frame.

    .venv/bin/python docs/images/completion_upright.py [--model MODEL.npz]

Without --model it writes the generated library and trains on it first (a few minutes).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import trimesh
import yaml

REPO = Path(__file__).resolve().parents[2]
OUT = Path(__file__).with_name("completion_upright.png")


def _homemodel(*args: str) -> None:
    subprocess.run([sys.executable, "-m", "homemodel", *map(str, args)], cwd=REPO, check=True, capture_output=True)


def _shaded(mesh: trimesh.Trimesh, colour: str, title: str) -> np.ndarray:
    import pyvista as pv

    plotter = pv.Plotter(off_screen=True, window_size=(420, 420))
    plotter.add_mesh(pv.wrap(mesh), color=colour, smooth_shading=True)
    floor = pv.Plane(center=(0, 0, 0), direction=(0, 0, 1), i_size=0.25, j_size=0.25, i_resolution=10, j_resolution=10)
    plotter.add_mesh(floor, color="white", show_edges=True, edge_color="grey", opacity=0.6)
    # +z of the frame, from the origin on the table
    plotter.add_mesh(pv.Arrow(start=(0, 0, 0), direction=(0, 0, 1), scale=0.16, tip_length=0.15, shaft_radius=0.01),
                     color="red")  # fmt: skip
    plotter.add_text(title, font_size=11, color="black")
    plotter.set_background("white")
    plotter.camera_position = [(0.32, -0.38, 0.22), (0.0, 0.0, 0.05), (0.0, 0.0, 1.0)]
    image = plotter.screenshot(return_img=True)
    plotter.close()
    return image


def main() -> None:
    import cv2

    from homemodel.core.transforms import world_from_camera_looking_at
    from homemodel.geometry.depth_io import write_depth
    from homemodel.geometry.mesh_io import load_mesh
    from homemodel.geometry.raycast import RayCaster
    from shape_completion.procedural import generate_instances
    from shape_completion.queries import FILLER_CAMERA

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", type=Path, help="a trained model file (default: train one)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        model = args.model
        if model is None:
            _homemodel("completion", "library", "--out", tmp / "library")
            _homemodel("completion", "train", tmp / "library", "--out", tmp / "model.npz")
            model = tmp / "model.npz"
        mug = generate_instances("cup", 30, seed=7)[24]  # the library holds instances 0-19 of seed 0
        table = trimesh.creation.box(extents=(1.2, 1.2, 0.03)).apply_translation((0.1, 0.2, -0.015))
        world_from_camera = world_from_camera_looking_at((0.45, -0.35, 0.4), (0.0, 0.0, 0.05))
        camera_from_world = np.linalg.inv(world_from_camera)
        depth = RayCaster(trimesh.util.concatenate([mug, table])).depth(FILLER_CAMERA, camera_from_world)
        write_depth(tmp / "depth.png", depth, depth_scale_m=FILLER_CAMERA.depth_scale_m)
        camera = FILLER_CAMERA.model_dump(exclude_none=True) | {"map_from_camera": world_from_camera.tolist()}
        (tmp / "camera.yaml").write_text(yaml.safe_dump(camera))
        _homemodel("completion", "run", model, tmp / "depth.png", "--camera", tmp / "camera.yaml", "--out", tmp / "out")
        completed = load_mesh(tmp / "out")
        summary = json.loads((tmp / "out" / "summary.json").read_text())["completion"]
    object_from_world = np.linalg.inv(np.array(summary["camera_from_object"])) @ camera_from_world
    truth = mug.copy().apply_transform(object_from_world)
    scaled = np.clip((np.nan_to_num(depth, nan=2.0) - 0.3) / 0.6, 0, 1)
    depth_picture = cv2.applyColorMap((255 * (1 - scaled)).astype(np.uint8), cv2.COLORMAP_TURBO)[..., ::-1]
    depth_picture[~np.isfinite(depth)] = 0
    depth_picture = cv2.resize(depth_picture, (560, 420), interpolation=cv2.INTER_NEAREST)
    cv2.putText(depth_picture, "depth image (mug on a table)", (8, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (255, 255, 255), 1)
    panels = [
        depth_picture,
        _shaded(completed, "lightsteelblue", f"completed ({summary['class']}), up from {summary['up_from']}"),
        _shaded(truth, "burlywood", "true mug, same frame"),
    ]
    cv2.imwrite(str(OUT), cv2.cvtColor(np.concatenate(panels, axis=1), cv2.COLOR_RGB2BGR))
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
