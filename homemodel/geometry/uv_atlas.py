"""A UV atlas (laid out by `chart_atlas`) and its texels on the surface: the part of baking a
texture that does not depend on where the colour comes from (the turntable's vertex colours,
the photos).

Texture images follow the OpenGL convention of the exporters: uv (0, 0) is the bottom-left
corner, row 0 of the image is its top (v = 1), texel centres sit at half-integer uv * size.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

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
    vertices: np.ndarray  # (V, 3) the atlas mesh's, which `corners` index

    @cached_property
    def points(self) -> np.ndarray:
        """(N, 3) the texel's point on the surface; on first use, as baking vertex colours needs none."""
        return self.interpolate(self.vertices)

    def interpolate(self, values: np.ndarray) -> np.ndarray:
        """Per-vertex `values` (V, C) blended at each texel (N, C)."""
        return np.einsum("nk,nkc->nc", self.weights, np.asarray(values, dtype=np.float64)[self.corners])

    def paint(self, colours: np.ndarray, *, gutter_px: int | None = None) -> np.ndarray:
        """The (size, size, 3) uint8 texture with each texel's colour (N, 3), and every empty
        texel within `gutter_px` of a chart (None: every empty texel) the colour of the nearest
        painted one, so bilinear filtering and mip-maps do not bleed the background into the model."""
        import cv2

        size = self.size_px
        texture = np.zeros((size, size, 3), np.uint8)
        texels = texture.reshape(-1, 3)  # flat views: one index per texel instead of two
        painted = self.rows * size + self.cols
        texels[painted] = colours
        empty = np.ones(size * size, np.uint8)
        empty[painted] = 0
        if not empty.any() or not len(painted):
            return texture
        # Chessboard distance (the gutter reaches as far diagonally as along rows), exact with
        # the 3x3 mask. OpenCV's labels each painted texel and the empty ones nearest it: half
        # SciPy's distance_transform_cdt's CPU (4.4 against 7.8 ms at 512 px), and it lets go of
        # the GIL. Of texels at the same distance it may pick another than SciPy did.
        distance, labels = cv2.distanceTransformWithLabels(
            empty.reshape(size, size), cv2.DIST_C, 3, labelType=cv2.DIST_LABEL_PIXEL
        )
        labels = labels.ravel()
        texel_of_label = np.empty(int(labels.max()) + 1, np.int64)
        texel_of_label[labels[painted]] = painted
        nearest = texel_of_label[labels]
        if gutter_px is None:  # every texel its nearest painted one's colour: a painted texel is its own
            return texels[nearest].reshape(texture.shape)
        fill = empty.astype(bool) & (distance.ravel() <= gutter_px)
        texels[fill] = texels[nearest[fill]]
        return texture


def atlas_texels(atlas: Atlas, size_px: int) -> Texels:
    """The texels of a `size_px` texture that the atlas's triangles cover, edge texels
    included, and where each lies on the surface."""
    import cv2

    faces, uv = atlas.mesh.faces, atlas.uv
    face_ids = np.full((size_px, size_px), -1, np.int32)
    x_px, y_px = uv[:, 0] * size_px - 0.5, (1 - uv[:, 1]) * size_px - 0.5
    triangles = np.round(np.stack([x_px, y_px], axis=1)[faces] * 16).astype(np.int32)  # 4 bits of sub-pixel precision
    fill = cv2.fillConvexPoly  # 12,000 calls for the turntable's carrier: the loop's own overhead counts
    for index, triangle in enumerate(list(triangles)):
        fill(face_ids, triangle, index, cv2.LINE_8, 4)
    rows, cols = np.nonzero(face_ids >= 0)
    corners = faces[face_ids[rows, cols]]
    # Barycentric coordinates of each texel centre in its triangle's UV corners, from 1-D
    # columns (the same arithmetic as on (N, 2) rows, without the strided reads).
    ax, ay = x_px[corners[:, 0]], y_px[corners[:, 0]]
    v0x, v0y = x_px[corners[:, 1]] - ax, y_px[corners[:, 1]] - ay
    v1x, v1y = x_px[corners[:, 2]] - ax, y_px[corners[:, 2]] - ay
    v2x, v2y = cols - ax, rows - ay
    denominator = v0x * v1y - v1x * v0y
    denominator[np.abs(denominator) < 1e-12] = 1e-12
    w1 = (v2x * v1y - v1x * v2y) / denominator
    w2 = (v0x * v2y - v2x * v0y) / denominator
    weights = np.clip(np.stack([1 - w1 - w2, w1, w2], axis=1), 0, 1)
    weights /= weights.sum(axis=1, keepdims=True)
    return Texels(size_px=size_px, rows=rows, cols=cols, corners=corners, weights=weights, vertices=atlas.mesh.vertices)
