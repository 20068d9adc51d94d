"""Whether a large object's refined pose may replace the map's: only when the observation
pins it down and it explains the observed depth clearly better than the map's pose does.
A wrong pose written into the map is worse than an old one kept, so doubt keeps the old one.

Both poses are scored on the same pixels (the object rendered at either pose, in front of
the rest of the scene, and not covered by something nearer), by the mean truncated squared
depth residual: 0 = every pixel explained, 1 = none.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from homemodel.core.checks import require_between
from tracking.fit_pose import free_motions, yaw_of
from tracking.fit_state import FitState
from tracking.fit_view import FitView
from tracking.scene import box_corners


# The map's doubt about a large object's pose, as the issue gives it: 2 cm, 2 deg.
DOUBT_M, DOUBT_RAD = 0.02, np.radians(2.0)


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
    # The map is a few centimetres and degrees off: a pose that moves a corner of the object's
    # box more than this many times the map's doubt there (DOUBT_M, and DOUBT_RAD at the
    # corner's lever about the origin) is a fit gone wrong, not the map's error put right (a
    # 1.5 m wardrobe seen edge-on at the image's edge turned 11 deg; the bound there is 10 cm,
    # for a 2.2 m sofa 12 cm: its 3 cm and 4 deg pass).
    max_corner_doubts: float = 2.0

    def check(self) -> None:
        for name in ("min_inliers", "max_cost_ratio", "min_cost_drop"):
            require_between(name, getattr(self, name), 0.0, 1.0)
        require_between("edge_margin_px", self.edge_margin_px, 0, 64)
        require_between("max_corner_doubts", self.max_corner_doubts, 0.0, 100.0)


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
    # Its seen surfaces, and its outline against what is far behind it, may leave a motion
    # free: what moved along it past the map's doubt is taken out. A wardrobe at the image's
    # edge showing its side alone cannot tell a slide along that side (its origin went 20 ->
    # 47 mm off as its turn was put right about that side); a cupboard in a row, its sides
    # hidden by its neighbours, slid 33-38 mm along its front, where the depth cost was lower
    # (0.089 -> 0.058 for the slide): the depth cannot tell the model's error from the map's.
    # Cut by the image's edge, its slide across the image is not pinned either: only the turn
    # and the shift along the view are kept.
    moved = _along_view(refined, map_from_object_before, view.map_from_camera) if cut else refined
    # Not cut, a free motion within the bound on the map's error (3 cm, 3 deg) is
    # its error put right, the view's best word on it: an oven in a row was put right 20 ->
    # 4-17 mm along its front, and to 18 mm with it taken out.
    pinned = _pinned(moved, map_from_object_before, *_seen_surface(state, view, object_id, background_m),
                     doubts=1.0 if cut else FREE_DOUBTS)
    # Where that pose is refused, the pose is judged as it was before this rule: as refined,
    # or cut by the edge, less what its surfaces alone leave free (an oven seen as a sliver
    # at 2.1 m, put right 20 -> 8 mm, explained the depth worse than at the map's pose with
    # its free motion taken out, and kept at the map's, a small object was found on it).
    before_this_rule = _pinned(moved, map_from_object_before,
                               *_seen_surface(state, view, object_id, background_m, outline=False)) if cut else refined
    for candidate in [pinned] if pinned is before_this_rule else [pinned, before_this_rule]:
        state.map_from_objects[object_id] = candidate
        verdict = _judged(state, view, object_id, map_from_object_before, before, background_m, gate, cut)
        if verdict.accepted:
            break
    return verdict


def _judged(
    state: FitState,
    view: FitView,
    object_id: str,
    map_from_object_before: np.ndarray,
    before: np.ndarray,
    background_m: np.ndarray,
    gate: PoseGate,
    cut: bool,
) -> PoseVerdict:
    """The verdict on `state`'s pose of `object_id` against `map_from_object_before`, whose
    depth is `before`."""
    after = object_depth(state, view, object_id)
    gone_wrong = past_the_doubt(state, object_id, map_from_object_before, gate)
    if gone_wrong:
        return PoseVerdict(accepted=False, note=f"{gone_wrong}: not the map's error put right")
    cost_before, cost_after = scene_costs(view, [before, after], background_m)
    verdict = PoseVerdict(accepted=False, note="", cost_before=cost_before, cost_after=cost_after)
    costs = f"depth cost {cost_before:.3f} -> {cost_after:.3f}"
    if cut:
        costs += ", cut by the image's edge: turn and shift along the view only"
    if not (cost_after <= gate.max_cost_ratio * cost_before and cost_before - cost_after >= gate.min_cost_drop):
        verdict.note = f"no clearly better fit ({costs})"
        return verdict
    verdict.accepted, verdict.note = True, costs
    return verdict


def past_the_doubt(state: FitState, object_id: str, map_from_before: np.ndarray, gate: PoseGate) -> str | None:
    """Why the object's current pose, from `map_from_before`, is a fit gone wrong rather than
    the map's error put right: a corner of its box moved more than `max_corner_doubts` times
    the map's doubt there, or it turned more than that many times the map's doubt about its
    turn (a small object's corners are near its origin: a microwave's pose turned 6.3 deg the
    wrong way, 8.3 deg off, passed the corners' bound). None when neither."""
    moved_m, doubt_m = _corner_move_m(state, object_id, map_from_before)
    if moved_m > gate.max_corner_doubts * doubt_m:
        return f"a corner moved {moved_m * 100:.0f} cm, the map's doubt there {doubt_m * 100:.0f} cm"
    change = np.linalg.inv(map_from_before) @ state.map_from_objects[object_id]
    turned = abs(yaw_of(change))
    if turned > gate.max_corner_doubts * DOUBT_RAD + 1e-9:
        return f"turned {np.degrees(turned):.1f} deg, the map's doubt {np.degrees(DOUBT_RAD):.0f} deg"
    return None


def _along_view(map_from_refined: np.ndarray, map_from_before: np.ndarray, map_from_camera: np.ndarray) -> np.ndarray:
    """The refined pose with its shift kept only along the camera's horizontal viewing direction."""
    forward = np.array([map_from_camera[0, 2], map_from_camera[1, 2], 0.0])
    forward /= max(np.linalg.norm(forward), 1e-9)
    shift = map_from_refined[:3, 3] - map_from_before[:3, 3]
    out = map_from_refined.copy()
    out[:3, 3] = map_from_before[:3, 3] + forward * (forward @ shift)
    return out


def _corner_move_m(state: FitState, object_id: str, map_from_before: np.ndarray) -> tuple[float, float]:
    """(how far, the map's doubt there) of the corner of the object's box (its parts' at the
    current joints) that moves the most for its doubt, from `map_from_before` to the current
    pose."""
    links = state.object_from_links(object_id)
    parts = [state.scene.parts[i] for i in state.object_parts(object_id)]
    corners = box_corners(np.concatenate([box_corners(p.vertices_link) @ links[p.link][:3, :3].T + links[p.link][:3, 3]
                                          for p in parts]))
    doubts = DOUBT_M + DOUBT_RAD * np.linalg.norm(corners[:, :2], axis=1)
    change = state.map_from_objects[object_id] - map_from_before  # each corner's move: change @ corner
    moved = np.linalg.norm(corners @ change[:3, :3].T + change[:3, 3], axis=1)
    worst = int(np.argmax(moved / doubts))
    return float(moved[worst]), float(doubts[worst])


def _seen_surface(
    state: FitState, view: FitView, object_id: str, background_m: np.ndarray, *, outline: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """(points, normals) in the map of the object's rendered surface at the current estimates
    where the observation shows it (within the view's tolerance), and with `outline` its
    outline's (`_outline`)."""
    rendering = state.renderer.render(state.map_from_parts(), view.camera, view.map_from_camera,
                                      only=state.object_parts(object_id))
    near = np.abs(np.nan_to_num(view.depth_m, nan=-1.0) - rendering.depth_m) < view.tolerance_m
    mine = rendering.hit & (rendering.depth_m < background_m)
    seen = mine & view.valid & near
    points = [view.points_map(rendering.depth_m, seen)]
    normals = [rendering.normals_camera[seen] @ view.map_from_camera[:3, :3].T]
    for edge_points, edge_normals in _outline(view, rendering.depth_m, seen, mine) if outline else ():
        points.append(edge_points)
        normals.append(edge_normals)
    return np.concatenate(points), np.concatenate(normals)


# An outline seen against something this much farther behind pins the object's motion across it.
OUTLINE_GAP_M = 0.05


def _outline(
    view: FitView, depth_m: np.ndarray, seen: np.ndarray, mine: np.ndarray
) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """(points, outward normals) in the map of the seen pixels at the object's outline, each
    way across the image, where the observation beyond is farther by OUTLINE_GAP_M: a slide
    along a front moves its outline against a wall far behind (a wall cupboard), not against
    a neighbour flush with it (a cupboard in a row). The normal is the horizontal part of
    the outward direction, at the object's depth; top and bottom edges give none."""
    observed = np.nan_to_num(view.depth_m, nan=-np.inf)
    rows, columns = depth_m.shape
    for dv, du in ((0, 1), (0, -1), (1, 0), (-1, 0)):
        inner = (slice(max(-dv, 0), rows - max(dv, 0)), slice(max(-du, 0), columns - max(du, 0)))
        outer = (slice(max(dv, 0), rows - max(-dv, 0)), slice(max(du, 0), columns - max(-du, 0)))
        edge = np.zeros_like(seen)
        edge[inner] = seen[inner] & ~mine[outer] & (observed[outer] > depth_m[inner] + OUTLINE_GAP_M)
        v, u = np.nonzero(edge)
        if not len(v):
            continue
        rays = view.camera.rays(np.column_stack([u, v]))
        outward = (view.camera.rays(np.column_stack([u + du, v + dv])) - rays) @ view.map_from_camera[:3, :3].T
        outward[:, 2] = 0.0
        length = np.linalg.norm(outward, axis=1)
        level = length > 0.5 * np.linalg.norm(rays, axis=1) / view.camera.fx  # not a top or bottom edge
        yield view.points_map(depth_m, edge)[level], outward[level] / length[level, None]


# The map's error as the issue bounds it (2-3 cm, a few degrees), in its doubts.
FREE_DOUBTS = 1.5


# A motion the seen surfaces pin less than this (the share of their points whose normals
# oppose it) is free. ICP's bar (`fit_pose.MIN_CONSTRAINT`, 0.03) is higher, but the pose
# judged here comes from depth fits too, which a part's outline pins: a strip of a cut
# oven's front (0.023) and a chest of drawers' (0.018) put their turns right, a wardrobe's
# side seen with a sliver of its front (0.0035) slid its origin 20 -> 40 mm.
FREE_SHARE = 0.008


def _pinned(
    map_from_moved: np.ndarray, map_from_before: np.ndarray, points: np.ndarray, normals: np.ndarray,
    doubts: float = 1.0,
) -> np.ndarray:
    """`map_from_moved` less the planar motion from `map_from_before` that the surfaces at
    `points` (with `normals`) leave free, taken out where it costs least against the map's
    doubt about the object's origin and turn (not about the seen part: turned right about a
    side it sees, an object's far end swings), unless it is within `doubts` times the map's
    doubt."""
    if len(points) < 3:
        return map_from_before
    free = free_motions(points, normals, FREE_SHARE)  # about the seen points' centroid
    if free.shape[1] == 0:
        return map_from_moved
    # The same motions about the object's origin: a turn about the centroid swings the origin.
    lever = points[:, :2].mean(axis=0) - map_from_before[:2, 3]
    free[:2] += free[2] * np.array([[lever[1]], [-lever[0]]])
    delta = map_from_moved @ np.linalg.inv(map_from_before)
    yaw = np.arctan2(delta[1, 0], delta[0, 0])
    # delta turns about the map's origin: about the object's origin it shifts by its own
    # translation plus the turn's swing of that origin.
    origin = map_from_before[:2, 3]
    shift = delta[:2, :2] @ origin + delta[:2, 3] - origin
    motion = np.array([shift[0], shift[1], yaw])
    weight = np.diag([DOUBT_M**-2, DOUBT_M**-2, DOUBT_RAD**-2])
    # The free part removed where it costs least against the map's doubt.
    free_part = free @ np.linalg.solve(free.T @ weight @ free, free.T @ weight @ motion)
    if np.hypot(*free_part[:2]) <= doubts * DOUBT_M and abs(free_part[2]) <= doubts * DOUBT_RAD:
        return map_from_moved
    x, y, yaw = motion - free_part
    out = map_from_before.copy()
    out[:3, :3] = np.array([[np.cos(yaw), -np.sin(yaw), 0.0], [np.sin(yaw), np.cos(yaw), 0.0], [0.0, 0.0, 1.0]]) @ out[:3, :3]
    out[:2, 3] = origin + (x, y)
    return out


def object_depth(state: FitState, view: FitView, object_id: str) -> np.ndarray:
    """Depth of the object's parts alone at the current estimates (inf where none is hit)."""
    return state.renderer.depth(state.map_from_parts(), view.camera, view.map_from_camera, state.object_parts(object_id))


def cut_by_edge(silhouette: np.ndarray, margin_px: int) -> bool:
    """Whether the silhouette comes within `margin_px` of the image's left or right edge."""
    edge = max(margin_px, 1)
    return bool(silhouette[:, :edge].any() or silhouette[:, -edge:].any())


def scene_costs(view: FitView, depths: Sequence[np.ndarray], background_m: np.ndarray) -> tuple[float, ...]:
    """`depth_costs` of the object rendered at each of `depths` in front of the scene's
    `background_m`, all on the pixels where any of them is in front."""
    considered = np.logical_or.reduce([d < background_m for d in depths])
    return depth_costs(view, [np.minimum(d, background_m) for d in depths], considered)


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
