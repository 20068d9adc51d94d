"""Bake vertex colours into a texture on xatlas UVs, so URDF (OBJ + MTL) and glTF carry colour."""

from __future__ import annotations

import numpy as np
import trimesh

from homemodel.geometry.mesh_ops import decimate


def decimated(mesh: trimesh.Trimesh, colors: np.ndarray, max_triangles: int) -> tuple[trimesh.Trimesh, np.ndarray]:
    """The mesh simplified to at most `max_triangles` with colours carried over from the nearest
    original vertex. xatlas's time grows much faster than linearly with the triangle count
    (about 1 s at 20k triangles, 15 s at 40k here)."""
    from scipy.spatial import cKDTree

    result = decimate(mesh, max_triangles)
    if result is mesh:
        return mesh, colors
    _, nearest = cKDTree(mesh.vertices).query(result.vertices, workers=-1)
    return result, np.asarray(colors)[nearest]


def bake_vertex_colors(
    mesh: trimesh.Trimesh, colors: np.ndarray, *, size_px: int = 1024
) -> tuple[trimesh.Trimesh, np.ndarray, np.ndarray]:
    """The mesh split along xatlas seams, its UVs (OpenGL, v up) and an (H, W, 3) uint8 image.

    Each texel takes the barycentric blend of its triangle's vertex colours; texels outside
    every chart take the nearest chart's colour, so mip-mapping does not bleed black in.
    """
    import cv2
    import open3d as o3d
    import xatlas

    colors = np.asarray(colors, dtype=np.float64)
    if colors.shape != (len(mesh.vertices), 3):
        raise ValueError(f"{colors.shape=} but expected ({len(mesh.vertices)}, 3)")
    atlas = xatlas.Atlas()
    atlas.add_mesh(np.asarray(mesh.vertices, dtype=np.float32), np.asarray(mesh.faces, dtype=np.uint32))
    charts = xatlas.ChartOptions()
    charts.max_iterations = 1
    pack = xatlas.PackOptions()
    pack.resolution = size_px
    pack.padding = 2
    atlas.generate(charts, pack)
    vmapping, faces, uvs = atlas[0]
    split = trimesh.Trimesh(mesh.vertices[vmapping], faces, process=False)
    split_colors = colors[vmapping]
    # Texel centres hit the UV layout (laid flat at z = 0) from above: the hit triangle and
    # its barycentric coordinates give the texel's colour.
    scene = o3d.t.geometry.RaycastingScene()
    flat = np.column_stack([uvs * size_px, np.zeros(len(uvs))]).astype(np.float32)
    scene.add_triangles(o3d.core.Tensor(flat), o3d.core.Tensor(faces.astype(np.uint32)))
    col, row = np.meshgrid(np.arange(size_px) + 0.5, np.arange(size_px) + 0.5)
    rays = np.column_stack(
        [col.ravel(), row.ravel(), np.ones(col.size), np.zeros(col.size), np.zeros(col.size), -np.ones(col.size)]
    ).astype(np.float32)
    hits = scene.cast_rays(o3d.core.Tensor(rays))
    triangle = hits["primitive_ids"].numpy().astype(np.int64)
    inside = triangle != o3d.t.geometry.RaycastingScene.INVALID_ID
    barycentric = hits["primitive_uvs"].numpy()[inside].astype(np.float64)
    corners = split_colors[faces[triangle[inside]]]  # (n, 3 corners, 3 channels)
    weights = np.column_stack([1.0 - barycentric.sum(axis=1), barycentric])
    texels = np.zeros((size_px * size_px, 3))
    texels[inside] = np.einsum("nk,nkc->nc", weights, corners)
    image = (np.clip(texels, 0.0, 1.0) * 255).round().astype(np.uint8).reshape(size_px, size_px, 3)
    empty = (~inside).reshape(size_px, size_px).astype(np.uint8)
    if empty.any() and not empty.all():
        image = cv2.inpaint(image, empty, 3, cv2.INPAINT_TELEA) if empty.mean() < 0.2 else _fill_nearest(image, empty)
    # Texel row r was laid out at v = (r + 0.5) / size; in the OpenGL convention the model's
    # uv follows, row 0 of the stored image is the top (v = 1): flip the rows, keep the uv.
    return split, uvs.astype(np.float64), image[::-1].copy()


def _fill_nearest(image: np.ndarray, empty: np.ndarray) -> np.ndarray:
    from scipy import ndimage

    _, (rows, cols) = ndimage.distance_transform_edt(empty, return_indices=True)
    return image[rows, cols]
