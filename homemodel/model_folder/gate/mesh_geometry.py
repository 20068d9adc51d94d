"""The gate's check of every mesh's geometry: finite, non-empty, not degenerate.

A mesh read without error can still be unusable: all-NaN vertices pass every client (pybullet,
check_urdf, yourdfpy load them), a triangle of zero area has no normal, and a collision mesh
with no volume gives a physics engine nothing to collide with.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import trimesh

from homemodel.core.errors import InputError
from homemodel.core.limits import MESH_TRIANGLES
from homemodel.exchange import urdf as urdf_doc
from homemodel.exchange.urdf import Element
from homemodel.exchange.urdf.mesh_paths import resolve_mesh
from homemodel.model_folder.gate.mesh_files import load_gate_mesh
from homemodel.geometry.mesh_ops import zero_area_faces
from homemodel.model_folder.gate.report import Check, check_from_problems, count

# Relative to the cubed size of the mesh's bounding box: below this a solid has no volume.
VOLUME_TOLERANCE = 1e-12


def _geometry_problems(mesh: trimesh.Trimesh, solid: bool) -> list[str]:
    """What is wrong with a mesh that loaded (with triangles); `solid` for collision meshes."""
    if not np.all(np.isfinite(mesh.vertices)):
        return ["the mesh has non-finite (NaN or infinite) vertex coordinates"]
    size = float(np.linalg.norm(mesh.extents))
    if size == 0.0:
        return ["all its vertices are one point"]
    problems = []
    flat = int(np.count_nonzero(zero_area_faces(mesh.vertices, mesh.faces)))
    if flat:
        problems.append(f"{flat} of {len(mesh.faces)} triangles have zero area")
    if solid:
        try:
            volume = abs(float(mesh.volume)) if mesh.is_watertight else float(mesh.convex_hull.volume)
        except Exception:  # qhull refuses flat or collinear point sets
            volume = 0.0
        if volume <= VOLUME_TOLERANCE * size**3:
            problems.append("a collision mesh with zero volume (flat or a line)")
    return problems


def over_triangle_bound(meshes: Check) -> bool:
    """Whether the meshes check found a mesh over the triangle bound, which the clients
    (yourdfpy, pybullet, the collision sweep) must not be given."""
    return not meshes.passed and MESH_TRIANGLES.name in meshes.detail


def mesh_geometry_check(robot: Element, urdf_dir: Path, package_paths: Sequence[Path] = ()) -> Check:
    """Every visual and collision mesh file inside the model folder is finite, has triangles
    of non-zero area, and (collision meshes, which are meant to be solid) has volume."""
    problems: list[str] = []
    checked: dict[tuple[Path, bool], list[str]] = {}
    for link, role, element in urdf_doc.mesh_elements(robot):
        filename = element.get("filename")
        try:
            path = resolve_mesh(filename or "", urdf_dir, package_paths)
        except InputError:
            continue  # the meshes check reports references it cannot follow
        if not path.is_file():
            continue
        key = (path, role == "collision")
        if key not in checked:
            try:
                mesh = load_gate_mesh(path, require_finite=False)
            except InputError:
                continue  # unreadable, or over the bounds: the meshes check reports it
            checked[key] = _geometry_problems(mesh, solid=key[1])
        problems += [f"link {link.get('name')!r}: {role} mesh {filename!r}: {p}" for p in checked[key]]
    detail = f"{count(len({p for p, _ in checked}), 'mesh file')} finite, with area, collision meshes with volume"
    return check_from_problems("mesh geometry", problems, detail if checked else "no mesh files")
