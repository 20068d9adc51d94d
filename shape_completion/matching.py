"""Matching: a random forest that groups training views of similar shape and viewpoint.

Departure from the paper: Rock et al. split on the entropy of the views' shape codes.
scikit-learn's regression forest splits on squared error over the codes instead; for
codes modelled as a Gaussian the entropy is a monotone function of their variance, so
reducing the summed variance is the same criterion under a diagonal-Gaussian model, and it
runs in scikit-learn's compiled tree builder.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.ensemble import RandomForestRegressor


class ViewForest(BaseEstimator):
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
        self.forest_ = RandomForestRegressor(
            n_estimators=self.n_estimators,
            min_samples_leaf=self.min_samples_leaf,
            max_features=self.max_features,
            random_state=self.random_state,
            n_jobs=1,
        ).fit(features, codes)
        self.train_leaves_ = self.forest_.apply(features)
        return self

    def candidates(self, features: np.ndarray, count: int, exclude: np.ndarray | None = None) -> np.ndarray:
        """Indices of up to `count` training views, most shared leaves first; `exclude` is a
        boolean mask of views that may not be returned (leave-one-out training of the filler)."""
        leaves = self.forest_.apply(features.reshape(1, -1))[0]
        votes = (self.train_leaves_ == leaves).sum(axis=1).astype(np.float64)
        if exclude is not None:
            votes[exclude] = -1.0
        order = np.argsort(-votes, kind="stable")
        order = order[votes[order] > 0]
        return order[:count]
