"""Wavefront OBJ + MTL writing for URDF visuals (pybullet and ROS tools read these)."""

from __future__ import annotations

import io

import numpy as np
import trimesh

from homemodel.exchange.numbers import fixed
from homemodel.geometry.mesh_ops import zero_area_faces


def obj_text(mesh: trimesh.Trimesh, *, mtl_file: str | None, material: str | None, uv: np.ndarray | None) -> str:
    """An OBJ of `mesh` with one texture coordinate per vertex when `uv` is given. Triangles
    with no area at the written precision (marching cubes makes a few slivers that rounding
    to 1 um flattens) are left out: they carry no surface, and the gate refuses them."""
    coordinates = [[fixed(c) for c in vertex] for vertex in np.asarray(mesh.vertices)]
    written = np.array(coordinates, dtype=np.float64).reshape(-1, 3)
    kept_faces = np.asarray(mesh.faces)[~zero_area_faces(written, mesh.faces)]
    out = io.StringIO()
    out.write("# homemodel\n")
    if mtl_file is not None:
        out.write(f"mtllib {mtl_file}\n")
    for x, y, z in coordinates:
        out.write(f"v {x} {y} {z}\n")
    if uv is not None:
        for u, v in uv:
            out.write(f"vt {fixed(u)} {fixed(v)}\n")
    if material is not None:
        out.write(f"usemtl {material}\n")
    faces = kept_faces + 1
    if uv is not None:
        out.writelines(f"f {a}/{a} {b}/{b} {c}/{c}\n" for a, b, c in faces)
    else:
        out.writelines(f"f {a} {b} {c}\n" for a, b, c in faces)
    return out.getvalue()


def mtl_text(name: str, rgba: tuple[float, float, float, float], texture_file: str | None) -> str:
    r, g, b, a = rgba
    lines = [
        "# homemodel",
        f"newmtl {name}",
        f"Ka {fixed(r)} {fixed(g)} {fixed(b)}",
        f"Kd {fixed(r)} {fixed(g)} {fixed(b)}",
        "Ks 0 0 0",
        f"d {fixed(a)}",
        "illum 1",
    ]
    if texture_file is not None:
        lines.append(f"map_Kd {texture_file}")
    return "\n".join(lines) + "\n"
