"""Benchmark: spec -> Blender build -> URDF/glTF export -> validation gate, per spec of the
catalogue (every kind) and of the photo-textured examples.

Baselines in the same run (these machines are shared and noisy, so ratios matter more
than seconds): trimesh's own glTF export of the same meshes beside our glb writer, and a
bare pybullet load of the URDF beside our whole validation gate (which also runs
check_urdf, yourdfpy, the pybullet joint sweeps and the Khronos validator in node).

Run: .venv/bin/python benchmarks/bench_build.py [--repeat 3] [SPEC_FOLDER ...]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import trimesh
from rich.console import Console
from rich.table import Table

from homemodel.exchange.gltf import glb_bytes
from homemodel.exchange.urdf.write import write_urdf
from homemodel.model_folder.gate.validate import validate_path
from modeller import build_model

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
DEFAULT_FOLDERS = (EXAMPLES / "catalogue", EXAMPLES / "textured")


def _timed(fn) -> float:
    started = time.perf_counter()
    fn()
    return time.perf_counter() - started


def _trimesh_glb(model, path: Path) -> None:
    scene = trimesh.Scene()
    for link, world_from_link in model.world_from_links().items():
        for visual in model.link(link).visuals:
            scene.add_geometry(visual.mesh, transform=world_from_link @ visual.link_from_visual)
    path.write_bytes(scene.export(file_type="glb"))


def _pybullet_load(urdf: Path) -> None:
    import pybullet

    client = pybullet.connect(pybullet.DIRECT)
    try:
        pybullet.loadURDF(str(urdf), useFixedBase=True, physicsClientId=client)
    finally:
        pybullet.disconnect(client)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs per object; the median is shown")
    parser.add_argument("folders", nargs="*", type=Path, default=DEFAULT_FOLDERS, help="folders of specs")
    args = parser.parse_args()
    specs = [p for folder in args.folders for p in sorted(folder.glob("*.yaml")) if p.name != "home.yaml"]
    build_model(specs[0])  # warm: the first bpy call loads Blender
    table = Table(title=f"spec to validated model, median of {args.repeat} (seconds)")
    for column in ("spec", "build", "urdf+obj", "glb", "trimesh glb", "glb/trimesh", "validate", "pybullet load", "total"):
        table.add_column(column, justify="left" if column == "spec" else "right")
    with tempfile.TemporaryDirectory() as tmp:
        for spec in specs:
            runs: dict[str, list[float]] = {}
            for r in range(args.repeat):
                folder = Path(tmp) / f"{spec.parent.name}_{spec.stem}_{r}"
                model = None

                def build() -> None:
                    nonlocal model
                    model = build_model(spec)

                for stage, fn in (
                    ("build", build),
                    ("urdf", lambda: write_urdf(model, folder)),
                    ("glb", lambda: (folder / "model.glb").write_bytes(glb_bytes(model))),
                    ("trimesh", lambda: _trimesh_glb(model, folder / "baseline.glb")),
                    ("validate", lambda: validate_path(folder)),
                    ("pybullet", lambda: _pybullet_load(folder / "model.urdf")),
                ):
                    runs.setdefault(stage, []).append(_timed(fn))
            med = {stage: statistics.median(times) for stage, times in runs.items()}
            total = med["build"] + med["urdf"] + med["glb"] + med["validate"]
            table.add_row(
                f"{spec.parent.name}/{spec.stem}",
                f"{med['build']:.3f}",
                f"{med['urdf']:.3f}",
                f"{med['glb']:.3f}",
                f"{med['trimesh']:.3f}",
                f"{med['glb'] / med['trimesh']:.2f}x",
                f"{med['validate']:.3f}",
                f"{med['pybullet']:.3f}",
                f"{total:.3f}",
            )
    Console(width=130).print(table)


if __name__ == "__main__":
    main()
