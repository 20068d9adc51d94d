"""The turntable's signed-distance surface (`turntable.meshing.distance_surface`) against exact
shapes: on the surface, closed, a patch with no points closed over rather than leaked through,
a concavity no camera saw into left open, points weighed by their raw counts, and the Poisson
fallback."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from homemodel.evaluation import mean_surface_distance_m
from turntable.fusion import Cylinder, MergedCloud
from turntable.meshing import MeshingOptions, _marched_on_table_top, distance_surface, object_mesh

VOXEL_M = 0.0015


def oriented_points(mesh: trimesh.Trimesh, spacing_m: float = VOXEL_M, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """About one point per `spacing_m` squared of the surface, with the faces' outward normals,
    as the merge's voxel centroids would lie."""
    count = int(mesh.area / spacing_m**2)
    points, faces = trimesh.sample.sample_surface_even(mesh, count, radius=0.7 * spacing_m, seed=seed)
    return points, mesh.face_normals[faces]


def test_a_sphere_is_closed_and_on_the_points() -> None:
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=0.04)
    points, normals = oriented_points(sphere)
    mesh = distance_surface(points, normals, VOXEL_M, reach_voxels=3.0, seal_voxels=3)
    mesh = max(mesh.split(only_watertight=False), key=lambda piece: len(piece.faces))
    assert mesh.is_watertight
    assert mean_surface_distance_m(mesh, sphere, n_samples=20_000) < 0.1e-3  # a fifteenth of a voxel
    assert mesh.volume == pytest.approx(sphere.volume, rel=0.02)


def test_points_weighted_by_their_raw_counts_pull_the_surface_back_from_a_noise_tail() -> None:
    """A sphere's points, each the average of 16 raw points, and beside half of them a voxel
    and a half outside the average of one (depth noise's tail, as a merge of many noisy frames
    keeps it): unweighted the surface moves out by a fifth of a voxel, weighted by the square
    root of the counts (as `object_mesh` weighs the merged points) by a twentieth."""
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=0.03)
    points, normals = oriented_points(sphere)
    tail = np.random.default_rng(0).random(len(points)) < 0.5
    points = np.concatenate([points, points[tail] + 1.5 * VOXEL_M * normals[tail]])
    normals = np.concatenate([normals, normals[tail]])
    counts = np.concatenate([np.full(len(tail), 16), np.ones(tail.sum())])
    for weights, most_mm in ((None, 0.4), (np.sqrt(counts), 0.1)):
        mesh = distance_surface(points, normals, VOXEL_M, reach_voxels=3.0, seal_voxels=3, weights=weights)
        mesh = max(mesh.split(only_watertight=False), key=lambda piece: len(piece.faces))
        out_mm = 1000 * (np.linalg.norm(mesh.vertices, axis=1).mean() - 0.03)
        assert (0.2 if weights is None else 0.0) < out_mm < most_mm, f"{out_mm:.3f} mm out"


def test_a_patch_without_points_is_closed_over_not_leaked_into() -> None:
    """A closed box with a 16 mm square of its side unseen (a dark patch): still a solid box;
    without the seal the outside leaks in, and the hollow shell it would leave is refused."""
    box = trimesh.creation.box(extents=(0.06, 0.05, 0.04))
    points, normals = oriented_points(box)
    patch = (np.abs(points[:, 0] - 0.03) < 1e-6) & (np.abs(points[:, 1]) < 0.008) & (np.abs(points[:, 2]) < 0.008)
    assert patch.sum() > 50
    mesh = distance_surface(points[~patch], normals[~patch], VOXEL_M, reach_voxels=3.0, seal_voxels=3)
    mesh = max(mesh.split(only_watertight=False), key=lambda piece: len(piece.faces))
    assert mesh.is_watertight
    assert mesh.volume == pytest.approx(box.volume, rel=0.03)
    assert mean_surface_distance_m(mesh, box, n_samples=20_000) < 0.3e-3
    # Unsealed, the outside leaks in: the hollow shell is refused (object_mesh then uses Poisson).
    leaked = distance_surface(points[~patch], normals[~patch], VOXEL_M, reach_voxels=3.0, seal_voxels=0)
    assert len(leaked.faces) == 0


def test_an_unseen_concavity_stays_open_and_the_pipeline_mesh_is_closed() -> None:
    """A cup (outer radius 30 mm, wall 4 mm, 60 mm tall) whose inside is seen only down to
    20 mm below the rim: the surface follows the walls down and does not lid the cup over
    where the points stop, as Poisson does; `object_mesh` (outliers, normals, the footprint)
    returns it closed, standing on the table."""
    outer = trimesh.creation.cylinder(radius=0.03, height=0.06, sections=128)
    inner = trimesh.creation.cylinder(radius=0.026, height=0.06, sections=128)
    inner.apply_translation([0, 0, 0.006])  # a 6 mm floor
    cup = outer.difference(inner)
    cup.apply_translation([0, 0, 0.03])  # standing on z = 0
    points, normals = oriented_points(cup)
    radial = np.hypot(points[:, 0], points[:, 1])
    seen = (points[:, 2] > 0.0) & ~((radial < 0.0262) & (points[:, 2] < 0.04))  # the inside's lower part unseen
    cloud = MergedCloud(
        points=points[seen],
        colors=np.full((seen.sum(), 3), 0.5),
        view_dirs=normals[seen],  # each point seen from its outside
        counts=np.ones(seen.sum(), dtype=np.int64),
    )
    cylinder = Cylinder(axis_xy_m=np.zeros(2), radius_m=0.1, z_min_m=0.0, z_max_m=1.0)
    mesh, colors, figures = object_mesh(cloud, cylinder, VOXEL_M, MeshingOptions())
    assert figures.triangles_poisson is None  # the signed-distance surface, no Poisson fallback
    assert mesh.is_watertight
    assert mesh.bounds[0, 2] >= 0.0
    assert np.allclose(colors, 0.5)
    # Open down to the unseen floor: far less than the cup lidded 20 mm below its rim.
    lidded = cup.volume + np.pi * 0.026**2 * 0.02
    assert mesh.volume < cup.volume + 0.35 * (lidded - cup.volume)
    assert mesh.volume > 0.9 * cup.volume
    poisson, _, poisson_figures = object_mesh(cloud, cylinder, VOXEL_M, MeshingOptions(surface="poisson"))
    assert poisson_figures.triangles_poisson > 0 and poisson.is_watertight
    # The seen surface agrees with the cup's within a voxel either way.
    for result in (mesh, poisson):
        _, distance, _ = trimesh.proximity.closest_point(result, points[seen][::20])
        assert np.median(distance) < 0.5 * VOXEL_M


def test_a_box_on_the_table_keeps_its_footprint_despite_stray_points_at_its_corners() -> None:
    """A 100 x 70 x 120 mm box seen down to 4 mm above the table (the merge's margin), with
    0.3 mm noise and 40 lone stray points 2-9 mm outside its lower corners (flying pixels):
    the mesh stands on the box's own footprint. The footprint's outline once took the strays
    in and its tangent plane carried the inside past the walls: a skirt 3-4 mm wide round the
    base (0.83 mm on the recordings' box)."""
    box = trimesh.creation.box(extents=(0.1, 0.07, 0.12))
    box.apply_translation([0.01, -0.007, 0.06])
    points, normals = oriented_points(box)
    rng = np.random.default_rng(0)
    seen = points[:, 2] > 0.004
    points = points[seen] + rng.normal(0.0, 0.0003, (seen.sum(), 3))
    corner = rng.integers(0, 4, 40)
    outward = np.array([[-1, -1], [-1, 1], [1, -1], [1, 1]])[corner]
    corners_xy = np.where(outward > 0, box.bounds[1, :2], box.bounds[0, :2])
    stray = np.column_stack([corners_xy + outward * rng.uniform(0.002, 0.009, (40, 2)), rng.uniform(0.005, 0.03, 40)])
    points = np.concatenate([points, stray])
    normals = np.concatenate([normals[seen], np.column_stack([outward / np.sqrt(2), np.zeros(40)])])
    cloud = MergedCloud(
        points=points, colors=np.full((len(points), 3), 0.5), view_dirs=normals, counts=np.ones(len(points), dtype=np.int64)
    )
    cylinder = Cylinder(axis_xy_m=np.array([0.01, -0.007]), radius_m=0.1, z_min_m=0.004, z_max_m=1.0)
    mesh, _, figures = object_mesh(cloud, cylinder, VOXEL_M, MeshingOptions())
    assert figures.triangles_poisson is None and mesh.is_watertight
    assert np.abs(mesh.bounds - box.bounds).max() < 1.0e-3  # 3.3-4.3 mm with the skirt
    assert mean_surface_distance_m(mesh, box, n_samples=20_000) < 0.13e-3  # 0.16 mm with it
    assert mesh.volume == pytest.approx(box.volume, rel=0.01)


def test_marching_cubes_largest_piece_is_kept_and_closed_only_when_wound_one_way() -> None:
    """`object_mesh` keeps marching cubes' largest piece (islands from stray points) and trusts
    it closed only when each directed edge appears once and its reverse once: a hole, or a face
    wound against the others (which trimesh's `is_watertight` lets pass), sends it to the repair."""
    big = trimesh.creation.icosphere(subdivisions=3, radius=0.04).apply_translation([0, 0, 0.05])
    island = trimesh.creation.icosphere(subdivisions=1, radius=0.005).apply_translation([0.08, 0, 0.01])
    kept, closed = _marched_on_table_top(trimesh.util.concatenate([island, big]))
    assert closed and len(kept.faces) == len(big.faces) and np.allclose(kept.vertices, big.vertices)
    assert np.array_equal(kept.faces, big.faces)
    holed = trimesh.Trimesh(big.vertices, big.faces[1:], process=False)
    assert not _marched_on_table_top(holed)[1]
    flipped = big.faces.copy()
    flipped[0] = flipped[0, ::-1]
    assert trimesh.Trimesh(big.vertices, flipped, process=False).is_watertight
    assert not _marched_on_table_top(trimesh.Trimesh(big.vertices, flipped, process=False))[1]
