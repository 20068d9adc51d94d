"""Benchmark: spec -> Blender build -> URDF/glTF export -> validation gate, per kitchen object.

Baselines in the same run (these machines are shared and noisy, so ratios matter more
than seconds): trimesh's own glTF export of the same meshes beside our exporter, and a
bare pybullet load of the URDF beside our whole validation gate.

Run: .venv/bin/python benchmarks/bench_build.py [--repeat 3]
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

from articulation.export import write_model_files
from articulation.validate import validate_path
from modeller import build_model

EXAMPLES = Path(__file__).resolve().parent.parent / "examples" / "kitchen"


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
    args = parser.parse_args()
    specs = sorted(p for p in EXAMPLES.glob("*.yaml") if p.name != "home.yaml")
    build_model(specs[0])  # warm: the first bpy call loads Blender
    table = Table(title=f"spec to validated model, median of {args.repeat} (seconds)")
    for column in ("spec", "build", "export", "trimesh glb", "export/trimesh", "validate", "pybullet load", "total"):
        table.add_column(column, justify="left" if column == "spec" else "right")
    with tempfile.TemporaryDirectory() as tmp:
        for spec in specs:
            runs: dict[str, list[float]] = {}
            for r in range(args.repeat):
                folder = Path(tmp) / f"{spec.stem}_{r}"
                model = None

                def build() -> None:
                    nonlocal model
                    model = build_model(spec)

                for stage, fn in (
                    ("build", build),
                    ("export", lambda: write_model_files(model, folder)),
                    ("trimesh", lambda: _trimesh_glb(model, folder / "baseline.glb")),
                    ("validate", lambda: validate_path(folder)),
                    ("pybullet", lambda: _pybullet_load(folder / "model.urdf")),
                ):
                    runs.setdefault(stage, []).append(_timed(fn))
            med = {stage: statistics.median(times) for stage, times in runs.items()}
            total = med["build"] + med["export"] + med["validate"]
            table.add_row(
                spec.stem,
                f"{med['build']:.3f}",
                f"{med['export']:.3f}",
                f"{med['trimesh']:.3f}",
                f"{med['export'] / med['trimesh']:.2f}x",
                f"{med['validate']:.3f}",
                f"{med['pybullet']:.3f}",
                f"{total:.3f}",
            )
    Console().print(table)


if __name__ == "__main__":
    main()
