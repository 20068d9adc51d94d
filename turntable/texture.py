"""Bake vertex colours into a texture on a chart atlas's UVs, so URDF (OBJ + MTL) and glTF carry colour.

In two parts: the carrier's layout (`carrier_layout`: the decimated copy, its atlas and texels)
needs the mesh only, so it runs while the vertex colours are found; `bake` then blends them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from homemodel.geometry.chart_atlas import chart_atlas
from homemodel.geometry.uv_atlas import Atlas, Texels, atlas_texels


def decimated(mesh: trimesh.Trimesh, max_triangles: int) -> tuple[trimesh.Trimesh, np.ndarray]:
    """The mesh simplified to at most `max_triangles`, and each of its vertices' nearest original
    vertex (its colour's source). The texture's carrier only (its colours come from the
    vertices, so a finer carrier adds texels to bake, not colour detail): fast-simplification's
    quadric collapse (0.1 s for a 68k-triangle mug to 12k, against Open3D's 1.1 s, the same
    distance to the truth within 0.001 mm, closed)."""
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


@dataclass(kw_only=True)
class CarrierLayout:
    """The texture's carrier laid out, before any colour: its atlas and the texels it covers."""

    vertices: int  # the original mesh's
    source_vertex: np.ndarray  # (V,) per vertex of `atlas.mesh`, the original mesh's vertex it takes its colour from
    atlas: Atlas
    texels: Texels


def carrier_layout(mesh: trimesh.Trimesh, *, max_triangles: int, size_px: int = 512) -> CarrierLayout:
    """`mesh` decimated to at most `max_triangles` (see `decimated`), split along a chart atlas's
    seams, and the texels of a `size_px` texture its charts cover."""
    carrier, nearest = decimated(mesh, max_triangles)
    atlas = chart_atlas(carrier, size_px=size_px, padding_px=2)
    return CarrierLayout(vertices=len(mesh.vertices), source_vertex=nearest[atlas.source_vertex], atlas=atlas, texels=atlas_texels(atlas, size_px))


def bake(layout: CarrierLayout, colors: np.ndarray) -> tuple[trimesh.Trimesh, np.ndarray, np.ndarray]:
    """The carrier split along the atlas's seams, its UVs (OpenGL, v up) and an (H, W, 3) uint8
    image of the original mesh's vertex `colors` (V, 3) in [0, 1].

    Each texel takes the barycentric blend of its triangle's vertex colours; texels outside
    every chart take the nearest chart's colour, so mip-mapping does not bleed black in.
    """
    colors = np.asarray(colors, dtype=np.float64)
    if colors.shape != (layout.vertices, 3):
        raise ValueError(f"{colors.shape=} but expected ({layout.vertices}, 3)")
    texel_colors = layout.texels.interpolate(colors[layout.source_vertex])
    image = layout.texels.paint((np.clip(texel_colors, 0.0, 1.0) * 255).round().astype(np.uint8))
    return layout.atlas.mesh, layout.atlas.uv, image
