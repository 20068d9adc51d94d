"""homemodel.geometry: the mesh operations and the UV atlas the reconstructions share."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from homemodel.core.errors import ModelError
from homemodel.geometry.mesh_ops import (
    close_holes,
    decimate,
    decimate_closed,
    largest_piece,
    merge_close_vertices,
    poisson_surface,
    watertight_finish,
)
from homemodel.geometry.chart_atlas import chart_atlas
from homemodel.geometry.uv_atlas import atlas_texels


def _sphere_without(faces: list[int], subdivisions: int = 4) -> tuple[trimesh.Trimesh, trimesh.Trimesh]:
    sphere = trimesh.creation.icosphere(subdivisions=subdivisions, radius=0.1)
    keep = np.ones(len(sphere.faces), bool)
    keep[faces] = False
    return sphere, trimesh.Trimesh(sphere.vertices, sphere.faces[keep], process=False)


def test_finished_mesh_has_no_micrometre_edges_to_tear_in_a_file(tmp_path: Path) -> None:
    # A closed sphere with one edge split 0.5 um from its end, as marching cubes leaves them.
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.1)
    a, b = sphere.edges_unique[0]
    near_a = sphere.vertices[a] + 5e-7 * (sphere.vertices[b] - sphere.vertices[a]) / sphere.edges_unique_length[0]
    vertices = np.vstack([sphere.vertices, near_a])
    split = len(vertices) - 1
    faces = []
    for face in sphere.faces:
        if a in face and b in face:  # the two faces on the edge: each becomes two, one a sliver
            faces += [np.where(face == b, split, face), np.where(face == a, split, face)]
        else:
            faces.append(face)
    torn = trimesh.Trimesh(vertices, np.array(faces), process=False)
    assert torn.is_watertight and torn.edges_unique_length.min() < 1e-6

    finished = watertight_finish(torn, max_faces=10_000)
    assert finished.is_watertight
    assert finished.edges_unique_length.min() > 1e-5
    # Written with 6 decimals and read back merging vertices by position: still closed.
    finished.export(tmp_path / "mesh.obj")
    read = trimesh.load(tmp_path / "mesh.obj", force="mesh")
    read.merge_vertices()
    assert read.is_watertight


def test_merged_vertices_leave_no_two_nearer_than_the_distance() -> None:
    rng = np.random.default_rng(0)
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.1)
    jittered = sphere.copy()
    jittered.vertices += rng.normal(0, 2e-3, sphere.vertices.shape)
    distance = float(np.quantile(jittered.edges_unique_length, 0.05))  # the shortest edges go
    merged = merge_close_vertices(jittered, distance)
    assert len(merged.vertices) < len(jittered.vertices)
    pairs = merged.vertices[:, None] - merged.vertices[None]
    assert (np.linalg.norm(pairs, axis=2) + np.eye(len(merged.vertices))).min() >= distance
    assert not (np.ptp(np.sort(merged.faces, axis=1), axis=1) == 0).any()  # no face lost a corner and stayed


def test_holes_are_closed_outward_including_two_that_touch() -> None:
    # Faces 100-102 are three corners of one subdivided triangle: their holes touch at vertices.
    sphere, holed = _sphere_without([0, 100, 101, 102, 500])
    assert not holed.is_watertight
    closed = close_holes(holed)
    assert closed.is_watertight and closed.is_winding_consistent
    assert closed.volume == pytest.approx(sphere.volume, rel=1e-3)


def test_holes_with_more_edges_than_the_limit_stay_open() -> None:
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.1)
    cap = sphere.triangles_center[:, 2] > 0.09  # a cap of about 40 border edges
    holed = trimesh.Trimesh(sphere.vertices, sphere.faces[~cap], process=False)
    assert not close_holes(holed, max_edges=20).is_watertight
    assert close_holes(holed, max_edges=100).is_watertight


def test_inward_wound_surface_is_finished_outward_and_left_as_it_was() -> None:
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.1)
    sphere.invert()
    finished = watertight_finish(sphere, max_faces=100_000)
    assert finished.is_watertight and finished.volume > 0
    assert sphere.volume < 0
    with pytest.raises(ModelError):
        watertight_finish(trimesh.Trimesh(), max_faces=100)


def test_decimation_reaches_the_target_and_keeps_a_closed_mesh_closed() -> None:
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=0.1)
    assert decimate(sphere, len(sphere.faces)) is sphere
    simple = decimate_closed(sphere, 2000)
    assert len(simple.faces) <= 2000 and simple.is_watertight
    assert simple.volume == pytest.approx(sphere.volume, rel=0.01)


def test_largest_piece_and_its_refusal_of_an_empty_mesh() -> None:
    big = trimesh.creation.icosphere(subdivisions=2, radius=0.1)
    small = trimesh.creation.icosphere(subdivisions=1, radius=0.01)
    small.apply_translation([1, 0, 0])
    assert len(largest_piece(trimesh.util.concatenate([small, big])).faces) == len(big.faces)
    assert largest_piece(big) is big
    with pytest.raises(ModelError):
        largest_piece(trimesh.Trimesh())


def test_poisson_surface_of_a_sphere_with_densities() -> None:
    rng = np.random.default_rng(1)
    normals = rng.normal(size=(4000, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    surface, densities = poisson_surface(0.1 * normals, normals, depth=6, scale=1.2)
    assert densities.shape == (len(surface.vertices),)
    radii = np.linalg.norm(surface.vertices, axis=1)
    assert np.median(np.abs(radii - 0.1)) < 0.002


def test_texels_cover_the_atlas_charts_and_lie_on_the_surface() -> None:
    box = trimesh.creation.box((0.2, 0.1, 0.05))
    atlas = chart_atlas(box, size_px=64, padding_px=2)
    assert np.allclose(atlas.mesh.vertices, box.vertices[atlas.source_vertex])
    assert atlas.uv.shape == (len(atlas.mesh.vertices), 2) and (0 <= atlas.uv).all() and (atlas.uv <= 1).all()
    texels = atlas_texels(atlas, 64)
    assert np.abs(np.abs(texels.points) - [0.1, 0.05, 0.025]).min(axis=1).max() < 1e-9  # on a face of the box
    assert np.allclose(texels.interpolate(atlas.mesh.vertices), texels.points)
    # A texel's point maps back to the texel's centre through the uv of its triangle; texels on
    # a triangle's edge (drawn so that the charts have no cracks) to the nearest point inside.
    uv = texels.interpolate(atlas.uv)
    offsets = np.hypot(uv[:, 0] * 64 - 0.5 - texels.cols, (1 - uv[:, 1]) * 64 - 0.5 - texels.rows)
    assert np.median(offsets) < 1e-9 and offsets.max() < 2.0


def test_painted_texture_fills_the_gutters_with_chart_colours() -> None:
    box = trimesh.creation.box((0.2, 0.1, 0.05))
    atlas = chart_atlas(box, size_px=64, padding_px=2)
    texels = atlas_texels(atlas, 64)
    colour = np.array([200, 100, 50], np.uint8)
    full = texels.paint(np.tile(colour, (len(texels.rows), 1)))
    assert (full == colour).all()  # every texel: the charts' own colour, no black bled in
    gutter = texels.paint(np.tile(colour, (len(texels.rows), 1)), gutter_px=1)
    painted = (gutter == colour).all(axis=2)
    assert painted.sum() > len(texels.rows) and not painted.all()
