"""A UV atlas (laid out by `chart_atlas`) and its texels on the surface: the part of baking a
texture that does not depend on where the colour comes from (the turntable's vertex colours,
the photos).

Texture images follow the OpenGL convention of the exporters: uv (0, 0) is the bottom-left
corner, row 0 of the image is its top (v = 1), texel centres sit at half-integer uv * size.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh


@dataclass(kw_only=True)
class Atlas:
    mesh: trimesh.Trimesh  # the input's vertices split along the chart seams
    uv: np.ndarray  # (V, 2) per vertex of `mesh`
    source_vertex: np.ndarray  # (V,) the input vertex each vertex of `mesh` copies


@dataclass(kw_only=True)
class Texels:
    """The texels an atlas's triangles cover: where each is in the image and on the surface."""

    size_px: int
    rows: np.ndarray  # (N,) image row, 0 at the top (v = 1)
    cols: np.ndarray  # (N,)
    corners: np.ndarray  # (N, 3) vertex indices of the texel's triangle
    weights: np.ndarray  # (N, 3) barycentric weights of the texel centre, clipped onto the triangle
    points: np.ndarray  # (N, 3) the texel's point on the surface

    def interpolate(self, values: np.ndarray) -> np.ndarray:
        """Per-vertex `values` (V, C) blended at each texel (N, C)."""
        return np.einsum("nk,nkc->nc", self.weights, np.asarray(values, dtype=np.float64)[self.corners])

    def paint(self, colours: np.ndarray, *, gutter_px: int | None = None) -> np.ndarray:
        """The (size, size, 3) uint8 texture with each texel's colour (N, 3), and every empty
        texel within `gutter_px` of a chart (None: every empty texel) the colour of the nearest
        painted one, so bilinear filtering and mip-maps do not bleed the background into the model."""
        from scipy import ndimage

        texture = np.zeros((self.size_px, self.size_px, 3), np.uint8)
        texture[self.rows, self.cols] = colours
        empty = np.ones((self.size_px, self.size_px), bool)
        empty[self.rows, self.cols] = False
        if not empty.any():
            return texture
        # Chessboard distance: the gutter reaches as far diagonally as along rows.
        distance, (rows, cols) = ndimage.distance_transform_cdt(empty, metric="chessboard", return_indices=True)
        fill = empty if gutter_px is None else empty & (distance <= gutter_px)
        texture[fill] = texture[rows[fill], cols[fill]]
        return texture


def atlas_texels(atlas: Atlas, size_px: int) -> Texels:
    """The texels of a `size_px` texture that the atlas's triangles cover, edge texels
    included, and where each lies on the surface."""
    import cv2

    mesh, uv = atlas.mesh, atlas.uv
    face_ids = np.full((size_px, size_px), -1, np.int32)
    corners_px = np.stack([uv[:, 0] * size_px - 0.5, (1 - uv[:, 1]) * size_px - 0.5], axis=1)
    triangles = np.round(corners_px[mesh.faces] * 16).astype(np.int32)  # 4 bits of sub-pixel precision
    for index, triangle in enumerate(triangles):
        cv2.fillConvexPoly(face_ids, triangle, int(index), lineType=cv2.LINE_8, shift=4)
    rows, cols = np.nonzero(face_ids >= 0)
    faces = face_ids[rows, cols]
    # Barycentric coordinates of each texel centre in its triangle's UV corners.
    a, b, c = (corners_px[mesh.faces[faces, k]] for k in range(3))
    p = np.stack([cols, rows], axis=1).astype(np.float64)
    v0, v1, v2 = b - a, c - a, p - a
    denominator = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
    denominator = np.where(np.abs(denominator) < 1e-12, 1e-12, denominator)
    w1 = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / denominator
    w2 = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / denominator
    weights = np.clip(np.stack([1 - w1 - w2, w1, w2], axis=1), 0, 1)
    weights /= weights.sum(axis=1, keepdims=True)
    corners = mesh.faces[faces]
    points = np.einsum("nk,nkd->nd", weights, mesh.vertices[corners])
    return Texels(size_px=size_px, rows=rows, cols=cols, corners=corners, weights=weights, points=points)
