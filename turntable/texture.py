"""Bake vertex colours into a texture on a chart atlas's UVs, so URDF (OBJ + MTL) and glTF carry colour."""

from __future__ import annotations

import numpy as np
import trimesh

from homemodel.geometry.chart_atlas import chart_atlas
from homemodel.geometry.uv_atlas import atlas_texels


def carrier(mesh: trimesh.Trimesh, max_triangles: int) -> tuple[trimesh.Trimesh, np.ndarray]:
    """The mesh simplified to at most `max_triangles`, and each of its vertices' nearest vertex of
    `mesh` (its colour's source). The texture's carrier only (its colours come from the vertices,
    so a finer carrier adds texels to bake, not colour detail): fast-simplification's quadric
    collapse (0.1 s for a 68k-triangle mug to 12k, against Open3D's 1.1 s, the same distance to
    the truth within 0.001 mm, closed)."""
    import fast_simplification
    from scipy.spatial import cKDTree

    if len(mesh.faces) <= max_triangles:
        return mesh, np.arange(len(mesh.vertices))
    vertices, faces = fast_simplification.simplify(
        mesh.vertices, mesh.faces.astype(np.int32), target_reduction=1 - max_triangles / len(mesh.faces)
    )
    result = trimesh.Trimesh(vertices, faces, process=False)
    result.remove_unreferenced_vertices()
    _, nearest = cKDTree(mesh.vertices).query(result.vertices, workers=-1)
    return result, nearest


def bake_vertex_colors(
    mesh: trimesh.Trimesh, colors: np.ndarray, *, size_px: int = 512
) -> tuple[trimesh.Trimesh, np.ndarray, np.ndarray]:
    """The mesh split along the atlas's chart seams, its UVs (OpenGL, v up) and an (H, W, 3) uint8 image.

    Each texel takes the barycentric blend of its triangle's vertex colours; texels outside
    every chart take the nearest chart's colour, so mip-mapping does not bleed black in.
    """
    colors = np.asarray(colors, dtype=np.float64)
    if colors.shape != (len(mesh.vertices), 3):
        raise ValueError(f"{colors.shape=} but expected ({len(mesh.vertices)}, 3)")
    atlas = chart_atlas(mesh, size_px=size_px, padding_px=2)
    texels = atlas_texels(atlas, size_px)
    texel_colors = texels.interpolate(colors[atlas.source_vertex])
    image = texels.paint((np.clip(texel_colors, 0.0, 1.0) * 255).round().astype(np.uint8))
    return atlas.mesh, atlas.uv, image
