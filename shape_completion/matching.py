"""Matching: a random forest that groups training views of similar shape and viewpoint, and the
alignment of a candidate view's cloud with the query that ranks the candidates.

Departure from the paper: Rock et al. split on the entropy of the views' shape codes.
scikit-learn's regression forest splits on squared error over the codes instead; for
codes modelled as a Gaussian the entropy is a monotone function of their variance, so
reducing the summed variance is the same criterion under a diagonal-Gaussian model, and it
runs in scikit-learn's compiled tree builder.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from homemodel.geometry.camera import Camera
from shape_completion.estimator import Estimator
from shape_completion.registration import apply
from shape_completion.tree_arrays import ForestArrays


class ViewForest(Estimator):
    """Retrieves the training views that share the most leaves with a query's features."""

    def __init__(
        self,
        *,
        n_estimators: int = 40,
        min_samples_leaf: int = 2,
        max_features: str | float = "sqrt",
        random_state: int = 0,
    ) -> None:
        self.n_estimators = n_estimators
        self.min_samples_leaf = min_samples_leaf
        self.max_features = max_features
        self.random_state = random_state

    def fit(self, features: np.ndarray, codes: np.ndarray) -> ViewForest:
        from sklearn.ensemble import RandomForestRegressor

        forest = RandomForestRegressor(
            n_estimators=self.n_estimators,
            min_samples_leaf=self.min_samples_leaf,
            max_features=self.max_features,
            random_state=self.random_state,
            n_jobs=1,
        ).fit(features, codes)
        self.trees_ = ForestArrays.from_sklearn(forest)  # what a model file keeps: arrays, no code
        self.train_leaves_ = forest.apply(features)
        return self

    def candidates(self, features: np.ndarray, count: int, exclude: np.ndarray | None = None) -> np.ndarray:
        """Indices of up to `count` training views, most shared leaves first; `exclude` is a
        boolean mask of views that may not be returned (leave-one-out training of the filler)."""
        leaves = self.trees_.apply(features.reshape(1, -1))[0]
        votes = (self.train_leaves_ == leaves).sum(axis=1).astype(np.float64)
        if exclude is not None:
            votes[exclude] = -1.0
        order = np.argsort(-votes, kind="stable")
        order = order[votes[order] > 0]
        return order[:count]


def quarter_turned(camera: Camera, turns: int) -> Camera:
    """The intrinsics of np.rot90(image, turns): each turn puts old row r, column c at row
    width - 1 - c, column r."""
    for _ in range(turns % 4):
        camera = Camera(
            width=camera.height,
            height=camera.width,
            fx=camera.fy,
            fy=camera.fx,
            cx=camera.cy,
            cy=camera.width - 1 - camera.cx,
        )
    return camera




def aligned_chamfer(
    view_cloud: np.ndarray,
    query: np.ndarray,
    query_tree: cKDTree,
    *,
    quarter_turns: int = 0,
    beaten_at: float = np.inf,
) -> tuple[float, np.ndarray] | None:
    """Mean two-way nearest-point distance after moving the view's cloud onto the query: rolled
    about the view camera's optical axis to undo a `quarter_turns` np.rot90 of the query image,
    turned so its centroid lies on the query centroid's ray, then shifted to the query's
    centroid. Returns the distance and that motion (4x4, query camera from view camera), or None
    when the view-to-query half alone shows the distance is `beaten_at` or more (the query-to-view
    half, 1,500 points against a tree of the view's 400 built for it, is then not measured)."""
    roll = np.eye(4)
    # np.rot90 maps a point's image coordinates (x, y) to (y, -x): undo it with +90 degrees about z.
    roll[:3, :3] = np.linalg.matrix_power(np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]), quarter_turns)
    rolled = apply(roll, view_cloud)
    view_centre, query_centre = rolled.mean(axis=0), query.mean(axis=0)
    a, b = view_centre / np.linalg.norm(view_centre), query_centre / np.linalg.norm(query_centre)
    rotation = _rotation_between(a, b)
    motion = np.eye(4)
    motion[:3, :3] = rotation
    motion[:3, 3] = query_centre - rotation @ view_centre
    moved = apply(motion, rolled)
    to_query = query_tree.query(moved)[0].mean()
    if 0.5 * to_query >= beaten_at:  # the other half adds a non-negative mean
        return None
    distance = 0.5 * (to_query + cKDTree(moved).query(query)[0].mean())
    return float(distance), motion @ roll


def _rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation taking unit vector a to unit vector b (Rodrigues)."""
    axis = np.cross(a, b)
    sin, cos = np.linalg.norm(axis), float(a @ b)
    if sin < 1e-12:
        return np.eye(3)
    k = axis / sin
    skew = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + sin * skew + (1 - cos) * skew @ skew
