"""Benchmark: what photo texturing costs, per textured example (examples/textured/).

For each spec, in one warm process: the Blender build with its photos (read, find the
face, rectify, UV-map, texture) beside the same spec built without photos (the
baseline; the ratio is what texturing adds), the export (URDF + OBJ/MTL + textures,
glb), and the validation gate; then the comparison picture alone.

Run: .venv/bin/python benchmarks/bench_textures.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from rich.console import Console
from rich.table import Table

from homemodel.exchange.model_files import write_model_files
from homemodel.model_folder.gate.validate import validate_path
from modeller.build import build_textured
from modeller.comparison_picture import PictureOptions, comparison_picture
from modeller.spec_loading import load_spec

EXAMPLES = Path(__file__).resolve().parent.parent / "examples" / "textured"


def _median_s(fn: Callable[[], object], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        started = time.perf_counter()
        fn()
        times.append(time.perf_counter() - started)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs per step; the median is shown")
    args = parser.parse_args()
    specs = sorted(EXAMPLES.glob("*.yaml"))
    table = Table(title=f"photo textures, median of {args.repeat} (s)")
    for column in ("spec", "photos", "plain build", "textured build", "ratio", "export", "gate", "picture", "total"):
        table.add_column(column, justify="left" if column == "spec" else "right")
    build_textured(load_spec(specs[0]), "warm", spec_path=specs[0])  # the first bpy call loads Blender
    with tempfile.TemporaryDirectory() as tmp:
        for path in specs:
            spec = load_spec(path)
            plain = spec.model_copy(update={"photos": []})
            plain_s = _median_s(lambda: build_textured(plain, path.stem, spec_path=path), args.repeat)
            textured_s = _median_s(lambda: build_textured(spec, path.stem, spec_path=path), args.repeat)
            built = build_textured(spec, path.stem, spec_path=path)
            folder = Path(tmp) / path.stem
            export_s = _median_s(lambda: write_model_files(built.model, folder), args.repeat)
            gate_s = _median_s(lambda: validate_path(folder), 1)
            options = PictureOptions(panel_height_px=240, three_quarter_view=False)
            picture_s = _median_s(
                lambda: comparison_picture(built.model, built.photos[0], folder / "picture.png", options), args.repeat
            )
            table.add_row(
                path.stem,
                str(len(spec.photos)),
                f"{plain_s:.3f}",
                f"{textured_s:.3f}",
                f"{textured_s / plain_s:.2f}",
                f"{export_s:.3f}",
                f"{gate_s:.3f}",
                f"{picture_s:.3f}",
                f"{textured_s + export_s + gate_s:.3f}",
            )
    Console(width=None if sys.stdout.isatty() else 120).print(table)


if __name__ == "__main__":
    main()
