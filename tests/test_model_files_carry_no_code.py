"""Completion model files are arrays, never code: a pickle (or an .npz hiding one) is refused
before it is read, with a payload that would create a file if it ran; the trees' arrays
predict exactly as scikit-learn's estimators and are checked before compiled code walks them."""

from __future__ import annotations

import io
import os
import pickle
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from cli_promise import REPO, assert_refused, run_cli

from homemodel.core.errors import InputError
from homemodel.core.limits import MODEL_BYTES
from homemodel.core.safe_npz import read_npz, write_npz
from homemodel.geometry.camera import Camera, save_camera
from homemodel.geometry.depth_io import write_depth
from shape_completion.model_io import load_model
from shape_completion.tree_arrays import NODE_DTYPE, BoosterArrays, ForestArrays


class CreatesFile:
    """Unpickling this calls os.mkdir(marker): what a hostile model file would do."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (os.mkdir, (str(self.marker),))


def test_the_payload_runs_when_unpickled(tmp_path: Path) -> None:
    """The control: the payload the tests below feed to homemodel does run code under pickle."""
    marker = tmp_path / "ran"
    pickle.loads(pickle.dumps({"completer": CreatesFile(marker)}))
    assert marker.is_dir()


@pytest.mark.parametrize("name", ["model.npz", "model.joblib", "model.pkl"])
def test_a_pickled_model_is_refused_unread(tmp_path: Path, name: str) -> None:
    marker = tmp_path / "ran"
    (tmp_path / name).write_bytes(pickle.dumps({"format": "homemodel-shape-completion", "x": CreatesFile(marker)}))
    with pytest.raises(InputError, match=rf"{name}: not an \.npz array file"):
        load_model(tmp_path / name)
    assert not marker.exists()


def test_an_npz_hiding_a_pickle_is_refused(tmp_path: Path) -> None:
    """An .npz member may be an object array, which numpy stores as a pickle."""
    marker = tmp_path / "ran"
    evil = tmp_path / "evil.npz"
    hidden = np.empty(1, dtype=object)
    hidden[0] = CreatesFile(marker)
    with zipfile.ZipFile(evil, "w") as archive:
        buffer = io.BytesIO()
        np.save(buffer, hidden, allow_pickle=True)
        archive.writestr("meta.npy", buffer.getvalue())
    with pytest.raises(InputError, match="evil.npz: meta.npy holds Python objects"):
        load_model(evil)
    assert not marker.exists()


def test_completion_run_refuses_a_pickle_in_one_line(tmp_path: Path) -> None:
    marker = tmp_path / "ran"
    model = tmp_path / "shared_by_a_stranger.npz"
    model.write_bytes(pickle.dumps(CreatesFile(marker)))
    camera = Camera(width=32, height=24, fx=30.0, fy=30.0, cx=15.5, cy=11.5, depth_scale_m=0.001)
    save_camera(camera, tmp_path / "camera.yaml")
    depth = np.full((24, 32), np.nan)
    depth[8:16, 10:20] = 0.5
    write_depth(tmp_path / "depth.png", depth, depth_scale_m=0.001)
    run = run_cli("completion", "run", model, tmp_path / "depth.png", "--camera", tmp_path / "camera.yaml",
                  "--out", tmp_path / "out")
    assert_refused(run, names=model, out=tmp_path / "out")
    assert not marker.exists()


def test_npz_headers_that_lie_are_refused_before_allocating(tmp_path: Path) -> None:
    """A member whose header claims 10^12 floats but holds none must not allocate 8 TB."""
    liar = tmp_path / "liar.npz"
    with zipfile.ZipFile(liar, "w") as archive:
        header = io.BytesIO()
        np.lib.format.write_array_header_1_0(header, {"descr": "<f8", "fortran_order": False, "shape": (10**12,)})
        archive.writestr("meta.npy", header.getvalue())
    with pytest.raises(InputError, match="liar.npz: not a readable .npz"):
        read_npz(liar, MODEL_BYTES)
    write_npz(tmp_path / "big.npz", {"a": np.zeros(1000)})
    with pytest.raises(InputError, match="over the limit of 100 .*HOMEMODEL_MAX_MODEL_BYTES"):
        read_npz(tmp_path / "big.npz", MODEL_BYTES.__class__(MODEL_BYTES.name, 100, MODEL_BYTES.what))


def test_reading_under_a_4_gib_limit_does_not_allocate_the_bound(tmp_path: Path) -> None:
    """`read_bounded` with an 8 GiB bound on a small file, in a process limited to 4 GiB."""
    small = tmp_path / "small.bin"
    small.write_bytes(b"x" * 1000)
    code = (
        "import resource, sys; resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30));"
        "from homemodel.core.input_files import read_bounded;"
        f"assert len(read_bounded({str(small)!r}, 8 << 30)) == 1000"
    )
    done = subprocess.run([sys.executable, "-c", code], env={**os.environ, "PYTHONPATH": str(REPO)},
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr


@pytest.fixture(scope="module")
def fitted():
    """A small booster with a categorical column (as the filler's), a forest, and queries."""
    from sklearn.ensemble import HistGradientBoostingClassifier, RandomForestRegressor  # 1-2 CPU-s: not at collection
    from threadpoolctl import threadpool_limits

    rng = np.random.default_rng(0)
    features = rng.normal(size=(3000, 6))
    features[:, 2] = rng.integers(0, 3, len(features))  # categorical, as the filler's class column
    features[rng.random(features.shape) < 0.02] = np.nan
    features[:, 2] = np.nan_to_num(features[:, 2])
    labels = features[:, 0] + features[:, 2] + 0.5 * rng.normal(size=len(features)) > 1
    with threadpool_limits(limits=1, user_api="openmp"):  # OpenMP spin-waits on a busy machine
        booster = HistGradientBoostingClassifier(max_iter=20, max_leaf_nodes=15, categorical_features=[2],
                                                 random_state=0).fit(features, labels)
    forest = RandomForestRegressor(n_estimators=5, min_samples_leaf=2, random_state=0).fit(
        features[:500], rng.random((500, 3)))
    queries = rng.normal(size=(2000, 6))
    queries[:, 2] = rng.integers(0, 4, len(queries))  # category 3 was never seen in training
    queries[rng.random(queries.shape) < 0.02] = np.nan
    return booster, forest, queries


def test_tree_arrays_predict_exactly_as_scikit_learn(fitted) -> None:
    from sklearn.ensemble._hist_gradient_boosting.common import PREDICTOR_RECORD_DTYPE

    assert NODE_DTYPE == PREDICTOR_RECORD_DTYPE  # model files hold scikit-learn's node records
    booster, forest, queries = fitted
    assert np.array_equal(BoosterArrays.from_sklearn(booster).probability(queries), booster.predict_proba(queries)[:, 1])
    assert np.array_equal(ForestArrays.from_sklearn(forest).apply(queries[:40]), forest.apply(queries[:40]))
    # and through their arrays, as a model file holds them
    booster_arrays = BoosterArrays.from_arrays(BoosterArrays.from_sklearn(booster).arrays(), "m.npz")
    assert np.array_equal(booster_arrays.probability(queries), booster.predict_proba(queries)[:, 1])
    forest_arrays = ForestArrays.from_arrays(ForestArrays.from_sklearn(forest).arrays(), "m.npz")
    assert np.array_equal(forest_arrays.apply(queries[:40]), forest.apply(queries[:40]))


def test_trees_of_more_than_32_leaves_predict_exactly_as_scikit_learn(fitted) -> None:
    """Their leaves do not fit the 32-bit masks of the filler's 31-leaf trees: 64-bit ones are used."""
    from sklearn.ensemble import HistGradientBoostingClassifier
    from threadpoolctl import threadpool_limits

    _, _, queries = fitted
    rng = np.random.default_rng(1)
    features = rng.normal(size=(4000, 6))
    features[:, 2] = rng.integers(0, 3, len(features))
    labels = np.sin(3 * features[:, 0]) + features[:, 1] * features[:, 3] + rng.normal(size=len(features)) > 0
    with threadpool_limits(limits=1, user_api="openmp"):
        booster = HistGradientBoostingClassifier(max_iter=8, max_leaf_nodes=60, categorical_features=[2],
                                                 random_state=0).fit(features, labels)
    arrays = BoosterArrays.from_arrays(BoosterArrays.from_sklearn(booster).arrays(), "m.npz")
    assert np.count_nonzero(arrays.nodes["is_leaf"]) > 32 * len(arrays.offsets[1:])  # most trees past 32 leaves
    assert np.array_equal(arrays.probability(queries), booster.predict_proba(queries)[:, 1])


@pytest.mark.parametrize("tamper", ["child past the end", "child before its parent", "feature out of range",
                                    "bitset out of range"])
def test_tampered_trees_are_refused_before_they_are_walked(fitted, tamper: str) -> None:
    booster, forest, _ = fitted
    boosted, trees = BoosterArrays.from_sklearn(booster).arrays(), ForestArrays.from_sklearn(forest).arrays()
    nodes = boosted["nodes"].copy()
    split = int(np.nonzero(nodes["is_leaf"] == 0)[0][0])
    if tamper == "child past the end":
        nodes["left"][split] = 10**6
        trees["right"] = trees["right"].copy()
        trees["right"][0] = 10**6
    elif tamper == "child before its parent":
        nodes["right"][split] = split
        trees["left"] = trees["left"].copy()
        trees["left"][0] = 0
    elif tamper == "feature out of range":
        nodes["feature_idx"][split] = 99
        trees["feature"] = trees["feature"].copy()
        trees["feature"][0] = -5
    else:
        categorical = np.nonzero((nodes["is_categorical"] == 1) & (nodes["is_leaf"] == 0))[0]
        nodes["bitset_idx"][categorical[0]] = 10**6
    with pytest.raises(InputError, match="m.npz: "):
        BoosterArrays.from_arrays(boosted | {"nodes": nodes}, "m.npz")
    if tamper != "bitset out of range":
        with pytest.raises(InputError, match="m.npz: "):
            ForestArrays.from_arrays(trees, "m.npz")
