"""One joint's position fitted against the model's own rendered depth: a coarse 1-D search
over the joint's range, then a fine one around the best, each candidate scored by how well
the scene rendered with the joint there explains the observed depth.

The score is robust to occlusion. It counts only the pixels where the moving part is the
first surface at some candidate position, and leaves out the pixels where the observation
lies in front of every surface any candidate renders there: something the map does not hold
(a person, a chair, a box) covers them, and they say nothing about the joint. At the pixels
left, the residual (observed minus rendered depth) is truncated at the sensor's tolerance: a
part rendered where the camera sees through it, or missing where the camera sees it, costs
the same wherever the mismatch is.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tracking.fit_state import FitState
from tracking.fit_view import FitView


@dataclass(kw_only=True)
class JointSearch:
    """How a joint is searched: the coarse grid's step and the fine grid's step (rad for
    revolute and continuous joints, m for prismatic ones)."""

    coarse_step: float
    fine_step: float
    # A joint that rests only at its named states (an oven knob's detents) is scored at
    # those alone, in the fine view.
    detents: tuple[float, ...] = ()


@dataclass(kw_only=True)
class JointFit:
    """A joint's estimate and what supports it."""

    position: float
    visible_fraction: float  # of the moving part's pixels (past the image's edges too), those nothing nearer covers
    residual_m: float  # RMS of the truncated residual over the part's observed pixels
    unexplained: float  # their mean truncated squared residual over the tolerance: 0 all explained, 1 none
    pixels: int  # the part's observed pixels (in the fine view)
    contrast: float  # how much worse (share of pixels) the best position far from this one scores; NaN for a refit


def joint_range(state: FitState, object_id: str, joint: str) -> tuple[float, float]:
    limits = state.scene.object(object_id).node.joint(joint).limits
    return (-np.pi, np.pi) if limits is None else (float(limits[0]), float(limits[1]))


def fit_joint(
    state: FitState,
    views: list[tuple[FitView, np.ndarray]],
    object_id: str,
    joint: str,
    search: JointSearch,
    *,
    near: float | None = None,
) -> JointFit | None:
    """Fit `joint` of `object_id`, the other joints and the poses at their estimates; sets
    the estimate in `state`. `views` are the coarse and the fine view, each with the depth
    of the scene without the object (`FitState.background_depth`). `near`: search only the
    fine grid two steps either side of this position (a refit after the pose moved a little). None (state
    unchanged) when the moving part is nowhere in view."""
    low, high = joint_range(state, object_id, joint)
    moving = state.moving_parts(object_id, joint)
    if not moving:
        return None
    (coarse, coarse_background), (fine, fine_background) = views
    contrast = float("nan")
    if search.detents:
        return _fit_detents(state, fine, fine_background, object_id, joint, moving, np.array(search.detents))
    # A refit follows a pose that moved by millimetres: the joint moves by a step or two.
    reach = 2 * search.fine_step
    if near is None:
        reach = search.coarse_step
        coarse_values = position_grid(low, high, search.coarse_step)
        coarse_static = static_depth(state, coarse, coarse_background, object_id, moving)
        coarse_costs = _costs(state, coarse, coarse_static, object_id, joint, moving, coarse_values)
        if coarse_costs is None:
            return None
        near = float(coarse_values[int(np.argmin(coarse_costs))])
        far = np.abs(coarse_values - near) > 2 * search.coarse_step
        contrast = float(coarse_costs[far].min() - coarse_costs.min()) if far.any() else 0.0
    fine_values = position_grid(max(low, near - reach), min(high, near + reach), search.fine_step)
    fine_static = static_depth(state, fine, fine_background, object_id, moving)
    fine_costs = _costs(state, fine, fine_static, object_id, joint, moving, fine_values)
    if fine_costs is None:
        return None
    position = float(np.clip(_parabola_minimum(fine_values, fine_costs), low, high))
    state.joint_positions[object_id][joint] = position
    support = _support(state, fine, fine_static, object_id, joint, moving, position)
    return JointFit(position=position, contrast=contrast, **support)


def _fit_detents(
    state: FitState, view: FitView, background: np.ndarray, object_id: str, joint: str, moving: list[int],
    values: np.ndarray,
) -> JointFit | None:
    static = static_depth(state, view, background, object_id, moving)
    costs = _costs(state, view, static, object_id, joint, moving, values)
    if costs is None:
        return None
    best = int(np.argmin(costs))
    position = float(values[best])
    state.joint_positions[object_id][joint] = position
    contrast = float(np.delete(costs, best).min() - costs[best]) if len(values) > 1 else 0.0
    return JointFit(position=position, contrast=contrast, **_support(state, view, static, object_id, joint, moving, position))


def position_grid(low: float, high: float, step: float) -> np.ndarray:
    """Positions from `low` to `high`, both included, at most `step` apart."""
    count = max(int(np.ceil((high - low) / step - 1e-9)), 1) + 1
    return np.linspace(low, high, count)


def _parabola_minimum(values: np.ndarray, costs: np.ndarray) -> float:
    """The vertex of the parabola through the best grid value and its neighbours."""
    k = int(np.argmin(costs))
    if k == 0 or k == len(values) - 1:
        return float(values[k])
    c0, c1, c2 = costs[k - 1], costs[k], costs[k + 1]
    curvature = c0 - 2 * c1 + c2
    if curvature <= 0:
        return float(values[k])
    step = values[k + 1] - values[k]
    return float(values[k] + 0.5 * step * (c0 - c2) / curvature)


def static_depth(state: FitState, view: FitView, background: np.ndarray, object_id: str, moving: list[int]) -> np.ndarray:
    """The scene's depth without the moving part."""
    others = [i for i in state.object_parts(object_id) if i not in set(moving)]
    if not others:
        return background
    return np.minimum(background, state.renderer.depth(state.map_from_parts(), view.camera, view.map_from_camera, others))


def moving_depths(
    state: FitState, view: FitView, object_id: str, joint: str, moving: list[int], values: np.ndarray
) -> np.ndarray:
    """(len(values), H, W) depth of the moving part alone at each position; inf where it is not
    hit, NaN where its glass is (a door's window: seen through, or no reading)."""
    current = state.map_from_parts()
    poses = [_map_from_parts_at(state, object_id, joint, moving, value, current) for value in values]
    return state.renderer.depth_stack(poses, view.camera, view.map_from_camera, moving, glass_unknown=True)


def _map_from_parts_at(
    state: FitState, object_id: str, joint: str, moving: list[int], value: float,
    current: list[np.ndarray] | None = None,
) -> list[np.ndarray]:
    """Every part's pose with `joint` at `value` (its `moving` parts moved), from `current`
    (`state.map_from_parts()`, computed once for many values)."""
    at_value = list(state.map_from_parts() if current is None else current)
    for i, pose in zip(moving, state.part_poses_at(object_id, joint, value, moving)):
        at_value[i] = pose
    return at_value


def _costs(
    state: FitState, view: FitView, static: np.ndarray, object_id: str, joint: str, moving: list[int], values: np.ndarray
) -> np.ndarray | None:
    """The mean truncated squared residual (0 = every pixel explained, 1 = none) at each value."""
    return stack_costs(view, static, moving_depths(state, view, object_id, joint, moving, values))


def stack_costs(view: FitView, static: np.ndarray, stack: np.ndarray) -> np.ndarray | None:
    """`_costs` of the moving part's depth at each position ((K, H, W) `stack`, `moving_depths`)
    in front of the `static` scene; None when no pixel has a usable reading. Through the moving
    part's glass (NaN) the camera sees the static scene."""
    with np.errstate(invalid="ignore"):
        in_front = stack < static  # the moving part is what the camera would see there
    considered = in_front.any(axis=0)
    model = np.fmin(stack[:, considered], static[considered])
    observed = view.depth_m[considered]
    tolerance = view.tolerance_m[considered]
    nearest = model.min(axis=0)
    usable = np.isfinite(observed) & (observed >= nearest - tolerance)
    if not usable.any():
        return None
    residual = (observed[usable] - model[:, usable]) / tolerance[usable]
    with np.errstate(invalid="ignore"):
        return np.minimum(np.nan_to_num(residual**2, nan=1.0, posinf=1.0), 1.0).mean(axis=1)


def _support(
    state: FitState, view: FitView, static: np.ndarray, object_id: str, joint: str, moving: list[int], position: float
) -> dict:
    own = moving_depths(state, view, object_id, joint, moving, np.array([position]))[0]
    # The part's whole image, past the view's edges too: a door the edge cuts in half is half seen.
    whole = state.renderer.pixels_whole(_map_from_parts_at(state, object_id, joint, moving, position), view.camera,
                                        view.map_from_camera, moving, glass_unknown=True)
    front = own < static
    observed = view.depth_m
    tolerance = view.tolerance_m
    with np.errstate(invalid="ignore"):
        covered = np.isfinite(observed) & (observed < own - tolerance)
        seen = front & np.isfinite(observed) & ~covered
        residual = np.where(seen, (observed - own) / tolerance, 0.0)
    truncated = np.minimum(residual[seen] ** 2, 1.0) * tolerance[seen] ** 2
    return {
        # Pixels with no reading count as visible: a door seen near edge-on gives none
        # (grazing incidence), yet nothing hides it.
        "visible_fraction": float((front & ~covered).sum() / whole) if whole else 0.0,
        "residual_m": float(np.sqrt(truncated.mean())) if seen.any() else float("nan"),
        "unexplained": float(np.minimum(residual[seen] ** 2, 1.0).mean()) if seen.any() else float("nan"),
        "pixels": int(seen.sum()),
    }
