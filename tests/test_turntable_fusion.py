"""The merge's voxel sums (`turntable.fusion.VoxelAccumulator`) against a plain grouping of all
the points at once: the dense-grid grouping of a compact cloud, the sorted grouping of points far
apart, and sums folded in over several flushes."""

from __future__ import annotations

import numpy as np
import pytest

import turntable.fusion
from turntable.fusion import VoxelAccumulator

VOXEL_M = 0.0015


def _frames(seed: int) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Eight frames of 3,000 points round the origin (negative coordinates too), a few
    millimetres wide and of a different width along each axis (a mix-up of axes shows), with
    colours and unit directions. Their voxels' box holds fewer than 8 cells a point: the
    dense grid's grouping, from the first flush on."""
    rng = np.random.default_rng(seed)
    frames = []
    for _ in range(8):
        points = rng.normal(0.0, [0.005, 0.004, 0.003], (3000, 3))
        views = rng.normal(size=(3000, 3))
        frames.append((points, rng.random((3000, 3)), views / np.linalg.norm(views, axis=1, keepdims=True)))
    return frames


def _grouped_at_once(frames: list, voxel_m: float) -> dict[tuple[int, int, int], np.ndarray]:
    """Per voxel (integer cell), the mean point, colour, the mean direction and the count."""
    points, colors, views = (np.concatenate(parts) for parts in zip(*frames))
    cells = np.floor(points / voxel_m).astype(np.int64)
    unique, inverse = np.unique(cells, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    counts = np.bincount(inverse)
    means = [np.column_stack([np.bincount(inverse, c) for c in a.T]) / counts[:, None] for a in (points, colors)]
    direction = np.column_stack([np.bincount(inverse, c) for c in views.T])
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    rows = np.column_stack([*means, direction, counts])
    return {tuple(cell): row for cell, row in zip(unique.tolist(), rows)}


@pytest.mark.parametrize("far_points", [False, True], ids=["dense grid", "sorted"])
@pytest.mark.parametrize("flush_points", [1_000, 2_000_000], ids=["many flushes", "one flush"])
def test_voxel_sums_equal_a_grouping_of_all_points(far_points: bool, flush_points: int, monkeypatch) -> None:
    monkeypatch.setattr(turntable.fusion, "_FLUSH_POINTS", flush_points)
    frames = _frames(seed=1)
    if far_points:  # the box 80 m wide: sorted
        points, colors, views = frames[-1]
        frames[-1] = (np.vstack([points, [[40.0, -40.0, 40.0], [-40.0, 40.0, 0.0]]]),
                      np.vstack([colors, np.ones((2, 3))]), np.vstack([views, np.eye(3)[:2]]))  # fmt: skip
    merge = VoxelAccumulator(voxel_size_m=VOXEL_M)
    for frame in frames:
        merge.add(*frame)
    merge.add(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3)))
    cloud = merge.cloud()
    expected = _grouped_at_once(frames, VOXEL_M)
    cells = np.floor(cloud.points / VOXEL_M).astype(np.int64)
    assert len(cloud.points) == len(expected) > 2000  # about 10 points a voxel
    assert len({tuple(c) for c in cells.tolist()}) == len(expected)
    want = np.array([expected[tuple(cell)] for cell in cells.tolist()])
    got = np.column_stack([cloud.points, cloud.colors, cloud.view_dirs, cloud.counts])
    assert np.allclose(got, want, rtol=1e-12, atol=1e-15)
    assert cloud.counts.sum() == sum(len(frame[0]) for frame in frames)
