"""A class library: a folder of mesh files per class, and its fingerprint.

```
LIBRARY/cup/any_name.obj    # .obj .stl .ply .off .glb .gltf, metres, z up, standing on z = 0
LIBRARY/bottle/...
```

The fingerprint hashes every mesh file's bytes with its class and name, so a model trained
on one version of a library is refused for another.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from homemodel.core.atomic import write_bytes_atomic
from homemodel.core.errors import InputError
from homemodel.geometry.mesh_io import MAX_MESH_BYTES, MESH_SUFFIXES, load_mesh
from homemodel.geometry.mesh_ops import decimate
from homemodel.core.input_files import read_bounded
from shape_completion.procedural import GENERATORS, generate_instances

# Outside this range a mesh is most likely in millimetres (or kilometres), not metres.
MIN_SIZE_M, MAX_SIZE_M = 0.005, 2.0
# Scanned or downloaded meshes often carry hundreds of thousands of triangles, and a query's
# time grows with them (the spline moves every vertex, carving samples every face): on
# generated shapes subdivided to 180,000-370,000 triangles, the slowest query took 4.75 s,
# and 2.25 s after simplifying to this many, with a VoxelIOU over 0.99 to the originals.
MAX_WORKING_TRIANGLES = 5_000


@dataclass(kw_only=True)
class LibraryMesh:
    class_name: str
    name: str
    mesh: trimesh.Trimesh


@dataclass(kw_only=True)
class Library:
    meshes: list[LibraryMesh]
    fingerprint: str

    @property
    def class_names(self) -> list[str]:
        return sorted({m.class_name for m in self.meshes})


def library_files(folder: Path) -> list[tuple[str, Path]]:
    """(class, file) of every mesh file one level below `folder`, sorted."""
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{folder}: no such library folder")
    found = []
    for class_dir in sorted(p for p in folder.iterdir() if p.is_dir() and not p.name.startswith(".")):
        meshes = sorted(p for p in class_dir.iterdir() if p.is_file() and p.suffix.lower() in MESH_SUFFIXES)
        # An empty class is a copy that went wrong, not a class to train without.
        if not meshes:
            raise InputError(f"{class_dir}: an empty class: no mesh files ({', '.join(MESH_SUFFIXES)})")
        found += [(class_dir.name, path) for path in meshes]
    if not found:
        raise InputError(f"{folder}: no class folders with mesh files ({', '.join(MESH_SUFFIXES)})")
    return found


def fingerprint_files(files: list[tuple[str, Path]]) -> str:
    digest = hashlib.sha256()
    for class_name, path in files:
        digest.update(f"{class_name}/{path.name}\0".encode())
        digest.update(hashlib.sha256(read_bounded(path, MAX_MESH_BYTES)).digest())
    return digest.hexdigest()


def load_library(folder: Path, *, min_per_class: int = 2) -> Library:
    """Every mesh of the library, checked: a class needs `min_per_class` meshes, a mesh a metric size."""
    files = library_files(folder)
    meshes = []
    for class_name, path in files:
        mesh = load_mesh(path)
        size = float(np.max(mesh.extents))
        if not (MIN_SIZE_M <= size <= MAX_SIZE_M):
            raise InputError(f"{path}: {size:g} across; library meshes must be in metres ({MIN_SIZE_M}-{MAX_SIZE_M} m)")
        meshes.append(LibraryMesh(class_name=class_name, name=path.stem, mesh=mesh))
    for class_name in sorted({c for c, _ in files}):
        count = sum(m.class_name == class_name for m in meshes)
        if count < min_per_class:
            raise InputError(f"{Path(folder) / class_name}: {count} mesh(es), a class needs at least {min_per_class}")
    return Library(meshes=meshes, fingerprint=fingerprint_files(files))


def working_mesh(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """A copy of `mesh` decimated to at most MAX_WORKING_TRIANGLES, its faces wound
    consistently (outward where it is closed): the fitting keeps the library surface that faces
    the camera by its normals, and meshes from elsewhere are not always wound one way."""
    working = decimate(mesh, MAX_WORKING_TRIANGLES)
    if working is mesh:
        working = mesh.copy()
    trimesh.repair.fix_normals(working)
    return working


def write_procedural_library(
    folder: Path, *, classes: list[str] | None = None, per_class: int = 20, seed: int = 0
) -> list[Path]:
    """Write `per_class` generated instances of each class as PLY files under `folder/<class>/`."""
    classes = sorted(GENERATORS) if classes is None else classes
    if not classes:
        raise InputError(f"no classes to write: the generator makes {sorted(GENERATORS)}")
    unknown = sorted(set(classes) - set(GENERATORS))
    if unknown:
        raise InputError(f"unknown class(es) {unknown}: the generator makes {sorted(GENERATORS)}")
    if per_class < 1:
        raise InputError(f"{per_class=}: at least one instance per class")
    written = []
    for class_name in classes:
        for index, mesh in enumerate(generate_instances(class_name, per_class, seed=seed)):
            path = Path(folder) / class_name / f"{class_name}_{index:03d}.ply"
            write_bytes_atomic(path, mesh.export(file_type="ply"))
            written.append(path)
    return written


def training_fingerprint(library_fingerprint: str, params: dict) -> str:
    """A hash of the library's files and the training options."""
    text = library_fingerprint + json.dumps(params, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()
