"""Draw `scan_meshes.png`: one of the real Kermit photos, the visual mesh `homemodel
photogrammetry reconstruct` makes from the 11 photos (textured, full detail), and the convex
collision parts beside it, each part in its own colour, from the same view.

    .venv/bin/python docs/images/scan_meshes.py [--model MODEL_DIR]

Without --model it reconstructs ../shared/data/photogrammetry/kermit first (a few minutes).
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
from lxml import etree

REPO = Path(__file__).resolve().parents[2]
PHOTOS = REPO.parent / "shared" / "data" / "photogrammetry" / "kermit"
OUT = Path(__file__).with_name("scan_meshes.png")
SIZE = 480


def _view(plotter, mesh: trimesh.Trimesh) -> None:
    """Looking at the front of the model (-y side in homemodel's frame), a little from above."""
    centre = mesh.bounds.mean(axis=0)
    reach = float(np.linalg.norm(mesh.extents))
    plotter.camera_position = [tuple(centre + reach * np.array([0.35, -1.6, 0.55])), tuple(centre), (0, 0, 1)]


def _visual(folder: Path, obj: Path) -> np.ndarray:
    import pyvista as pv

    mesh = trimesh.load(folder / obj, force="mesh", process=False)
    plotter = pv.Plotter(off_screen=True, window_size=(SIZE, SIZE))
    wrapped = pv.wrap(trimesh.Trimesh(mesh.vertices, mesh.faces, process=False))
    texture_files = sorted((folder / "meshes").glob("*_texture.png"))
    uv = getattr(mesh.visual, "uv", None)
    if texture_files and uv is not None:
        wrapped.active_texture_coordinates = np.asarray(uv, dtype=np.float32)
        plotter.add_mesh(wrapped, texture=pv.read_texture(str(texture_files[0])), smooth_shading=True)
    else:
        plotter.add_mesh(wrapped, color="lightgrey", smooth_shading=True)
    _view(plotter, mesh)
    plotter.add_text(f"visual: {len(mesh.faces):,} faces", font_size=11)
    image = plotter.screenshot(return_img=True)
    plotter.close()
    return image, mesh


def _parts(folder: Path, files: list[str], visual: trimesh.Trimesh, summary: dict) -> np.ndarray:
    import pyvista as pv

    plotter = pv.Plotter(off_screen=True, window_size=(SIZE, SIZE))
    colours = np.random.default_rng(3).uniform(0.25, 0.95, (len(files), 3))
    for colour, name in zip(colours, files, strict=True):
        part = trimesh.load(folder / name, force="mesh")
        plotter.add_mesh(pv.wrap(part), color=colour, show_edges=True, edge_color="black", line_width=0.5)
    _view(plotter, visual)
    c = summary["meshes"]["collision"]
    unit = 1000.0 if summary["metric"] else 100.0 / float(np.linalg.norm(visual.extents))
    suffix = "mm" if summary["metric"] else "% of size"
    plotter.add_text(
        f"collision: {c['parts']} convex parts\n95% within {max(c['overshoot_p95'], c['gap_p95']) * unit:.1f} {suffix}",
        font_size=11,
    )
    image = plotter.screenshot(return_img=True)
    plotter.close()
    return image


def _photo(path: Path) -> np.ndarray:
    import cv2

    photo = cv2.cvtColor(cv2.imread(str(path)), cv2.COLOR_BGR2RGB)
    scale = SIZE / max(photo.shape[:2])
    photo = cv2.resize(photo, (round(photo.shape[1] * scale), round(photo.shape[0] * scale)), interpolation=cv2.INTER_AREA)
    canvas = np.full((SIZE, SIZE, 3), 255, np.uint8)
    top, left = (SIZE - photo.shape[0]) // 2, (SIZE - photo.shape[1]) // 2
    canvas[top : top + photo.shape[0], left : left + photo.shape[1]] = photo
    return canvas


def draw(folder: Path) -> None:
    import cv2

    urdf = etree.parse(str(folder / "model.urdf"))
    visual_obj = Path(urdf.find("link/visual/geometry/mesh").get("filename"))
    parts = [e.get("filename") for e in urdf.findall("link/collision/geometry/mesh")]
    summary = json.loads((folder / "summary.json").read_text())
    visual_image, visual = _visual(folder, visual_obj)
    panels = [_photo(sorted(PHOTOS.glob("*.jpg"))[0]), visual_image, _parts(folder, parts, visual, summary)]
    cv2.imwrite(str(OUT), cv2.cvtColor(np.hstack(panels), cv2.COLOR_RGB2BGR))
    print(f"wrote {OUT}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", type=Path, help="a model folder of the Kermit photos (default: reconstruct them)")
    args = parser.parse_args()
    if args.model is not None:
        draw(args.model)
        return
    with tempfile.TemporaryDirectory() as work:
        folder = Path(work) / "kermit"
        command = [sys.executable, "-m", "homemodel", "photogrammetry", "reconstruct", str(PHOTOS), "--out", str(folder)]
        subprocess.run(command, cwd=REPO, check=True, capture_output=True)
        draw(folder)


if __name__ == "__main__":
    main()
