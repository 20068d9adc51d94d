"""The trained trees of shape completion as plain arrays, so a model file carries no code.

scikit-learn grows the trees; what prediction needs of them is copied out into numeric
arrays (`arrays()`), which `from_arrays` checks before prediction walks them: a child
index past the end, or one that points back up the tree, would read outside the array or
never end. Prediction is numpy's, so a query imports no scikit-learn (1.2 CPU-s): the
retrieval forest is walked one query row at a time; the filler's boosted trees are
evaluated all at once from tables of their leaves (`BoosterArrays`, after QuickScorer).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy.special import expit

from homemodel.core.errors import InputError

if TYPE_CHECKING:
    from sklearn.ensemble import HistGradientBoostingClassifier, RandomForestRegressor

BITSET_WORDS = 8  # scikit-learn's categorical bitsets: 8 x 32 bits, categories 0..255
# scikit-learn's record of a boosted tree's node (PREDICTOR_RECORD_DTYPE), as model files hold it.
NODE_DTYPE = np.dtype([
    ("value", "<f8"), ("count", "<u4"), ("feature_idx", "<i8"), ("num_threshold", "<f8"),
    ("missing_go_to_left", "u1"), ("left", "<u4"), ("right", "<u4"), ("gain", "<f8"), ("depth", "<u4"),
    ("is_leaf", "u1"), ("bin_threshold", "u1"), ("is_categorical", "u1"), ("bitset_idx", "<u4"),
])
MAX_LEAVES = 64  # a tree's leaves are the bits of one uint64
# Rows evaluated together: their (rows, trees) masks stay in the core's cache (about 200 kB).
# On a query's 36,000 rows, 512 took 0.06 CPU-s where whole blocks of 8,192 took 0.09.
ROWS_PER_BLOCK = 512


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
    the front (its OrdinalEncoder in a ColumnTransformer); `encoded` does the same.

    Prediction follows QuickScorer (Lucchese et al., SIGIR 2015): a tree's leaves, left to
    right, are the bits of a mask; a split a row fails (it goes right) clears the bits of its
    left subtree's leaves, and the row's leaf is the lowest bit left once every failed split
    is applied. Per feature, its splits sorted by threshold give a table of the masks a value
    leaves (row r: the AND of the r lowest thresholds' masks), so a row's leaves in all trees
    are one table lookup per feature and an AND: a few numpy passes instead of walking nodes."""

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
        self._tables = _LeafTables(self)

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
            nodes=np.concatenate([tree.nodes for tree in trees]).astype(NODE_DTYPE),
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
        if nodes.dtype != NODE_DTYPE:
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
                or category_offsets[-1] != len(categories)
                or np.any(np.diff(category_offsets) > BITSET_WORDS * 32)):
            raise InputError(f"{name}: the filler's categorical columns do not fit its {n_features} features")
        for a, b, c, d in zip(offsets[:-1], offsets[1:], bitset_offsets[:-1], bitset_offsets[1:]):
            tree = nodes[a:b]
            is_leaf = tree["is_leaf"].astype(bool)
            _check_children(tree["left"].astype(np.int64), tree["right"].astype(np.int64), is_leaf, name)
            _check_features(tree["feature_idx"].astype(np.int64), is_leaf, n_features, name)
            if np.count_nonzero(is_leaf) > MAX_LEAVES:
                raise InputError(f"{name}: a filler tree has more than {MAX_LEAVES} leaves")
            categorical = ~is_leaf & tree["is_categorical"].astype(bool)
            if np.any(tree["bitset_idx"][categorical] >= d - c) or (np.any(categorical) and len(known) == 0):
                raise InputError(f"{name}: a filler tree's category bitset index lies outside its bitsets")
            # The encoded rows hold the categorical columns first: their splits must be categorical.
            if np.any(categorical != (~is_leaf & (tree["feature_idx"] < len(columns)))):
                raise InputError(f"{name}: a filler tree splits a categorical column by threshold, or the reverse")
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
        """P(classes[1]) per row, equal to scikit-learn's `predict_proba` (the trees' values
        summed in the same order)."""
        rows = np.asarray(features, dtype=np.float64)
        if rows.ndim != 2 or rows.shape[1] != self.n_features:
            raise ValueError(f"{rows.shape=} but expected (N, {self.n_features})")
        return expit(self._tables.raw_scores(self.encoded(rows), self.baseline))


def _leaf_ranges(tree: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per node of one tree, the range [low, high) of its subtree's leaves numbered left to
    right, and the leaves' node indices in that order."""
    low, high = np.zeros(len(tree), dtype=np.int64), np.zeros(len(tree), dtype=np.int64)
    leaves: list[int] = []
    stack = [(0, False)]
    while stack:  # depth first, left before right; a node is closed after its children
        node, closing = stack.pop()
        if closing:
            low[node], high[node] = low[tree["left"][node]], high[tree["right"][node]]
        elif tree["is_leaf"][node]:
            low[node], high[node] = len(leaves), len(leaves) + 1
            leaves.append(node)
        else:
            stack += [(node, True), (int(tree["right"][node]), False), (int(tree["left"][node]), False)]
    return low, high, np.asarray(leaves, dtype=np.int64)


class _LeafTables:
    """The boosted trees as QuickScorer's tables (see `BoosterArrays`), built from checked arrays."""

    def __init__(self, booster: BoosterArrays) -> None:
        nodes, offsets = booster.nodes, booster.offsets
        n_trees = len(offsets) - 1
        most_leaves = max(int(np.count_nonzero(nodes["is_leaf"][a:b])) for a, b in zip(offsets[:-1], offsets[1:]))
        # Half the bytes to gather when every tree has at most 32 leaves (the filler has 31).
        self.dtype = np.dtype(np.uint32 if most_leaves <= 32 else np.uint64)
        all_leaves = self.dtype.type(2 ** (8 * self.dtype.itemsize) - 1)
        split_tree, split_node, split_keeps = [], [], []  # per split: its tree, its node, the mask of going right
        self.leaf_values = np.zeros((n_trees, MAX_LEAVES))
        for t, (start, stop) in enumerate(zip(offsets[:-1], offsets[1:])):
            tree = nodes[start:stop]
            low, high, leaves = _leaf_ranges(tree)
            self.leaf_values[t, : len(leaves)] = tree["value"][leaves]
            for node in np.nonzero(tree["is_leaf"] == 0)[0]:
                left = tree["left"][node]
                cleared = (2 ** int(high[left]) - 1) ^ (2 ** int(low[left]) - 1)  # the left subtree's bits
                split_tree.append(t)
                split_node.append(start + node)
                split_keeps.append(all_leaves ^ self.dtype.type(cleared))
        split_tree, split_node = np.asarray(split_tree, dtype=np.int64), np.asarray(split_node, dtype=np.int64)
        split_keeps = np.asarray(split_keeps, dtype=self.dtype)
        n_categorical = len(booster.categorical_columns)
        self.n_trees, self.all_leaves = n_trees, all_leaves
        self.columns: list[tuple[int, np.ndarray | None, np.ndarray]] = []  # (column, thresholds or None, table)
        for column in np.unique(nodes["feature_idx"][split_node]) if len(split_node) else []:
            on_column = nodes["feature_idx"][split_node] == column
            trees, at, keeps = split_tree[on_column], split_node[on_column], split_keeps[on_column]
            goes_right_if_missing = nodes["missing_go_to_left"][at] == 0
            if column < n_categorical:  # rows: each category's code, then missing
                count = int(np.diff(booster.category_offsets)[column])
                known_row = booster.known_cat_bitsets[booster.f_idx_map[column]] if len(booster.known_cat_bitsets) else None
                bitsets = booster.left_cat_bitsets[booster.bitset_offsets[trees] + nodes["bitset_idx"][at]]
                right = np.zeros((count + 1, len(at)), dtype=bool)
                for code in range(count):
                    word, bit = divmod(code, 32)
                    is_known = known_row is not None and (known_row[word] >> np.uint32(bit)) & 1
                    in_left = (bitsets[:, word] >> np.uint32(bit)) & 1 == 1
                    right[code] = ~in_left if is_known else goes_right_if_missing
                right[count] = goes_right_if_missing
                table = np.full((count + 1, n_trees), all_leaves)
                for row in range(count + 1):
                    np.bitwise_and.at(table[row], trees[right[row]], keeps[right[row]])
                self.columns.append((int(column), None, table))
                continue
            # Rows: r = how many of the sorted thresholds a value passes (x > threshold: right), then missing.
            order = np.argsort(nodes["num_threshold"][at], kind="stable")
            thresholds = nodes["num_threshold"][at][order]
            # Row r + 1 = row r with the r-th split's tree masked: a running AND down the rows.
            table = np.full((len(at) + 2, n_trees), all_leaves)
            table[np.arange(1, len(at) + 1), trees[order]] = keeps[order]
            np.bitwise_and.accumulate(table[:-1], axis=0, out=table[:-1])
            np.bitwise_and.at(table[-1], trees[goes_right_if_missing], keeps[goes_right_if_missing])
            self.columns.append((int(column), thresholds, table))

    def raw_scores(self, rows: np.ndarray, baseline: float) -> np.ndarray:
        """Per encoded row, `baseline` plus the values of the leaves it reaches, summed tree by tree
        in order (as scikit-learn sums them, so the result is equal to the bit)."""
        common = np.full(self.n_trees, self.all_leaves)  # what columns with one value for all rows leave
        gathers = []  # (table, row of the table per row) of the other columns
        for column, thresholds, table in self.columns:
            values = rows[:, column]
            missing = np.isnan(values)
            if thresholds is None:
                index = np.where(missing, len(table) - 1, np.nan_to_num(values)).astype(np.int64)
            else:
                index = np.where(missing, len(table) - 1, np.searchsorted(thresholds, values, side="left"))
            if len(index) and np.all(index == index[0]):  # a query's match and fit distances, its class
                common &= table[index[0]]
            else:
                gathers.append((table, index))
        raw = np.empty(len(rows))
        block = min(ROWS_PER_BLOCK, len(rows))
        mask = np.empty((block, self.n_trees), dtype=self.dtype)
        gathered = np.empty_like(mask)
        terms = np.empty((self.n_trees + 1, block))  # the baseline, then each tree's leaf value
        leaf_base = MAX_LEAVES * np.arange(self.n_trees)[:, None]
        for start in range(0, len(rows), ROWS_PER_BLOCK):
            stop = min(start + ROWS_PER_BLOCK, len(rows))
            m, g, t = mask[: stop - start], gathered[: stop - start], terms[:, : stop - start]
            m[:] = common
            for table, index in gathers:
                np.take(table, index[start:stop], axis=0, out=g)
                m &= g
            lowest = m & (~m + self.dtype.type(1))  # the lowest set bit: the row's leaf
            t[0] = baseline
            np.take(self.leaf_values.ravel(), _bit_index(lowest).T + leaf_base, out=t[1:])
            np.add.reduce(t, axis=0, out=raw[start:stop])  # along the outer axis: tree after tree
        return raw


def _bit_index(powers: np.ndarray) -> np.ndarray:
    """The exponent of each power of two (every row reaches a leaf, so none is zero)."""
    if powers.dtype == np.uint32:  # exact in float32: its exponent field, unbiased
        return (powers.astype(np.float32).view(np.int32) >> 23) - 127
    _, exponent = np.frexp(powers.astype(np.float64))
    return exponent.astype(np.int64) - 1
