"""Checks shared by the metrics: a mesh to compare must have triangles and finite vertices."""

from __future__ import annotations

import numpy as np
import trimesh

from homemodel.core.errors import InputError


def checked_mesh(mesh: trimesh.Trimesh, role: str) -> trimesh.Trimesh:
    """`mesh` if it can be measured; `role` ("pred", "gt") names it in the error."""
    if not isinstance(mesh, trimesh.Trimesh):
        raise InputError(f"{role}: expected a triangle mesh, got {type(mesh).__name__}")
    if len(mesh.faces) == 0 or len(mesh.vertices) == 0:
        raise InputError(f"{role}: the mesh has no triangles")
    if not np.all(np.isfinite(mesh.vertices)):
        raise InputError(f"{role}: the mesh has non-finite vertex coordinates")
    if mesh.area <= 0.0:
        raise InputError(f"{role}: the mesh has zero surface area")
    return mesh
