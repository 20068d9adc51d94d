"""Wavefront OBJ + MTL writing for URDF visuals (pybullet and ROS tools read these)."""

from __future__ import annotations

import io

import numpy as np
import trimesh

from articulation.model import Material
from articulation.numbers import fixed


def obj_text(mesh: trimesh.Trimesh, *, mtl_file: str | None, material: str | None, uv: np.ndarray | None) -> str:
    """An OBJ of `mesh` with one texture coordinate per vertex when `uv` is given."""
    out = io.StringIO()
    out.write("# homemodel\n")
    if mtl_file is not None:
        out.write(f"mtllib {mtl_file}\n")
    for x, y, z in mesh.vertices:
        out.write(f"v {fixed(x)} {fixed(y)} {fixed(z)}\n")
    if uv is not None:
        for u, v in uv:
            out.write(f"vt {fixed(u)} {fixed(v)}\n")
    if material is not None:
        out.write(f"usemtl {material}\n")
    faces = np.asarray(mesh.faces) + 1
    if uv is not None:
        out.writelines(f"f {a}/{a} {b}/{b} {c}/{c}\n" for a, b, c in faces)
    else:
        out.writelines(f"f {a} {b} {c}\n" for a, b, c in faces)
    return out.getvalue()


def mtl_text(name: str, material: Material, texture_file: str | None) -> str:
    r, g, b, a = material.rgba
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
