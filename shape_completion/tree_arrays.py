"""The trained trees of shape completion as plain arrays, so a model file carries no code.

scikit-learn grows the trees; what prediction needs of them is copied out into numeric
arrays (`arrays()`), which `from_arrays` checks before any compiled code walks them: a child
index past the end, or one that points back up the tree, would read outside the array or
never end. The retrieval forest is walked in numpy (one query row at a time); the filler's
boosted trees by scikit-learn's compiled `TreePredictor`, given the checked arrays.
"""

from __future__ import annotations

import numpy as np
from scipy.special import expit
from sklearn.ensemble import HistGradientBoostingClassifier, RandomForestRegressor
from sklearn.ensemble._hist_gradient_boosting.common import PREDICTOR_RECORD_DTYPE
from sklearn.ensemble._hist_gradient_boosting.predictor import TreePredictor
from sklearn.utils._openmp_helpers import _openmp_effective_n_threads

from homemodel.core.errors import InputError

BITSET_WORDS = 8  # scikit-learn's categorical bitsets: 8 x 32 bits, categories 0..255


def _check_children(left: np.ndarray, right: np.ndarray, is_leaf: np.ndarray, name: str) -> None:
    """Every split's children lie after it and inside the tree: walks stay in bounds and end."""
    count = len(left)
    if count == 0:
        raise InputError(f"{name}: a tree without nodes")
    splits = np.nonzero(~is_leaf)[0]
    for child in (left[splits], right[splits]):
        if np.any(child <= splits) or np.any(child >= count):
            raise InputError(f"{name}: a tree's child index lies outside it or before its parent")


def _check_features(feature: np.ndarray, is_leaf: np.ndarray, n_features: int, name: str) -> None:
    used = feature[~is_leaf]
    if np.any(used < 0) or np.any(used >= n_features):
        raise InputError(f"{name}: a tree splits on a feature outside 0..{n_features - 1}")


class ForestArrays:
    """A regression forest's split structure: which leaf each tree sends a row to (`apply`)."""

    def __init__(self, *, n_features: int, offsets: np.ndarray, left: np.ndarray, right: np.ndarray,
                 feature: np.ndarray, threshold: np.ndarray, missing_go_to_left: np.ndarray) -> None:
        self.n_features = n_features
        self.offsets = offsets  # tree t holds nodes offsets[t]:offsets[t + 1]
        self.left, self.right = left, right
        self.feature, self.threshold, self.missing_go_to_left = feature, threshold, missing_go_to_left

    @classmethod
    def from_sklearn(cls, forest: RandomForestRegressor) -> ForestArrays:
        trees = [estimator.tree_ for estimator in forest.estimators_]
        return cls(
            n_features=int(forest.n_features_in_),
            offsets=np.cumsum([0] + [tree.node_count for tree in trees]).astype(np.int64),
            left=np.concatenate([tree.children_left for tree in trees]).astype(np.int64),
            right=np.concatenate([tree.children_right for tree in trees]).astype(np.int64),
            feature=np.concatenate([tree.feature for tree in trees]).astype(np.int64),
            threshold=np.concatenate([tree.threshold for tree in trees]).astype(np.float64),
            missing_go_to_left=np.concatenate([tree.missing_go_to_left for tree in trees]).astype(np.uint8),
        )

    def arrays(self) -> dict[str, np.ndarray]:
        return {
            "n_features": np.int64(self.n_features), "offsets": self.offsets, "left": self.left, "right": self.right,
            "feature": self.feature, "threshold": self.threshold, "missing_go_to_left": self.missing_go_to_left,
        }

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], name: str) -> ForestArrays:
        forest = cls(n_features=int(arrays["n_features"]), **{key: arrays[key] for key in (
            "offsets", "left", "right", "feature", "threshold", "missing_go_to_left")})
        offsets = forest.offsets
        if offsets.ndim != 1 or len(offsets) < 2 or offsets[0] != 0 or np.any(np.diff(offsets) < 1):
            raise InputError(f"{name}: the forest's tree offsets are not increasing from 0")
        if any(len(a) != offsets[-1] for a in (forest.left, forest.right, forest.feature, forest.threshold,
                                                forest.missing_go_to_left)):
            raise InputError(f"{name}: the forest's node arrays differ in length")
        for start, stop in zip(offsets[:-1], offsets[1:]):
            is_leaf = forest.left[start:stop] == -1
            _check_children(forest.left[start:stop], forest.right[start:stop], is_leaf, name)
            _check_features(forest.feature[start:stop], is_leaf, forest.n_features, name)
        return forest

    def apply(self, features: np.ndarray) -> np.ndarray:
        """(rows, trees) leaf index of each row in each tree, as scikit-learn's `apply` numbers them."""
        rows = np.asarray(features, dtype=np.float32)  # scikit-learn's trees split float32 values
        leaves = np.empty((len(rows), len(self.offsets) - 1), dtype=np.int64)
        for r, row in enumerate(rows):
            for t, start in enumerate(self.offsets[:-1]):
                node = 0
                while self.left[start + node] != -1:
                    i = start + node
                    value = row[self.feature[i]]
                    go_left = self.missing_go_to_left[i] if np.isnan(value) else value <= self.threshold[i]
                    node = self.left[i] if go_left else self.right[i]
                leaves[r, t] = node
        return leaves


class BoosterArrays:
    """A binary HistGradientBoostingClassifier's trees: P(class 1) per row (`probability`).

    With categorical features scikit-learn first encodes each one's values as their index
    among the sorted categories seen in training (unknown -> NaN) and moves those columns to
    the front (its OrdinalEncoder in a ColumnTransformer); `encoded` does the same."""

    def __init__(self, *, n_features: int, baseline: float, classes: np.ndarray, offsets: np.ndarray,
                 nodes: np.ndarray, bitset_offsets: np.ndarray, left_cat_bitsets: np.ndarray,
                 known_cat_bitsets: np.ndarray, f_idx_map: np.ndarray, categorical_columns: np.ndarray,
                 category_offsets: np.ndarray, categories: np.ndarray) -> None:
        self.n_features, self.baseline, self.classes = n_features, baseline, classes
        self.categorical_columns, self.category_offsets, self.categories = (
            categorical_columns, category_offsets, categories)
        self.offsets, self.nodes = offsets, nodes  # tree t holds nodes offsets[t]:offsets[t + 1]
        self.bitset_offsets, self.left_cat_bitsets = bitset_offsets, left_cat_bitsets
        self.known_cat_bitsets, self.f_idx_map = known_cat_bitsets, f_idx_map
        self._predictors = [
            TreePredictor(nodes[a:b], None, left_cat_bitsets[c:d])
            for a, b, c, d in zip(offsets[:-1], offsets[1:], bitset_offsets[:-1], bitset_offsets[1:])
        ]

    @classmethod
    def from_sklearn(cls, booster: HistGradientBoostingClassifier) -> BoosterArrays:
        if booster.n_trees_per_iteration_ != 1:
            raise ValueError(f"{booster.n_trees_per_iteration_=} but the filler is a binary classifier")
        trees = [iteration[0] for iteration in booster._predictors]
        known, f_idx_map = booster._bin_mapper.make_known_categories_bitsets()
        if booster._preprocessor is None:
            columns, categories = np.zeros(0, dtype=np.int64), []
        else:
            columns = np.nonzero(booster.is_categorical_)[0].astype(np.int64)
            categories = booster._preprocessor.named_transformers_["encoder"].categories_
        return cls(
            n_features=int(booster.n_features_in_),
            baseline=float(np.ravel(booster._baseline_prediction)[0]),
            classes=np.asarray(booster.classes_),
            offsets=np.cumsum([0] + [len(tree.nodes) for tree in trees]).astype(np.int64),
            nodes=np.concatenate([tree.nodes for tree in trees]),
            bitset_offsets=np.cumsum([0] + [len(tree.raw_left_cat_bitsets) for tree in trees]).astype(np.int64),
            left_cat_bitsets=np.concatenate([tree.raw_left_cat_bitsets for tree in trees]).reshape(-1, BITSET_WORDS),
            known_cat_bitsets=np.asarray(known, dtype=np.uint32).reshape(-1, BITSET_WORDS),
            f_idx_map=np.asarray(f_idx_map, dtype=np.uint32),
            categorical_columns=columns,
            category_offsets=np.cumsum([0] + [len(c) for c in categories]).astype(np.int64),
            categories=np.concatenate([np.zeros(0), *categories]).astype(np.float64),
        )

    def arrays(self) -> dict[str, np.ndarray]:
        return {
            "n_features": np.int64(self.n_features), "baseline": np.float64(self.baseline), "classes": self.classes,
            "offsets": self.offsets, "nodes": self.nodes, "bitset_offsets": self.bitset_offsets,
            "left_cat_bitsets": self.left_cat_bitsets, "known_cat_bitsets": self.known_cat_bitsets,
            "f_idx_map": self.f_idx_map, "categorical_columns": self.categorical_columns,
            "category_offsets": self.category_offsets, "categories": self.categories,
        }

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], name: str) -> BoosterArrays:
        nodes, offsets, bitset_offsets = arrays["nodes"], arrays["offsets"], arrays["bitset_offsets"]
        n_features = int(arrays["n_features"])
        if nodes.dtype != PREDICTOR_RECORD_DTYPE:
            raise InputError(f"{name}: the filler's tree nodes are not in scikit-learn's record layout")
        for label, bounds, total in (("tree", offsets, len(nodes)), ("bitset", bitset_offsets, None)):
            if bounds.ndim != 1 or len(bounds) != len(offsets) or bounds[0] != 0 or np.any(np.diff(bounds) < 0):
                raise InputError(f"{name}: the filler's {label} offsets are not increasing from 0")
        if offsets[-1] != len(nodes) or np.any(np.diff(offsets) < 1):
            raise InputError(f"{name}: the filler's tree offsets do not cover its nodes")
        bitsets, known, f_idx_map = arrays["left_cat_bitsets"], arrays["known_cat_bitsets"], arrays["f_idx_map"]
        for label, array in (("left", bitsets), ("known", known)):
            if array.dtype != np.uint32 or array.ndim != 2 or array.shape[1] != BITSET_WORDS:
                raise InputError(f"{name}: the filler's {label} category bitsets are not (n, 8) uint32")
        if bitset_offsets[-1] != len(bitsets):
            raise InputError(f"{name}: the filler's bitset offsets do not cover its bitsets")
        if f_idx_map.dtype != np.uint32 or f_idx_map.shape != (n_features,) or (
                len(known) and np.any(f_idx_map >= len(known))):
            raise InputError(f"{name}: the filler's category map does not fit its {n_features} features")
        columns, category_offsets, categories = (
            arrays["categorical_columns"], arrays["category_offsets"], arrays["categories"])
        if (columns.ndim != 1 or np.any(columns < 0) or np.any(columns >= n_features)
                or len(np.unique(columns)) != len(columns) or category_offsets.shape != (len(columns) + 1,)
                or category_offsets[0] != 0 or np.any(np.diff(category_offsets) < 0)
                or category_offsets[-1] != len(categories)):
            raise InputError(f"{name}: the filler's categorical columns do not fit its {n_features} features")
        for a, b, c, d in zip(offsets[:-1], offsets[1:], bitset_offsets[:-1], bitset_offsets[1:]):
            tree = nodes[a:b]
            is_leaf = tree["is_leaf"].astype(bool)
            _check_children(tree["left"].astype(np.int64), tree["right"].astype(np.int64), is_leaf, name)
            _check_features(tree["feature_idx"].astype(np.int64), is_leaf, n_features, name)
            categorical = ~is_leaf & tree["is_categorical"].astype(bool)
            if np.any(tree["bitset_idx"][categorical] >= d - c) or (np.any(categorical) and len(known) == 0):
                raise InputError(f"{name}: a filler tree's category bitset index lies outside its bitsets")
        return cls(n_features=n_features, baseline=float(arrays["baseline"]), classes=arrays["classes"],
                   offsets=offsets, nodes=nodes, bitset_offsets=bitset_offsets, left_cat_bitsets=bitsets,
                   known_cat_bitsets=known, f_idx_map=f_idx_map, categorical_columns=columns,
                   category_offsets=category_offsets, categories=categories)

    def encoded(self, rows: np.ndarray) -> np.ndarray:
        """`rows` as scikit-learn's trees see them: categorical columns first, as category indices."""
        if len(self.categorical_columns) == 0:
            return rows
        numeric = np.ones(self.n_features, dtype=bool)
        numeric[self.categorical_columns] = False
        codes = []
        for column, start, stop in zip(self.categorical_columns, self.category_offsets[:-1], self.category_offsets[1:]):
            known = self.categories[start:stop]
            values = rows[:, column]
            if len(known) == 0:
                codes.append(np.full(len(values), np.nan))
                continue
            index = np.minimum(np.searchsorted(known, values), len(known) - 1)
            found = known[index] == values
            codes.append(np.where(found, index, np.nan))
        return np.column_stack([*codes, rows[:, numeric]]).astype(np.float64)

    def probability(self, features: np.ndarray) -> np.ndarray:
        """P(classes[1]) per row, computed as scikit-learn's `predict_proba` does (same sums, same order)."""
        rows = np.asarray(features, dtype=np.float64)
        if rows.ndim != 2 or rows.shape[1] != self.n_features:
            raise ValueError(f"{rows.shape=} but expected (N, {self.n_features})")
        rows = self.encoded(rows)
        raw = np.zeros(len(rows), dtype=np.float64)
        raw += self.baseline
        threads = _openmp_effective_n_threads()
        for predictor in self._predictors:
            raw += predictor.predict(rows, self.known_cat_bitsets, self.f_idx_map, threads)
        return expit(raw)
