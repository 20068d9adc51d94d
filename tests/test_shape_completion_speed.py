"""Shape completion's faster paths decide as the plain ones do: the booster predicted coarse to
fine against every voxel predicted, the grid's depth lookup through two pinhole tables against
projecting every voxel centre, spin images binned in one pass against np.histogram2d, and the
batched Kabsch fits against one at a time; a query's BLAS on one thread."""

from __future__ import annotations

import numpy as np
import pytest
from cli_promise import REPO

from homemodel.core.errors import InputError
from homemodel.evaluation.voxels import solid_occupancy
from homemodel.geometry.raycast import RayCaster
from shape_completion.filling import VoxelFiller, carve, depth_behind, grid_depth_behind
from shape_completion.procedural import generate_instances
from shape_completion.queries import FILLER_CAMERA, random_query_pose
from shape_completion.registration import kabsch, kabsch_batch
from shape_completion.spin_images import ALPHA_BINS, BETA_BINS, spin_images
from shape_completion.symmetry import RevolutionAxis


@pytest.fixture(scope="module")
def carved_mug():
    """A rendered generated mug carved around a stand-in for its fitted model (the true mug
    scaled by 5 % about its centre, revolved about its body's axis), and the truth on the
    carving's grid."""
    mug = generate_instances("cup", 3, seed=4)[2]
    camera_from_object = random_query_pose(mug, np.random.default_rng(1))
    depth = RayCaster(mug).depth(FILLER_CAMERA, camera_from_object)
    truth_mesh = mug.copy().apply_transform(camera_from_object)
    centre = truth_mesh.bounds.mean(axis=0)
    deformed = truth_mesh.copy()
    deformed.vertices = centre + 1.05 * (deformed.vertices - centre)
    carved = carve(
        depth_m=depth,
        camera=FILLER_CAMERA,
        deformed=deformed,
        planes_camera=[],
        axis_camera=RevolutionAxis(point=camera_from_object[:3, 3], direction=camera_from_object[:3, 2]),
        match_distance_m=0.004,
        fit_distance_m=0.002,
        class_index=0,
        resolution=64,
    )
    return carved, depth, solid_occupancy(truth_mesh, carved.grid)


def test_coarse_to_fine_prediction_decides_as_predicting_every_voxel(carved_mug):
    carved, _, truth = carved_mug
    features = carved.features
    assert len(features) > 5_000
    sample = np.random.default_rng(0).permutation(len(features))[:6_000]
    filler = VoxelFiller(max_iter=40).fit(features[sample], truth[carved.ambiguous][sample])
    level = 0.5
    every = filler.occupancy_probability(features)
    predicted = []
    counting = VoxelFiller(max_iter=40)
    counting.__dict__.update(filler.__dict__)
    counting.occupancy_probability = lambda rows: predicted.append(len(rows)) or filler.occupancy_probability(rows)
    coarse = carved.ambiguous_probability(counting, level)
    assert coarse.shape == every.shape and np.all(np.isfinite(coarse))
    agree = np.mean((coarse > level) == (every > level))
    assert agree > 0.99, agree
    assert sum(predicted) < 0.6 * len(every), (sum(predicted), len(every))
    # Where it predicted, it is the booster's own value.
    exact = np.isclose(coarse, every)
    assert exact.mean() > 0.3


def test_the_grids_depth_lookup_is_the_per_voxel_projection(carved_mug):
    carved, depth, _ = carved_mug
    grid = carved.grid
    expected = depth_behind(grid.centres_m().reshape(-1, 3), depth, FILLER_CAMERA).reshape(grid.shape)
    found = grid_depth_behind(grid, depth, FILLER_CAMERA)
    assert np.array_equal(np.isnan(found), np.isnan(expected))
    assert np.allclose(found[~np.isnan(found)], expected[~np.isnan(expected)], atol=1e-12)


def test_spin_images_bin_as_histogram2d():
    rng = np.random.default_rng(3)
    points = rng.normal(scale=0.05, size=(1500, 3))
    normals = rng.normal(size=(1500, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    keypoints = rng.choice(len(points), 80, replace=False)
    radius = 0.04
    images = spin_images(points, normals, keypoints, radius)
    for row, index in enumerate(keypoints):
        offsets = points[np.linalg.norm(points - points[index], axis=1) <= radius] - points[index]
        beta = offsets @ normals[index]
        alpha = np.sqrt(np.maximum((offsets**2).sum(axis=1) - beta**2, 0.0))
        reference, _, _ = np.histogram2d(
            alpha, beta, bins=(ALPHA_BINS, BETA_BINS), range=((0.0, radius), (-radius, radius))
        )
        reference = reference.ravel() / max(np.linalg.norm(reference), 1e-12)
        assert np.allclose(images[row], reference, atol=1e-12)


def test_batched_kabsch_is_kabsch():
    rng = np.random.default_rng(5)
    source, target = rng.normal(size=(40, 6, 3)), rng.normal(size=(40, 6, 3))
    one_by_one = np.array([kabsch(s, t) for s, t in zip(source, target)])
    assert np.allclose(kabsch_batch(source, target), one_by_one, atol=1e-12)


def test_a_query_runs_its_blas_on_one_thread(tmp_path, monkeypatch):
    """OpenBLAS's second thread spin-waits between a query's many small products (64,100
    sched_yield calls in one README query, 1,359 on one thread): `complete()` limits BLAS to one
    thread while it works, and gives the caller's limits back after."""
    from threadpoolctl import threadpool_info, threadpool_limits

    from shape_completion import complete
    from shape_completion.pipeline import ShapeCompleter

    def blas_threads() -> list[int]:
        return [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]

    seen = []

    def record_and_stop(self, depth_m, camera, progress=None):
        seen.append(blas_threads())
        raise InputError("stopped by the test")

    monkeypatch.setattr(ShapeCompleter, "complete", record_and_stop)
    inputs = REPO / "examples" / "database" / "inputs"
    with threadpool_limits(limits=2, user_api="blas"):  # the caller's own limit, whatever the machine's cores
        before = blas_threads()
        with pytest.raises(InputError, match="stopped by the test"):
            complete(inputs / "completer.npz", inputs / "query" / "depth.png", tmp_path / "out")
        assert blas_threads() == before and max(before) == 2
    assert seen and set(seen[0]) == {1}
    assert not (tmp_path / "out").exists()
