"""Wavefront OBJ + MTL writing for URDF visuals (pybullet and ROS tools read these)."""

from __future__ import annotations

import numpy as np
import trimesh

from homemodel.exchange.numbers import fixed
from homemodel.geometry.mesh_ops import zero_area_faces


def _fixed_rows(tag: str, values: np.ndarray) -> tuple[str, np.ndarray]:
    """One line `tag x y ...` per row of `values`, each number as `numbers.fixed` writes it
    (formatted in one call per block, not one per number), and the values a reader gets back."""
    values = np.asarray(values, dtype=np.float64)
    if len(values) == 0:
        return "", values
    text = ((tag + " %.6f" * values.shape[1] + "\n") * len(values)) % tuple(values.ravel().tolist())
    written = np.array(text.split(), dtype=object).reshape(len(values), -1)[:, 1:].astype(np.float64)
    # Every number has six decimals: dropping a zero before a separator six times removes the
    # trailing zeros and never reaches past the point, which goes next; "-0" can only be a whole number.
    for _ in range(6):
        text = text.replace("0 ", " ").replace("0\n", "\n")
    text = text.replace(". ", " ").replace(".\n", "\n").replace("-0 ", "0 ").replace("-0\n", "0\n")
    return text, written


def obj_text(mesh: trimesh.Trimesh, *, mtl_file: str | None, material: str | None, uv: np.ndarray | None) -> str:
    """An OBJ of `mesh` with one texture coordinate per vertex when `uv` is given. Triangles
    with no area at the written precision (marching cubes makes a few slivers that rounding
    to 1 um flattens) are left out: they carry no surface, and the gate refuses them."""
    vertex_lines, written = _fixed_rows("v", np.asarray(mesh.vertices).reshape(-1, 3))
    faces = np.asarray(mesh.faces)[~zero_area_faces(written, mesh.faces)] + 1
    parts = ["# homemodel\n"]
    if mtl_file is not None:
        parts.append(f"mtllib {mtl_file}\n")
    parts.append(vertex_lines)
    if uv is not None:
        parts.append(_fixed_rows("vt", np.asarray(uv).reshape(-1, 2))[0])
    if material is not None:
        parts.append(f"usemtl {material}\n")
    if len(faces):
        if uv is not None:
            parts.append(("f %d/%d %d/%d %d/%d\n" * len(faces)) % tuple(np.repeat(faces, 2, axis=1).ravel().tolist()))
        else:
            parts.append(("f %d %d %d\n" * len(faces)) % tuple(faces.ravel().tolist()))
    return "".join(parts)


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
