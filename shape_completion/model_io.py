"""Save and load a trained `ShapeCompleter` as plain arrays (`.npz`), with its format version
and fingerprint.

Model files are shared between people, so one must not be able to carry code: the file holds
numeric arrays and one JSON document, read with `homemodel.core.safe_npz` (no pickle), and the
trees' arrays are checked before prediction walks them (`shape_completion.tree_arrays`).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import trimesh

from homemodel.core.errors import InputError
from homemodel.core.limits import MODEL_BYTES
from homemodel.core.safe_npz import read_npz, write_npz
from shape_completion.features import PATCH, PixelTests
from shape_completion.filling import VoxelFiller
from shape_completion.library import training_fingerprint
from shape_completion.matching import ViewForest
from shape_completion.pipeline import LibraryShape, ShapeCompleter
from shape_completion.shape_codes import ShapeBasis
from shape_completion.symmetry import Plane, RevolutionAxis
from shape_completion.tree_arrays import BoosterArrays, ForestArrays

FORMAT = "homemodel-shape-completion"
FORMAT_VERSION = 5  # 5: shapes' arrays concatenated, stored uncompressed; 4: one member per array; 3 and before were pickles


def _text(document: dict) -> np.ndarray:
    return np.frombuffer(json.dumps(document).encode("utf-8"), dtype=np.uint8)


def _counts(arrays: list[np.ndarray]) -> np.ndarray:
    return np.array([len(a) for a in arrays], dtype=np.int64)


def _model_arrays(completer: ShapeCompleter) -> dict[str, np.ndarray]:
    shapes = completer.shapes_
    meshes = [shape.mesh for shape in shapes]
    planes = [shape.planes for shape in shapes]
    # Every shape's arrays concatenated, with their counts: a few large members read much faster
    # than seven small ones per library mesh.
    arrays: dict[str, np.ndarray] = {
        "shapes.vertex_counts": _counts([m.vertices for m in meshes]),
        "shapes.face_counts": _counts([m.faces for m in meshes]),
        "shapes.vertices": np.concatenate([np.asarray(m.vertices, dtype=np.float64) for m in meshes]),
        "shapes.faces": np.concatenate([np.asarray(m.faces, dtype=np.int64) for m in meshes]),
        "shapes.sample_counts": _counts([shape.samples for shape in shapes]),
        "shapes.samples": np.concatenate([shape.samples for shape in shapes]),
        "shapes.normals": np.concatenate([shape.normals for shape in shapes]),
        "shapes.plane_counts": _counts(planes),
        "shapes.plane_normals": np.array([p.normal for ps in planes for p in ps], dtype=np.float64).reshape(-1, 3),
        "shapes.plane_offsets": np.array([p.offset for ps in planes for p in ps], dtype=np.float64),
        "shapes.axes": np.array(
            [np.zeros((2, 3)) if s.axis is None else np.stack([s.axis.point, s.axis.direction]) for s in shapes]
        ).reshape(-1, 2, 3),
    }
    shape_meta = [{"class_name": s.class_name, "name": s.name, "has_axis": s.axis is not None} for s in shapes]
    forest, filler = completer.forest_, completer.filler_
    meta = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "fingerprint": completer.fingerprint_,
        "library_fingerprint": completer.library_fingerprint_,
        "params": completer.get_params(),
        "class_names": list(completer.class_names_),
        "training_seconds": completer.training_seconds_,
        "shapes": shape_meta,
        "forest_params": forest.get_params(),
        "filler_params": filler.get_params(),
        "filler_level": filler.level_,
        "basis_params": {"n_components": completer.shape_basis_.n_components,
                         "random_state": completer.shape_basis_.random_state},
    }
    arrays |= {
        "meta": _text(meta),
        "tests.silhouette": completer.tests_.silhouette,
        "tests.depth_pairs": completer.tests_.depth_pairs,
        "views.shape": completer.view_shape_,
        "views.poses": completer.view_poses_,
        "views.cloud_sizes": np.array([len(c) for c in completer.view_clouds_], dtype=np.int64),
        "views.clouds": np.concatenate(completer.view_clouds_),
        "basis.components": completer.shape_basis_.components_,
        "forest.train_leaves": forest.train_leaves_,
    }
    arrays |= {f"forest.{k}": v for k, v in forest.trees_.arrays().items()}
    arrays |= {f"filler.{k}": v for k, v in filler.trees_.arrays().items()}
    return arrays


def save_model(completer: ShapeCompleter, path: Path, *, force: bool = True) -> None:
    """Write the fitted completer atomically as an `.npz` of arrays; without `force` never
    over an existing file (checked in the same step that puts the file in place)."""
    write_npz(Path(path), _model_arrays(completer), overwrite=force, compressed=False)


def _group(arrays: dict[str, np.ndarray], prefix: str) -> dict[str, np.ndarray]:
    return {k[len(prefix):]: v for k, v in arrays.items() if k.startswith(prefix)}


def _check_shapes(arrays: dict[str, np.ndarray]) -> None:
    """Each array has the shape and kind its use needs (a later IndexError would be a traceback)."""
    for key, array in arrays.items():
        field = key.rsplit(".", 1)[-1]
        width = {"vertices": 3, "faces": 3, "samples": 3, "normals": 3, "plane_normals": 3, "clouds": 3,
                 "depth_pairs": 2}.get(field)
        if width is not None and (array.ndim != 2 or array.shape[1] != width):
            raise ValueError(f"{key} has shape {array.shape}, not (N, {width})")
        if array.dtype.kind not in "biuf" and key != "filler.nodes":
            raise ValueError(f"{key} is not numeric")
    poses = arrays["views.poses"]
    if poses.ndim != 3 or poses.shape[1:] != (4, 4):
        raise ValueError(f"views.poses has shape {poses.shape}, not (N, 4, 4)")
    pixels = PATCH * PATCH
    for key in ("tests.silhouette", "tests.depth_pairs"):
        if arrays[key].size and (arrays[key].min() < 0 or arrays[key].max() >= pixels):
            raise ValueError(f"{key} indexes outside the {PATCH} x {PATCH} patch")


def _completer(arrays: dict[str, np.ndarray], meta: dict, name: str) -> ShapeCompleter:
    """The completer the arrays describe; KeyError, TypeError or ValueError if they do not fit."""
    _check_shapes(arrays)
    completer = ShapeCompleter(**meta["params"])
    completer.fingerprint_ = meta["fingerprint"]
    completer.library_fingerprint_ = meta["library_fingerprint"]
    completer.class_names_ = [str(c) for c in meta["class_names"]]
    completer.training_seconds_ = float(meta["training_seconds"])
    completer.tests_ = PixelTests(silhouette=arrays["tests.silhouette"], depth_pairs=arrays["tests.depth_pairs"])
    completer.shapes_ = []
    counts = {k: arrays[f"shapes.{k}_counts"] for k in ("vertex", "face", "sample", "plane")}
    ends = {k: np.cumsum(c) for k, c in counts.items()}
    for key, rows in (("vertex", "vertices"), ("face", "faces"), ("sample", "samples"), ("sample", "normals"),
                      ("plane", "plane_normals"), ("plane", "plane_offsets")):  # fmt: skip
        if np.any(counts[key] < 0) or ends[key][-1:].sum() != len(arrays[f"shapes.{rows}"]):
            raise ValueError(f"shapes.{rows} does not hold the {key} counts' rows")
    n_shapes = len(meta["shapes"])
    if any(len(c) != n_shapes for c in counts.values()) or arrays["shapes.axes"].shape != (n_shapes, 2, 3):
        raise ValueError("the shapes' arrays differ in length")
    for i, entry in enumerate(meta["shapes"]):
        part = {k: slice(ends[k][i] - counts[k][i], ends[k][i]) for k in counts}
        vertices, faces = arrays["shapes.vertices"][part["vertex"]], arrays["shapes.faces"][part["face"]]
        if len(faces) and (faces.min() < 0 or faces.max() >= len(vertices)):
            raise ValueError(f"library shape {i}: a face names a vertex it does not have")
        axis = arrays["shapes.axes"][i]
        completer.shapes_.append(LibraryShape(
            class_name=str(entry["class_name"]),
            name=str(entry["name"]),
            mesh=trimesh.Trimesh(vertices, faces, process=False),
            samples=arrays["shapes.samples"][part["sample"]],
            normals=arrays["shapes.normals"][part["sample"]],
            planes=[Plane(normal=n, offset=float(o)) for n, o in
                    zip(arrays["shapes.plane_normals"][part["plane"]], arrays["shapes.plane_offsets"][part["plane"]],
                        strict=True)],
            axis=RevolutionAxis(point=axis[0], direction=axis[1]) if entry["has_axis"] else None,
        ))
    completer.view_shape_ = arrays["views.shape"]
    completer.view_poses_ = arrays["views.poses"]
    sizes = arrays["views.cloud_sizes"]
    ends = np.cumsum(sizes)
    # Slices, not np.split: the same views of the array, without np.split's cost per piece
    # (12,000 views: 0.05 CPU-s of a query's load).
    completer.view_clouds_ = [arrays["views.clouds"][a:b] for a, b in zip(ends - sizes, ends, strict=True)]
    if np.any(completer.view_shape_ < 0) or np.any(completer.view_shape_ >= len(completer.shapes_)):
        raise ValueError("a view names a library shape the model does not have")
    if not (len(sizes) == len(completer.view_shape_) == len(completer.view_poses_)):
        raise ValueError("the views' arrays differ in length")
    basis = ShapeBasis(**meta["basis_params"])
    basis.components_ = arrays["basis.components"]
    completer.shape_basis_ = basis
    forest = ViewForest(**meta["forest_params"])
    forest.trees_ = ForestArrays.from_arrays(_group(arrays, "forest."), name)
    forest.train_leaves_ = arrays["forest.train_leaves"]
    if forest.train_leaves_.shape != (len(sizes), len(forest.trees_.offsets) - 1):
        raise ValueError("the forest's training leaves do not fit its views and trees")
    completer.forest_ = forest
    filler = VoxelFiller(**meta["filler_params"])
    filler.trees_ = BoosterArrays.from_arrays(_group(arrays, "filler."), name)
    filler.classes_ = filler.trees_.classes
    filler.level_ = float(meta["filler_level"])
    completer.filler_ = filler
    return completer


def load_model(path: Path, *, library_fingerprint: str | None = None) -> ShapeCompleter:
    """The completer in `path`; refuses anything but this format's `.npz` before reading it,
    another format version, a model whose fingerprint does not fit its options, and (when
    given) a model trained on another library version."""
    path = Path(path)
    arrays = read_npz(path, MODEL_BYTES)
    try:
        meta = json.loads(arrays.pop("meta").tobytes().decode("utf-8"))
    except (KeyError, UnicodeDecodeError, json.JSONDecodeError, RecursionError):
        raise InputError(f"{path}: not a completion model file") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise InputError(f"{path}: not a completion model file")
    if meta.get("format_version") != FORMAT_VERSION:
        raise InputError(
            f"{path}: model format version {meta.get('format_version')}, this homemodel reads version"
            f" {FORMAT_VERSION}: train it again"
        )
    try:
        completer = _completer(arrays, meta, str(path))
        consistent = meta["fingerprint"] == training_fingerprint(meta["library_fingerprint"], completer.get_params())
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as exc:
        raise InputError(f"{path}: the model's arrays are incomplete or inconsistent ({exc}): train it again") from None
    if not consistent:
        raise InputError(f"{path}: the model's fingerprint does not match its contents: train it again")
    if library_fingerprint is not None and meta["library_fingerprint"] != library_fingerprint:
        raise InputError(f"{path}: trained on another version of the library: train it again on this one")
    return completer
