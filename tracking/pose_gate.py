"""Whether a large object's refined pose may replace the map's: only when the observation
pins it down and it explains the observed depth clearly better than the map's pose does.
A wrong pose written into the map is worse than an old one kept, so doubt keeps the old one.

Both poses are scored on the same pixels (the object rendered at either pose, in front of
the rest of the scene, and not covered by something nearer), by the mean truncated squared
depth residual: 0 = every pixel explained, 1 = none.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from homemodel.core.checks import require_between
from tracking.fit_state import FitState
from tracking.fit_view import FitView


@dataclass(kw_only=True)
class PoseGate:
    """The refined pose goes into the map when its ICP inlier share is at least
    `min_inliers`, its depth cost is at most `max_cost_ratio` of the map pose's and lower by
    at least `min_cost_drop`. An object whose silhouette comes within `edge_margin_px` pixels of
    the image's left or right edge (cut there, nothing pins its slide across the image) is
    judged with only the turn and the shift along the view."""

    min_inliers: float = 0.5
    max_cost_ratio: float = 0.9
    min_cost_drop: float = 0.005
    edge_margin_px: int = 1

    def check(self) -> None:
        for name in ("min_inliers", "max_cost_ratio", "min_cost_drop"):
            require_between(name, getattr(self, name), 0.0, 1.0)
        require_between("edge_margin_px", self.edge_margin_px, 0, 64)


@dataclass(kw_only=True)
class PoseVerdict:
    accepted: bool
    note: str  # why, for the report
    cost_before: float = float("nan")
    cost_after: float = float("nan")


def judge_pose(
    state: FitState,
    view: FitView,
    object_id: str,
    map_from_object_before: np.ndarray,
    inlier_fraction: float | None,
    background_m: np.ndarray,
    gate: PoseGate,
) -> PoseVerdict:
    """Judge `state`'s pose of `object_id` (refined, ICP inlier share `inlier_fraction`; None
    when no refinement ran) against `map_from_object_before`, the joints at their estimates."""
    if inlier_fraction is None:
        return PoseVerdict(accepted=False, note="too little of it seen to refine")
    if inlier_fraction < gate.min_inliers:
        return PoseVerdict(accepted=False, note=f"only {inlier_fraction:.0%} of its points fit")
    refined = state.map_from_objects[object_id]
    state.map_from_objects[object_id] = map_from_object_before
    before = object_depth(state, view, object_id)
    state.map_from_objects[object_id] = refined
    after = object_depth(state, view, object_id)
    cut = cut_by_edge((after < background_m) | (before < background_m), gate.edge_margin_px)
    if cut:
        # Its slide across the image is not pinned: only the turn and the shift along the
        # view are kept, and judged like any refined pose.
        state.map_from_objects[object_id] = _along_view(refined, map_from_object_before, view.map_from_camera)
        after = object_depth(state, view, object_id)
    considered = (after < background_m) | (before < background_m)
    scene_depths = [np.minimum(d, background_m) for d in (before, after)]
    cost_before, cost_after = depth_costs(view, scene_depths, considered)
    verdict = PoseVerdict(accepted=False, note="", cost_before=cost_before, cost_after=cost_after)
    costs = f"depth cost {cost_before:.3f} -> {cost_after:.3f}"
    if cut:
        costs += ", cut by the image's edge: turn and shift along the view only"
    if not (cost_after <= gate.max_cost_ratio * cost_before and cost_before - cost_after >= gate.min_cost_drop):
        verdict.note = f"no clearly better fit ({costs})"
        return verdict
    verdict.accepted, verdict.note = True, costs
    return verdict


def _along_view(map_from_refined: np.ndarray, map_from_before: np.ndarray, map_from_camera: np.ndarray) -> np.ndarray:
    """The refined pose with its shift kept only along the camera's horizontal viewing direction."""
    forward = np.array([map_from_camera[0, 2], map_from_camera[1, 2], 0.0])
    forward /= max(np.linalg.norm(forward), 1e-9)
    shift = map_from_refined[:3, 3] - map_from_before[:3, 3]
    out = map_from_refined.copy()
    out[:3, 3] = map_from_before[:3, 3] + forward * (forward @ shift)
    return out


def object_depth(state: FitState, view: FitView, object_id: str) -> np.ndarray:
    """Depth of the object's parts alone at the current estimates (inf where none is hit)."""
    return state.renderer.depth(state.map_from_parts(), view.camera, view.map_from_camera, state.object_parts(object_id))


def cut_by_edge(silhouette: np.ndarray, margin_px: int) -> bool:
    """Whether the silhouette comes within `margin_px` of the image's left or right edge."""
    edge = max(margin_px, 1)
    return bool(silhouette[:, :edge].any() or silhouette[:, -edge:].any())


def depth_costs(view: FitView, depths: list[np.ndarray], considered: np.ndarray) -> tuple[float, ...]:
    """The mean truncated squared residual of each rendered depth over `considered`'s
    observed pixels, leaving out those where the observation is in front of both renderings
    (an occluder the map does not hold)."""
    observed = view.depth_m[considered]
    tolerance = view.tolerance_m[considered]
    model = np.stack([d[considered] for d in depths])
    usable = np.isfinite(observed) & (observed >= model.min(axis=0) - tolerance)
    if not usable.any():
        return tuple(1.0 for _ in depths)
    residual = (observed[usable] - model[:, usable]) / tolerance[usable]
    with np.errstate(invalid="ignore"):
        costs = np.minimum(np.nan_to_num(residual**2, nan=1.0, posinf=1.0), 1.0).mean(axis=1)
    return tuple(float(c) for c in costs)
