"""Concave collision meshes split into convex parts (V-HACD), measured against the real surface."""

from __future__ import annotations

import tracemalloc
from pathlib import Path

import numpy as np
import pytest
import trimesh

from articulation.convex_parts import (
    _volume_points,
    as_convex_hull,
    cell_decomposition,
    decompose,
    fidelity,
    is_concave,
    solid_points,
    spans_a_volume,
)
from homemodel.exchange.model_files import write_model_files
from homemodel.model_folder.gate.validate import validate_path
from articulation.model import MeshGeometry
from articulation.scan_model import scan_model
from homemodel.geometry.surface_distance import SurfaceDistance


def _microwave_frame() -> trimesh.Trimesh:
    """A 0.4 x 0.5 x 0.3 m box with a cavity open at the front (+x), 30 mm walls."""
    cavity = trimesh.creation.box((0.4, 0.44, 0.26))
    cavity.apply_translation((0.03, 0, 0))
    return trimesh.creation.box((0.4, 0.5, 0.3)).difference(cavity)


def _cup() -> trimesh.Trimesh:
    """A 90 mm cup, 5 mm walls, 100 mm high, standing on z = 0."""
    wall = trimesh.creation.annulus(0.04, 0.045, 0.1)
    wall.apply_translation((0, 0, 0.05))
    floor = trimesh.creation.cylinder(0.045, 0.005)
    floor.apply_translation((0, 0, 0.0025))
    return wall.union(floor)


def test_a_concave_frame_is_split_into_faithful_convex_parts() -> None:
    frame = _microwave_frame()
    assert is_concave(frame) and not is_concave(trimesh.creation.box((0.4, 0.5, 0.3)))
    split = decompose(frame)
    assert 2 <= len(split.parts) <= 8
    assert all(part.mesh.is_convex for part in split.parts)
    # One hull reaches 60 mm or more past the frame into the cavity; no part reaches a third of that.
    assert split.hull_overshoot_m > 0.05
    assert max(p.overshoot_m for p in split.parts) < split.hull_overshoot_m / 3
    assert split.coverage > 0.95
    middle_of_cavity = np.array([[0.05, 0.0, 0.0]])
    assert frame.convex_hull.contains(middle_of_cavity)[0]
    assert not any(p.mesh.contains(middle_of_cavity)[0] for p in split.parts)


@pytest.mark.slow
def test_a_scanned_cup_keeps_its_opening_and_passes_the_gate(tmp_path: Path) -> None:
    model = scan_model(_cup(), name="cup_scan", density_kg_m3=1000.0)
    collisions = model.links[0].collisions
    assert len(collisions) > 1 and all(c.name.startswith("part_") for c in collisions)
    assert "convex parts covering" in model.properties["collision_parts"]
    inside_cup = np.array([[0.0, 0.0, 0.06]])
    assert not any(c.geometry.mesh.contains(inside_cup)[0] for c in collisions if isinstance(c.geometry, MeshGeometry))
    write_model_files(model, tmp_path)
    report = validate_path(tmp_path)
    assert report.ok, report.format()
    solid = scan_model(trimesh.creation.box((0.1, 0.1, 0.1)), name="box_scan", density_kg_m3=500.0)
    assert [c.name for c in solid.links[0].collisions] == ["hull"] and "collision_parts" not in solid.properties


def test_a_flat_or_collapsed_part_is_left_out_rather_than_given_to_qhull() -> None:
    # V-HACD can return a part of four or more faces whose points lie on one plane (a completed
    # mug's CLI run crashed in qhull on one): such a part has no hull and is dropped.
    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 0]], float)
    assert not spans_a_volume(square)
    assert not spans_a_volume(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 0]], float))
    assert spans_a_volume(trimesh.creation.box().vertices)


def test_a_mesh_that_bounds_a_convex_solid_is_its_own_hull() -> None:
    # The exporters write each collision mesh's hull: a part that already is one is written as it
    # is, anything else is rebuilt by qhull.
    box = trimesh.creation.box((0.1, 0.2, 0.3))
    assert as_convex_hull(box) is box
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=0.05)
    assert as_convex_hull(sphere) is sphere
    cup = trimesh.creation.annulus(0.04, 0.045, 0.1)  # concave: its inner wall faces inwards
    inverted = box.copy()
    inverted.invert()  # the faces' planes turned inwards
    open_box = trimesh.Trimesh(box.vertices, box.faces[:-1], process=False)  # not closed
    stray = trimesh.Trimesh(np.vstack([box.vertices, [[0.0, 0.0, 0.0]]]), box.faces, process=False)
    doubled = trimesh.Trimesh(box.vertices, np.vstack([box.faces, box.faces]), process=False)
    for mesh in (cup, inverted, open_box, stray, doubled):
        hull = as_convex_hull(mesh)
        assert hull is not mesh and hull.is_convex and hull.volume > 0
        assert hull.volume == pytest.approx(mesh.convex_hull.volume, rel=1e-12)


def test_a_large_closed_mesh_is_hulled_by_qhull_without_a_vertex_by_face_matrix() -> None:
    # Every vertex against every face of an imported asset's collision mesh would take GBs (a
    # sphere of 10,000 vertices: 3.3 GB): past a bound qhull builds the hull.
    sphere = trimesh.creation.icosphere(subdivisions=4)  # 2,562 vertices, 5,120 faces
    tracemalloc.start()
    try:
        hull = as_convex_hull(sphere)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 20e6, peak
    assert hull is not sphere and hull.volume == pytest.approx(sphere.volume, rel=1e-9)


class _Measure:
    """A surface's distances whose bounds are the real ones, exact, or loosened at random around
    the distances; counts the points asked about and the points measured exactly."""

    def __init__(self, to_surface: SurfaceDistance, bounds: str) -> None:
        self.to_surface, self.kind, self.rng = to_surface, bounds, np.random.default_rng(3)
        self.asked = self.measured = 0

    def distances(self, points: np.ndarray) -> np.ndarray:
        self.measured += len(points)
        return self.to_surface.distances(points)

    def bounds(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        self.asked += len(points)
        if self.kind == "real":
            return self.to_surface.bounds(points)
        d = self.to_surface.distances(points)
        if self.kind == "exact":
            return d, d
        return d * self.rng.uniform(0, 1, len(d)), d * self.rng.uniform(1, 2, len(d))


def test_the_overshoots_are_those_of_every_point_measured() -> None:
    # A cup's wall of 12,288 small triangles, 8 cells: their hulls reach about 10 mm into it.
    # `fidelity` measures exactly only the points whose bounds could change its figures.
    cup = trimesh.creation.annulus(0.04, 0.045, 0.1, sections=24).subdivide().subdivide().subdivide()
    to_cup = SurfaceDistance(cup, open3d=False)
    parts = [p.mesh for p in cell_decomposition(cup, 8, to_surface=to_cup).parts]
    every = fidelity(parts, cup, to_real=_Measure(to_cup, "exact"))
    for kind in ("real", "loose"):
        measure = _Measure(to_cup, kind)
        fit = fidelity(parts, cup, to_real=measure)
        assert np.array_equal(fit.overshoot_m, every.overshoot_m)
        assert (fit.overshoot_all_m, fit.overshoot_max_m) == (every.overshoot_all_m, every.overshoot_max_m)
        assert 0 < measure.measured < measure.asked / 2
    assert 0.005 < every.overshoot_all_m < 0.02


def _open_shell() -> trimesh.Trimesh:
    """Two nested spheres, the inner one open towards +x: from a point inside it the rays out
    through the hole and through its wall disagree, and trimesh casts a third in a random direction."""
    inner = trimesh.creation.icosphere(subdivisions=2, radius=0.06)
    inner.update_faces(inner.triangles_center[:, 0] < 0.045)
    inner.remove_unreferenced_vertices()
    return trimesh.util.concatenate([trimesh.creation.icosphere(subdivisions=2, radius=0.1), inner])


def test_an_open_meshs_points_and_figures_repeat_whatever_numpys_global_generator_holds() -> None:
    # Before, the cells' solid points (82 of 21,952 lattice points here), the V-HACD parts'
    # coverage samples and so the figures changed with np.random's state.
    shell = _open_shell()
    parts = [trimesh.creation.box((0.12, 0.12, 0.12)), trimesh.creation.icosphere(subdivisions=1, radius=0.08)]
    found = []
    for seed in (1, 2):
        np.random.seed(seed)
        fit = fidelity(parts, shell)
        found.append([solid_points(shell).inside.tolist(), _volume_points(shell, 2000).tolist(), fit.overshoot_m.tolist()])
        assert np.random.random() == np.random.RandomState(seed).random_sample()  # the caller's generator left as it was
    assert found[0] == found[1] and len(found[0][0]) > 1000 and len(found[0][1]) > 200
