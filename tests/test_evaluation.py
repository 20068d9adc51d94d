"""The shared evaluation metrics against analytic ground truth."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from homemodel.exchange.model_files import export_model
from articulation.model import Link, Material, Model, Visual
from homemodel.core.errors import InputError
from homemodel.evaluation import (
    f_score,
    mean_surface_distance_m,
    rock_surface_distance,
    rock_voxel_iou,
    voxel_iou,
)
from homemodel.geometry.mesh_io import load_mesh
from homemodel.evaluation.voxels import VoxelGrid, solid_occupancy


def sphere(radius: float, centre=(0.0, 0.0, 0.0)) -> trimesh.Trimesh:
    mesh = trimesh.creation.icosphere(subdivisions=5, radius=radius)
    mesh.apply_translation(centre)
    return mesh


def box(size, centre=(0.0, 0.0, 0.0)) -> trimesh.Trimesh:
    mesh = trimesh.creation.box(extents=size)
    mesh.apply_translation(centre)
    return mesh


def shifted_sphere_mean_distance(radius: float, shift: float) -> float:
    """Mean over a sphere's surface of the distance to the same sphere shifted by `shift`:
    cos(theta) is uniform on [-1, 1] for area-uniform points, so a 1-D integral."""
    cos = np.linspace(-1.0, 1.0, 200_001)
    return float(np.mean(np.abs(np.sqrt(radius**2 + shift**2 - 2 * radius * shift * cos) - radius)))


def test_identical_meshes_score_perfectly():
    mesh = sphere(0.04)
    assert voxel_iou(mesh, mesh.copy(), voxel_size_m=0.002) == 1.0
    assert rock_voxel_iou(mesh, mesh.copy()) == 1.0
    assert mean_surface_distance_m(mesh, mesh.copy(), n_samples=20_000) < 1e-7
    assert rock_surface_distance(mesh, mesh.copy(), n_samples=20_000) < 1e-7
    assert f_score(mesh, mesh.copy(), n_samples=20_000) == 1.0


@pytest.mark.parametrize("shift", [0.02, 0.05, 0.08])
def test_overlapping_boxes_match_the_analytic_iou(shift):
    a = box([0.1, 0.1, 0.1])
    b = box([0.1, 0.1, 0.1], centre=(shift, 0.0, 0.0))
    overlap = 0.1 - shift
    expected = overlap / (0.2 - overlap)
    # A solid voxelisation counts the surface voxels whole: allow about a voxel layer of error.
    assert voxel_iou(a, b, voxel_size_m=0.001) == pytest.approx(expected, abs=0.01)
    assert rock_voxel_iou(a, b) == pytest.approx(expected, abs=0.02)


def test_concentric_spheres_iou_is_the_volume_ratio():
    inner, outer = sphere(0.03), sphere(0.04)
    assert voxel_iou(inner, outer, voxel_size_m=0.0005) == pytest.approx((3 / 4) ** 3, abs=0.02)
    assert rock_voxel_iou(inner, outer) == pytest.approx((3 / 4) ** 3, abs=0.02)


def test_iou_is_symmetric_and_disjoint_solids_score_zero():
    a, b = box([0.05, 0.08, 0.1]), sphere(0.04, centre=(0.02, 0.0, 0.01))
    assert voxel_iou(a, b, voxel_size_m=0.001) == pytest.approx(voxel_iou(b, a, voxel_size_m=0.001), abs=1e-12)
    far = box([0.05, 0.05, 0.05], centre=(1.0, 0.0, 0.0))
    assert voxel_iou(a, far, voxel_size_m=0.005) == 0.0


def test_rock_conventions_do_not_depend_on_units_or_placement():
    a, b = box([0.05, 0.08, 0.1]), sphere(0.045, centre=(0.01, 0.0, 0.01))
    moved = trimesh.transformations.scale_and_translate(1000.0, [3.0, -7.0, 2.0])
    a_mm, b_mm = a.copy().apply_transform(moved), b.copy().apply_transform(moved)
    assert rock_voxel_iou(a_mm, b_mm) == pytest.approx(rock_voxel_iou(a, b), abs=0.003)
    assert rock_surface_distance(a_mm, b_mm, n_samples=20_000) == pytest.approx(
        rock_surface_distance(a, b, n_samples=20_000), rel=0.02
    )


def test_surface_distance_of_concentric_spheres_is_the_radius_gap():
    inner, outer = sphere(0.03), sphere(0.04)
    # Tessellation: the icosphere's facets lie up to r(1 - cos(edge/2r)) inside the sphere.
    assert mean_surface_distance_m(inner, outer, n_samples=20_000) == pytest.approx(0.01, abs=2e-4)
    # Rock: normalised so the outer sphere's diameter spans 4 - 2 voxels, then divided by the side 4.
    scale = 2 * (2.0 - 0.02) / 0.08
    assert rock_surface_distance(inner, outer, n_samples=20_000) == pytest.approx(0.01 * scale / 4, rel=0.03)


@pytest.mark.parametrize("shift", [0.002, 0.01, 0.03])
def test_surface_distance_of_a_shifted_sphere(shift):
    radius = 0.05
    a, b = sphere(radius), sphere(radius, centre=(shift, 0.0, 0.0))
    expected = shifted_sphere_mean_distance(radius, shift)
    assert mean_surface_distance_m(a, b, n_samples=50_000) == pytest.approx(expected, rel=0.03)


def test_f_score_threshold_is_a_fraction_of_the_gt_diagonal():
    gt = sphere(0.05)
    diagonal = float(np.linalg.norm(gt.extents))
    near = sphere(0.05 + 0.5 * 0.01 * diagonal)  # every point within half the threshold
    far = sphere(0.05 + 2.0 * 0.01 * diagonal)  # every point twice the threshold away
    assert f_score(near, gt, n_samples=20_000) == 1.0
    assert f_score(far, gt, n_samples=20_000) == 0.0
    assert f_score(far, gt, threshold_fraction=0.03, n_samples=20_000) == 1.0


def test_f_score_counts_missing_parts_as_lost_recall():
    gt = box([0.1, 0.1, 0.1])
    half = box([0.05, 0.1, 0.1], centre=(-0.025, 0.0, 0.0))
    # All of `half` lies on or inside gt but its cut face is 0.05 from gt's surface:
    # precision = 1 - area(cut face)/area(half), recall = area of gt's surface half covers.
    precision = 1 - 0.01 / 0.04
    recall = (0.01 + 4 * 0.005) / 0.06
    expected = 2 * precision * recall / (precision + recall)
    assert f_score(half, gt, n_samples=50_000) == pytest.approx(expected, abs=0.02)


def test_a_small_hole_in_the_surface_still_voxelises_solid():
    closed = sphere(0.04)
    holed = trimesh.Trimesh(closed.vertices, closed.faces[1:], process=False)
    assert not holed.is_watertight
    assert voxel_iou(holed, closed, voxel_size_m=0.001) > 0.99


def test_a_solid_cut_by_the_grid_border_stays_solid_inside_the_grid():
    ball = sphere(0.04)
    whole = VoxelGrid(origin_m=np.full(3, -0.05), voxel_size_m=0.002, shape=(50, 50, 50))
    # This grid holds the ball's left half only: its shell is open at the grid's border.
    half = VoxelGrid(origin_m=np.full(3, -0.05), voxel_size_m=0.002, shape=(25, 50, 50))
    cut = solid_occupancy(ball, half)
    assert np.array_equal(cut, solid_occupancy(ball, whole)[:25])
    assert cut[20, 25, 25]  # the centre's neighbourhood, not flooded from the open side


def test_an_open_cup_stays_hollow():
    outer = trimesh.creation.cylinder(radius=0.04, height=0.1, sections=64)
    # Remove the top cap of a cylinder: an open cylinder is a shell with an open end.
    top = outer.triangles_center[:, 2] > 0.0499
    shell = trimesh.Trimesh(outer.vertices, outer.faces[~top], process=False)
    iou = voxel_iou(shell, outer, voxel_size_m=0.001)
    assert iou < 0.2  # only the shell's voxels and the bottom are occupied


def test_bad_input_is_refused_with_a_clear_error(tmp_path):
    empty = trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64))
    with pytest.raises(InputError, match="pred: the mesh has no triangles"):
        voxel_iou(empty, sphere(0.04), voxel_size_m=0.001)
    nan = sphere(0.04)
    nan.vertices[0] = np.nan
    with pytest.raises(InputError, match="gt: the mesh has non-finite"):
        mean_surface_distance_m(sphere(0.04), nan)
    with pytest.raises(InputError, match="choose a larger voxel size"):
        voxel_iou(sphere(0.04), sphere(0.04), voxel_size_m=1e-5)
    with pytest.raises(InputError, match="positive"):
        voxel_iou(sphere(0.04), sphere(0.04), voxel_size_m=0.0)
    corrupt = tmp_path / "broken.ply"
    corrupt.write_bytes(b"ply\nformat nonsense\n")
    with pytest.raises(InputError, match="broken.ply"):
        load_mesh(corrupt)
    with pytest.raises(InputError, match="no such file"):
        load_mesh(tmp_path / "missing.obj")


def test_mesh_files_and_model_folders_load_in_the_model_frame(tmp_path):
    mesh = box([0.1, 0.2, 0.3], centre=(0.0, 0.0, 0.15))
    mesh.export(tmp_path / "box.stl")
    model = Model(
        name="box", links=[Link(name="body", visuals=[Visual(name="body", mesh=mesh, material=Material(name="grey"))])]
    )
    export_model(model, tmp_path / "model")
    for path in (tmp_path / "box.stl", tmp_path / "model"):
        loaded = load_mesh(path)
        assert np.allclose(loaded.bounds, mesh.bounds, atol=1e-6)


def test_eval_commands_print_the_figures_and_refuse_bad_files(tmp_path):
    import json

    from typer.testing import CliRunner

    from homemodel.cli import app

    a, b = box([0.1, 0.1, 0.1]), box([0.1, 0.1, 0.1], centre=(0.05, 0.0, 0.0))
    a.export(tmp_path / "a.stl")
    b.export(tmp_path / "b.ply")
    runner = CliRunner()
    result = runner.invoke(app, ["eval", "voxel-iou", str(tmp_path / "a.stl"), str(tmp_path / "b.ply"), "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["rock_voxel_iou"] == pytest.approx(1 / 3, abs=0.02)
    result = runner.invoke(app, ["eval", "surface-distance", str(tmp_path / "a.stl"), str(tmp_path / "a.stl")])
    assert result.exit_code == 0, result.output
    figures = dict(line.split() for line in result.stdout.splitlines())
    assert float(figures["mean_surface_distance_m"]) < 1e-7 and float(figures["f_score@0.01"]) == 1.0
    result = runner.invoke(app, ["eval", "voxel-iou", str(tmp_path / "a.stl"), str(tmp_path / "none.obj")])
    assert result.exit_code == 2 and "none.obj: no such file" in result.output


def test_camera_pose_errors_are_the_centre_distance_and_the_rotation_angle():
    from homemodel.evaluation import camera_pose_errors
    from homemodel.core.transforms import transform_from_xyz_rpy

    true = transform_from_xyz_rpy((0.1, -0.2, 0.7), (0.3, 0.1, -0.4))
    # The camera moved 2 mm along its own x and turned 0.5 degrees about its own z.
    camera_from_true_camera = transform_from_xyz_rpy((-0.002, 0, 0), (0, 0, np.radians(0.5)))
    estimated = camera_from_true_camera @ true
    centres, angles = camera_pose_errors({"f0": estimated, "f1": true}, {"f0": true, "f1": true, "f2": true})
    np.testing.assert_allclose(centres, [0.002, 0.0], atol=1e-12)
    np.testing.assert_allclose(angles, [0.5, 0.0], atol=1e-6)
