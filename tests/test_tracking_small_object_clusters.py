"""`tracking.find_small_objects`: which clusters of unexplained points a moved small object is
looked for in. A large object seen a little off its estimate (the map's pose 2-3 cm off, kept
in doubt) shows its own edges and knobs as such clusters; a moved object is looked for only
in the clusters standing clear of the large objects' faces that do not face up."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tracking.find_small_objects import POSE_DOUBT_M, _Cluster, _faces, _off_their_sides
from tracking.fit_state import FitState
from tracking.scene import HomeScene


def _cluster(state: FitState, owner: str, points_object: np.ndarray, height_m: float) -> _Cluster:
    map_from_object = state.map_from_objects[owner]
    points = points_object @ map_from_object[:3, :3].T + map_from_object[:3, 3]
    return _Cluster(points=points, owner=owner, height_m=height_m, relation="on")


def test_a_cluster_against_a_large_objects_face_is_not_taken_for_a_moved_object(kitchen_map: Path) -> None:
    state = FitState.start(HomeScene.load(kitchen_map))
    rng = np.random.default_rng(0)
    low, high = state.scene.object("oven_1").model.world_mesh().bounds
    # Patches 1 cm off the oven's back and side (its own surface seen 1 cm off its estimate).
    patch = rng.uniform([-0.05, -0.02, 0.40], [0.05, 0.02, 0.50], (60, 3))
    back = _cluster(state, "oven_1", patch[:, [1, 0, 2]] + [low[0] - 0.01, 0.0, 0.0], float(high[2]))
    side = _cluster(state, "oven_1", patch + [0.0, high[1] + 0.01, 0.0], float(high[2]))
    # A cup's near half (8 cm across, 10 cm tall) on the middle of the table, and one standing
    # 1 cm from the oven's side: both clear of the faces by more than the pose's doubt.
    angle = rng.uniform(-np.pi / 2, np.pi / 2, 200)
    half_cup = np.column_stack([0.04 * np.cos(angle), 0.04 * np.sin(angle), rng.uniform(0.0, 0.1, 200)])
    table_top = float(state.scene.object("table_1").model.world_mesh().bounds[1, 2])
    on_table = _cluster(state, "table_1", half_cup + [0.0, 0.0, table_top], table_top)
    beside = _cluster(state, "oven_1", half_cup + [0.0, high[1] + 0.05, 0.2], 0.2)  # its half seen from the front
    faces = [_faces(state, object_id) for object_id in ("oven_1", "table_1")]
    clear = _off_their_sides(faces, [back, side, on_table, beside])
    assert clear == [False, False, True, True]
    assert POSE_DOUBT_M >= 0.02  # the map's pose is 2-3 cm off


def test_a_cluster_is_left_at_another_objects_colour_only_until_its_own_is_found(monkeypatch) -> None:  # noqa: ANN001
    """`_fit_on_cluster`'s starts stop at a colour FAR_COLOUR times `max_colour_difference`
    off (another object's cluster) only while no start has found the object's own colour: a
    later start that slid onto a neighbour of another colour leaves the one found standing.
    The starts' refinements are scripted (no rendering)."""
    from types import SimpleNamespace

    import tracking.find_small_objects as fso

    search = fso.SmallObjectSearch()
    far = 2 * fso.FAR_COLOUR * search.max_colour_difference

    def candidate(x_m: float, colour: float) -> fso._Candidate:
        pose = np.eye(4)
        pose[0, 3] = x_m  # each its own place: no two ends together
        return fso._Candidate(map_from_object=pose, explained=0.8, cluster_explained=0.8, rmse_m=0.001, misfit=10,
                              kernel_m=0.01, colour_difference=colour)

    view = SimpleNamespace(map_from_camera=np.eye(4))
    view.around = lambda corners: (view,)
    monkeypatch.setattr(fso, "_scene_depth", lambda state, view: None)
    monkeypatch.setattr(fso, "_yaw_as_seen", lambda state, view, depth, object_id, best, cluster, search: best)
    # What follows the starts (the misfit's descent, the place pinned, the relief) is not this test's.
    monkeypatch.setattr(fso, "_settled", lambda state, view, depth, object_id, best, cluster, search: best)
    monkeypatch.setattr(fso, "_pinned", lambda *args: True)
    monkeypatch.setattr(fso, "_own_relief_seen", lambda *args: True)
    cluster = _Cluster(points=np.random.default_rng(0).uniform(-0.04, 0.04, (40, 3)) + [1.0, 0.0, 0.75],
                       owner="table_1", height_m=0.75, relation="on")
    bounds = np.array([[-0.04, -0.04, 0.0], [0.04, 0.04, 0.1]])
    for script, found in (([candidate(0.0, 0.01), candidate(0.05, far)], 0.0), ([candidate(0.0, far)], None)):
        calls = iter(script + [None] * 2 * search.yaw_candidates)
        monkeypatch.setattr(fso, "_refine", lambda *args: next(calls))
        best = fso._fit_on_cluster(None, view, "red_cup", bounds, cluster, search)
        assert (best is None) if found is None else best.map_from_object[0, 3] == found
        if found is None:
            assert next(calls) is None and len(list(calls)) == 2 * search.yaw_candidates - 1  # stopped at the first start
