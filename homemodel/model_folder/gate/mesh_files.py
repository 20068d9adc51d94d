"""The gate's mesh reading: a plain OBJ (triangles of positions, as homemodel writes collision
hulls) through the strict OBJ reader, any other file through trimesh; both give the same
vertices and faces, and the strict reader is several times cheaper than trimesh's parser."""

from __future__ import annotations

from pathlib import Path

import trimesh

from homemodel.core.input_files import read_bounded
from homemodel.core.limits import MESH_TRIANGLES
from homemodel.exchange.obj import read_plain_obj
from homemodel.geometry import mesh_io


def read_gate_mesh(path: Path) -> trimesh.Trimesh:
    """`mesh_io.load_mesh`'s reading of `path`, for `load_mesh(path, read=read_gate_mesh)`."""
    path = Path(path)
    if path.suffix.lower() != ".obj" or not path.is_file():
        return mesh_io.read_mesh_file(path)
    data = read_bounded(path, mesh_io.MAX_MESH_BYTES)
    MESH_TRIANGLES.check(path, mesh_io.declared_faces(data, ".obj"))
    obj = read_plain_obj(data, path)
    if obj is None:
        return mesh_io.read_mesh_file(path)
    MESH_TRIANGLES.check(path, len(obj.faces))
    return obj.trimesh(keep_unreferenced=False)


def load_gate_mesh(path: Path, *, require_finite: bool = True) -> trimesh.Trimesh:
    """`mesh_io.load_mesh` (one parse per file within `meshes_read_once`) read as above."""
    return mesh_io.load_mesh(path, require_finite=require_finite, read=read_gate_mesh)
