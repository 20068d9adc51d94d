"""Read a mesh file (or a model folder's model.glb) into one triangle mesh, with one-line errors."""

from __future__ import annotations

import io
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path

import numpy as np
import trimesh

from homemodel.core.errors import InputError
from homemodel.core.input_files import read_bounded
from homemodel.core.limits import MESH_TRIANGLES
from homemodel.core.transforms import Y_UP_FROM_Z_UP
from homemodel.geometry.collada import collada_unit_m

MAX_MESH_BYTES = 512 * 1024 * 1024
MESH_SUFFIXES = (".obj", ".stl", ".ply", ".off", ".glb", ".gltf", ".dae")
# While `meshes_read_once` is active: the meshes read, by (resolved path, mtime, size).
_READ: ContextVar[dict | None] = ContextVar("meshes_read", default=None)


@contextmanager
def meshes_read_once() -> Iterator[None]:
    """Within the block, `load_mesh` parses each unchanged file once and hands out copies: the
    validation gate's rules, mesh geometry and collision checks each read every mesh (a completed
    cup's 49 OBJs were parsed three times, two thirds of the gate's time)."""
    token = _READ.set({})
    try:
        yield
    finally:
        _READ.reset(token)


def declared_faces(data: bytes, suffix: str) -> int:
    """The face count a mesh file declares or plainly holds, read before parsing it (which
    takes many times the file's size in memory); 0 where the format does not say cheaply."""
    if suffix == ".obj":
        return data.count(b"\nf ") + data.startswith(b"f ")
    if suffix == ".stl" and not data[:5].lower().startswith(b"solid") and len(data) >= 84:
        return int.from_bytes(data[80:84], "little")  # binary STL: the count follows the header
    if suffix == ".ply":
        header = data[: data.find(b"end_header")] if b"end_header" in data[:65536] else b""
        for line in header.splitlines():
            words = line.split()
            if len(words) == 3 and words[:2] == [b"element", b"face"] and words[2].isdigit():
                return int(words[2])
    return 0


def load_mesh(
    path: Path, *, require_finite: bool = True, read: Callable[[Path], trimesh.Trimesh] | None = None
) -> trimesh.Trimesh:
    """All the triangles of a mesh file, or of `model.glb` when `path` is a model folder,
    in the file's frame (scene nodes' transforms applied); a model folder's in the model's z-up
    frame. `require_finite=False` leaves NaN and infinite vertices for the caller to report.
    `read` replaces `read_mesh_file` with a reader giving the same triangles (the gate's cheaper
    OBJ reading, which this layer cannot import)."""
    path = Path(path)
    cache = _READ.get()
    stat = path.stat() if cache is not None and path.is_file() else None
    key = None if stat is None else (str(path.resolve()), stat.st_mtime_ns, stat.st_size)
    if key is not None and key in cache:
        mesh = cache[key].copy()
    else:
        mesh = (read or read_mesh_file)(path)
        if key is not None:  # the cache keeps the parsed mesh; every reader gets a copy
            cache[key], mesh = mesh, mesh.copy()
    if require_finite and not np.all(np.isfinite(mesh.vertices)):
        raise InputError(f"{path}: the mesh has non-finite (NaN or infinite) vertex coordinates")
    return mesh


def read_mesh_file(path: Path) -> trimesh.Trimesh:
    """`load_mesh` of a file without the finite check."""
    model_folder = path.is_dir()
    if model_folder:
        path = path / "model.glb"
    suffix = path.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise InputError(f"{path}: not a mesh file (expected one of {', '.join(MESH_SUFFIXES)} or a model folder)")
    data = read_bounded(path, MAX_MESH_BYTES)
    MESH_TRIANGLES.check(path, declared_faces(data, suffix))
    # A DAE (a ROS package's mesh) in metres, as ROS tools read it; its unit read safely first.
    unit_m = collada_unit_m(data, path) if suffix == ".dae" else 1.0
    try:
        loaded = trimesh.load(io.BytesIO(data), file_type=suffix[1:], force="mesh", process=False)
    except Exception as exc:  # trimesh raises many types on corrupt files
        raise InputError(f"{path}: cannot read the mesh: {type(exc).__name__}: {exc}") from None
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise InputError(f"{path}: the file holds no triangles")
    MESH_TRIANGLES.check(path, len(loaded.faces))
    if unit_m != 1.0:
        loaded.apply_scale(unit_m)
    if model_folder:  # model.glb turns the z-up model into glTF's y-up at its root node: undo it
        loaded.apply_transform(np.linalg.inv(Y_UP_FROM_Z_UP))
    return loaded
