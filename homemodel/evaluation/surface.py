"""Surface metrics from points sampled on one mesh and their exact distance to the other surface."""

from __future__ import annotations

import numpy as np
import trimesh

from homemodel.core.checks import require_between
from homemodel.core.errors import InputError
from homemodel.core.limits import SURFACE_SAMPLES
from homemodel.evaluation.meshes import checked_mesh
from homemodel.geometry.raycast import RayCaster

MAX_THRESHOLD_FRACTION = 10.0  # of gt's diagonal: beyond it every point is within


def check_sample_count(n_samples: int) -> None:
    """An InputError unless 1 <= n_samples <= the SURFACE_SAMPLES bound (memory grows with it)."""
    if isinstance(n_samples, bool) or not isinstance(n_samples, int | np.integer) or n_samples < 1:
        raise InputError(f"n_samples: must be a whole number of at least 1, got {n_samples!r}")
    SURFACE_SAMPLES.check("n_samples", int(n_samples))


def check_threshold_fraction(threshold_fraction: float) -> None:
    require_between("threshold_fraction", threshold_fraction, 1e-9, MAX_THRESHOLD_FRACTION)


def sample_surface_points(mesh: trimesh.Trimesh, n_samples: int, seed: int) -> np.ndarray:
    """`n_samples` points uniformly by area on `mesh`, reproducible with `seed`."""
    check_sample_count(n_samples)
    points, _ = trimesh.sample.sample_surface(mesh, n_samples, seed=seed)
    return np.asarray(points, dtype=np.float64)


def distances_to_surface(points: np.ndarray, mesh: trimesh.Trimesh) -> np.ndarray:
    """Exact unsigned distance from each point to the nearest point of the mesh's triangles
    (float32 inside: keep the points near the mesh's frame's origin)."""
    return RayCaster(mesh).distances(points)


def two_way_distances(
    pred: trimesh.Trimesh, gt: trimesh.Trimesh, *, n_samples: int, seed: int
) -> tuple[np.ndarray, np.ndarray]:
    """(distances of pred's samples to gt's surface, distances of gt's samples to pred's surface)."""
    pred, gt = checked_mesh(pred, "pred"), checked_mesh(gt, "gt")
    # Shift both by one offset: float32 distances near the origin keep their precision.
    offset = gt.bounds.mean(axis=0)
    pred_points = sample_surface_points(pred, n_samples, seed) - offset
    gt_points = sample_surface_points(gt, n_samples, seed + 1) - offset
    pred_local = trimesh.Trimesh(pred.vertices - offset, pred.faces, process=False)
    gt_local = trimesh.Trimesh(gt.vertices - offset, gt.faces, process=False)
    return distances_to_surface(pred_points, gt_local), distances_to_surface(gt_points, pred_local)


def mean_surface_distance_m(
    pred: trimesh.Trimesh, gt: trimesh.Trimesh, *, n_samples: int = 100_000, seed: int = 0
) -> float:
    """Symmetric mean surface distance: the mean of (mean distance of pred's samples to gt's
    surface, mean distance of gt's samples to pred's surface), in the meshes' units."""
    pred_to_gt, gt_to_pred = two_way_distances(pred, gt, n_samples=n_samples, seed=seed)
    return float(0.5 * (pred_to_gt.mean() + gt_to_pred.mean()))


def f_score(
    pred: trimesh.Trimesh,
    gt: trimesh.Trimesh,
    *,
    threshold_fraction: float = 0.01,
    n_samples: int = 100_000,
    seed: int = 0,
) -> float:
    """F-score at a distance threshold of `threshold_fraction` times gt's bounding-box diagonal.

    Precision: the share of pred's samples within the threshold of gt's surface; recall: the
    share of gt's samples within it of pred's surface; F = 2PR / (P + R), 0 when both are 0.
    """
    check_threshold_fraction(threshold_fraction)
    gt = checked_mesh(gt, "gt")
    threshold = threshold_fraction * float(np.linalg.norm(gt.bounds[1] - gt.bounds[0]))
    pred_to_gt, gt_to_pred = two_way_distances(pred, gt, n_samples=n_samples, seed=seed)
    precision = float(np.mean(pred_to_gt <= threshold))
    recall = float(np.mean(gt_to_pred <= threshold))
    if precision + recall == 0.0:
        return 0.0
    return 2.0 * precision * recall / (precision + recall)
