"""The projection-chart UV atlas the photo texture and the turntable's colours are baked on: every face gets its own texels
(no chart folds onto another), at one density within the projection's shrink, the colour a
surface point is given comes back at its UV, and a large mesh is laid out in seconds."""

from __future__ import annotations

import time

import numpy as np
import trimesh

from homemodel.geometry.chart_atlas import chart_atlas
from homemodel.geometry.uv_atlas import atlas_texels

SIZE = 1024


def _bumpy_torus(subdivisions: int) -> trimesh.Trimesh:
    """A torus (its inner ring is fold-prone: saddle-shaped) with vertices shaken by a fifth of
    an edge (normals scattered like a reconstruction's): 16k faces at 4 subdivisions."""
    torus = trimesh.creation.torus(major_radius=0.1, minor_radius=0.04, major_sections=64, minor_sections=32)
    for _ in range(subdivisions - 3):
        torus = torus.subdivide()
    rng = np.random.default_rng(1)
    edge = float(np.mean(torus.edges_unique_length))
    torus.vertices += rng.normal(0, 0.2 * edge, torus.vertices.shape)
    return torus


def test_every_face_has_its_own_texels_at_one_density() -> None:
    import cv2

    mesh = _bumpy_torus(4)
    atlas = chart_atlas(mesh, size_px=SIZE, padding_px=2)
    assert len(atlas.mesh.faces) == len(mesh.faces)
    assert np.allclose(atlas.mesh.vertices, mesh.vertices[atlas.source_vertex])
    assert atlas.uv.min() >= 0 and atlas.uv.max() <= 1
    corners = atlas.uv[atlas.mesh.faces] * SIZE
    uv_area = 0.5 * np.abs(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]))
    # One density: texels per surface area within the projection's shrink (at most 60 degrees off).
    ratio = uv_area / mesh.area_faces
    assert ratio.min() / ratio.max() > 0.45, (ratio.min(), ratio.max())
    # The texture is used: the charts' texels cover a good part of it.
    texels = atlas_texels(atlas, SIZE)
    assert len(texels.rows) > 0.3 * SIZE**2, len(texels.rows) / SIZE**2
    # No overlaps: the texel at a face's centre is its own (a chart folded onto itself or
    # onto another would show the other face there); faces whose centre is 1.5 texels inside
    # their edges, so that the neighbours' edge texels do not reach it.
    ids = np.full((SIZE, SIZE), -1, np.int32)
    for index, triangle in enumerate(np.round((corners - [0.5, 0.5]) * [1, -1] * 16 + [0, (SIZE - 0.5) * 16 - 8]).astype(np.int32)):
        cv2.fillConvexPoly(ids, triangle, index, lineType=cv2.LINE_8, shift=4)
    centres = np.round(corners.mean(axis=1) * [1, -1] + [-0.5, SIZE - 0.5]).astype(int)
    shown = ids[centres[:, 1], centres[:, 0]]
    edges = np.linalg.norm(corners[:, [1, 2, 0]] - corners, axis=2).sum(axis=1)
    big = 2 * uv_area / edges > 1.5  # the inscribed circle's radius
    assert big.sum() > 0.3 * len(big) and np.mean(shown[big] != np.nonzero(big)[0]) < 0.002


def test_a_colour_painted_at_a_surface_point_comes_back_at_its_uv() -> None:
    """Paint every texel with its surface point's position, then read random surface points'
    UVs bilinearly: the position comes back within a texel's size."""
    import cv2

    mesh = _bumpy_torus(4)
    atlas = chart_atlas(mesh, size_px=SIZE, padding_px=2)
    texels = atlas_texels(atlas, SIZE)
    low, span = mesh.bounds[0], mesh.extents.max()
    image = np.zeros((SIZE, SIZE, 3), np.float32)
    image[texels.rows, texels.cols] = (texels.points - low) / span
    rng = np.random.default_rng(2)
    faces = rng.integers(0, len(atlas.mesh.faces), 3000)
    weights = rng.dirichlet(np.ones(3), len(faces)) * 0.8 + 0.2 / 3  # inside, off the edges
    corners = atlas.mesh.faces[faces]
    points = np.einsum("nk,nkd->nd", weights, atlas.mesh.vertices[corners])
    uv = np.einsum("nk,nkd->nd", weights, atlas.uv[corners])
    x = (uv[:, 0] * SIZE - 0.5).astype(np.float32)
    y = ((1 - uv[:, 1]) * SIZE - 0.5).astype(np.float32)
    read = cv2.remap(image, x[None], y[None], cv2.INTER_NEAREST)[0]
    error = np.linalg.norm(read * span + low - points, axis=1)
    texel_m = np.sqrt(mesh.area / len(texels.rows))
    assert np.percentile(error, 95) < 1.5 * texel_m, (np.percentile(error, [50, 95]), texel_m)


def test_a_large_mesh_is_laid_out_in_seconds() -> None:
    """65k faces: under 4 CPU-s for the atlas and its texels (measured 1.1-2.0 s; xatlas took
    2.7 CPU-s on Kermit's 34k faces and 6.2 on 138k)."""
    mesh = _bumpy_torus(5)
    assert len(mesh.faces) > 60_000
    start = time.process_time()
    atlas = chart_atlas(mesh, size_px=2048, padding_px=2)
    atlas_texels(atlas, 2048)
    assert time.process_time() - start < 4.0


def test_many_charts_fit_a_small_texture_with_less_padding() -> None:
    """16k faces in a 128 px texture: the charts do not fit 4 texels apart, but do closer."""
    atlas = chart_atlas(_bumpy_torus(4), size_px=128, padding_px=4)
    assert atlas.uv.min() >= 0 and atlas.uv.max() <= 1
    assert len(atlas_texels(atlas, 128).rows) > 0.2 * 128**2


def test_shelf_packing_lays_boxes_apart_in_rows_tallest_first() -> None:
    """Random boxes (ties in height included): each inside the width, none overlapping another,
    rows filled left to right with the tallest first, the height the rows' sum; a box wider
    than the texture cannot be laid."""
    from homemodel.geometry.chart_atlas import _shelf_pack

    rng = np.random.default_rng(4)
    for count, width in ((1, 10), (40, 37), (300, 128)):
        sizes = np.column_stack([rng.integers(1, width + 1, count), rng.integers(1, 12, count)])
        corners, height = _shelf_pack(sizes, width)
        ends = corners + sizes
        assert (corners >= 0).all() and (ends[:, 0] <= width).all() and ends[:, 1].max() == height
        apart = (ends[:, None, 0] <= corners[None, :, 0]) | (ends[None, :, 0] <= corners[:, None, 0])
        apart |= (ends[:, None, 1] <= corners[None, :, 1]) | (ends[None, :, 1] <= corners[:, None, 1])
        assert apart[~np.eye(count, dtype=bool)].all()
        rows = np.unique(corners[:, 1])
        for top, below in zip(rows, [*rows[1:], height]):
            row = corners[:, 1] == top
            assert sizes[row, 1].max() == below - top  # a row as tall as its tallest box
            assert sizes[row, 1].min() >= sizes[corners[:, 1] > top, 1].max(initial=0)  # taller rows first
            left = np.sort(corners[row, 0])
            assert left[0] == 0 and np.array_equal(np.sort(ends[row, 0])[:-1], left[1:])  # side by side
    assert _shelf_pack(np.array([[11, 3], [2, 2]]), 10)[1] == np.inf
