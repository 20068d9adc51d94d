"""An object's pose and its joints refined together: Gauss-Newton on [pose, joint positions]
over the point-to-plane residuals between the observed depth and the object's own rendered
surface, the object re-rendered at every step.

Fitting the pose and each joint by turns does not settle where they trade against each
other: a drawer's front and the body's front are parallel, so the body's shift along the
slide and the drawer's slide are told apart only when both are fitted at once. Motions the
seen surfaces do not pin down (a slide across a cupboard seen only from the front) are left
out, not guessed (degeneracy-aware, as `fit_pose` does for the pose alone).

Occlusion: a pixel counts only where the object is the first surface of the rendered scene
and the observation lies within the gate of the rendered depth (a box in front, or the
room seen through an opening, lies outside it); a Tukey kernel discounts what is left.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from tracking.fit_pose import LEVER_M, yaw_of
from tracking.fit_joints import joint_range
from tracking.fit_state import FitState
from tracking.fit_view import FitView
from tracking.pose_gate import cut_by_edge, object_depth, scene_costs

# A step smaller than these (m, and rad at LEVER_M) ends a gate's iterations.
STEP_DONE_M = 0.0002
# A motion of the pose and joints that moves the seen surfaces along their normals less than
# this (mean square, turns at LEVER_M) is left out of a step. A joint moves a small share of
# an object's pixels: at `fit_pose`'s 0.03, a drawer's slide and the body's shift it trades
# with (0.026 on the bench's cupboard at 1.2 m, `--seed 2`) were never stepped, and the fit
# ended where the map's pose had left them, the drawer 12 mm off. A motion nothing pins (a
# slide along a flat front seen square on) moves no pixel along its normal and stays under it.
MIN_CONSTRAINT = 0.003


@dataclass(kw_only=True)
class TogetherFit:
    """What the refinement did: the object's rendered depth cost (`depth_costs`) before and
    after (the same when the result was not kept), and the steps taken."""

    cost_before: float
    cost_after: float
    steps: int


@dataclass(frozen=True)
class _PoseMotion:
    """The directions (unit vectors, map frame) the pose may shift and turn along: any, or for
    an object standing on a surface (`planar`) a shift in the floor's plane and a yaw."""

    shifts: np.ndarray  # (k, 3)
    turns: np.ndarray  # (m, 3)

    @classmethod
    def of(cls, planar: bool) -> _PoseMotion:
        if not planar:
            return cls(shifts=np.eye(3), turns=np.eye(3))
        return cls(shifts=np.eye(3)[:2], turns=np.eye(3)[2:])


def refine_pose_and_joints(
    state: FitState,
    view: FitView,
    object_id: str,
    joints: list[str],
    background_m: np.ndarray,
    *,
    gates_m: tuple[float, ...],
    kernel_m: float,
    planar: bool,
    min_points: int,
    edge_margin_px: int = 1,
    search_view: tuple[FitView, np.ndarray] | None = None,
    iterations: int = 4,
    kept_in_place: tuple[str, ...] = (),
) -> TogetherFit | None:
    """Refine `state`'s pose of `object_id` and the positions of `joints` (its movable joints
    to fit; the others stay) from the observed points in front of `background_m`. The state
    changes only when the result explains the object's observed depth better; None, unchanged,
    when too few points are seen or the image's left or right edge cuts the object (within
    `edge_margin_px`). `search_view` (a coarser view and its background) is where compass
    searches and a grid of starts on the rendered depth start the fit, for an object standing on
    a surface. `kept_in_place`: joints fitted but not refined here (a drawer front partly seen),
    moved back at each end so their parts stay where they were fitted as the body moves."""
    start = (state.map_from_objects[object_id].copy(), dict(state.joint_positions[object_id]))
    depth_before = object_depth(state, view, object_id)
    if cut_by_edge(depth_before < background_m, edge_margin_px):
        # Nothing pins its slide across the image (`judge_pose` keeps only the shift along
        # the view): the search would slide it there.
        return None
    motion = _PoseMotion.of(planar)
    first = _residuals(state, view, object_id, joints, background_m, min(gates_m), motion)
    if first is None or len(first[0]) < min_points:
        return None
    starts = [start]
    if planar and search_view is not None:
        search_view = _search_pixels(state, *search_view, object_id)
        starts = _search_ends(state, *search_view, object_id, joints, motion)
        starts += _grid_starts(state, *search_view, object_id, joints, motion)
    ends, depths, steps, settled = [], [depth_before], 0, []
    for pose, positions in starts:
        state.map_from_objects[object_id], state.joint_positions[object_id] = pose.copy(), dict(positions)
        taken, outcome = _gauss_newton(state, view, object_id, joints, background_m, gates_m, kernel_m, min_points,
                                       motion, iterations, settled)
        steps += taken
        if outcome == "repeated":
            continue
        ends.append((state.map_from_objects[object_id].copy(), dict(state.joint_positions[object_id])))
        if outcome == "settled":
            settled.append(ends[-1])
        depths.append(object_depth(state, view, object_id))
        if kept_in_place:
            # Each end judged twice: with the parts not refined here carried along by the body,
            # and kept where they were fitted. Carried, a part fitted at the start's body would
            # count against the end that puts the body right (a fridge behind a box at 2.5 m,
            # `--seed 1`: every end 0.4 mm from the truth, none kept for its drawer front 11 mm
            # out); kept, a part fitted wrong holds the body to it (a cupboard behind a box at
            # 1.2 m, `--seed 3`: its drawer 0.46 seen, the pose 12.6 mm off, a door 3.3 deg).
            _keep_in_place(state, object_id, kept_in_place, *start)
            ends.append((state.map_from_objects[object_id].copy(), dict(state.joint_positions[object_id])))
            depths.append(object_depth(state, view, object_id))
    # Judged like a refined pose (`judge_pose`): by the rendered depth, silhouettes included,
    # which the point-to-plane residuals of the object's own pixels do not see; every end on
    # the same pixels.
    costs = scene_costs(view, depths, background_m)
    best = 1 + int(np.argmin(costs[1:]))
    if not costs[best] < costs[0]:
        state.map_from_objects[object_id], state.joint_positions[object_id] = start
        return TogetherFit(cost_before=costs[0], cost_after=costs[0], steps=steps)
    state.map_from_objects[object_id], state.joint_positions[object_id] = ends[best - 1]
    return TogetherFit(cost_before=costs[0], cost_after=costs[best], steps=steps)


def _keep_in_place(
    state: FitState, object_id: str, joints: tuple[str, ...], map_from_before: np.ndarray, positions_before: dict
) -> None:
    """Move `joints` so their parts stay where they were with the body at `map_from_before` and
    the joints at `positions_before`, as far as each joint moves them: a slide takes back the
    shift of its origin along its axis; a hinge about the vertical, the body's turn."""
    map_from_object, positions = state.map_from_objects[object_id], state.joint_positions[object_id]
    turn = yaw_of(map_from_object) - yaw_of(map_from_before)
    turn = float(np.arctan2(np.sin(turn), np.cos(turn)))
    for joint in joints:
        axis, origin, kind = joint_axis_map(state, object_id, joint)
        if kind == "prismatic":
            state.map_from_objects[object_id], state.joint_positions[object_id] = map_from_before, positions_before
            origin_before = joint_axis_map(state, object_id, joint)[1]
            state.map_from_objects[object_id], state.joint_positions[object_id] = map_from_object, positions
            change = float((origin_before - origin) @ axis)
        else:
            change = -turn * axis[2]
        low, high = joint_range(state, object_id, joint)
        positions[joint] = float(np.clip(positions[joint] + change, low, high))


def _gauss_newton(
    state: FitState, view: FitView, object_id: str, joints: list[str], background_m: np.ndarray,
    gates_m: tuple[float, ...], kernel_m: float, min_points: int, motion: _PoseMotion, iterations: int,
    known_ends: Sequence[tuple[np.ndarray, dict[str, float]]] = (),
) -> tuple[int, str]:
    """Point-to-plane Gauss-Newton steps on the pose and `joints`, `iterations` at most in each
    gate (m, widest first); the number of steps taken, and how they ended: "settled" (the last
    gate's last step under STEP_DONE_M), "repeated" (within SAME_END_M of one of `known_ends`,
    other starts' settled ends: from there the steps go where they went) or "unsettled"."""
    steps, settled = 0, False
    for gate_m in gates_m:
        settled = False
        for _ in range(iterations):
            system = _residuals(state, view, object_id, joints, background_m, gate_m, motion)
            if system is None or len(system[0]) < min_points:
                break
            residual, jacobian, centre = system
            step = _step(residual, jacobian, max(kernel_m, gate_m / 2))
            _apply(state, object_id, joints, step, centre, motion)
            steps += 1
            if any(_within(state, object_id, joints, *end, SAME_END_M) for end in known_ends):
                return steps, "repeated"
            if np.abs(step).max() < STEP_DONE_M:
                settled = True
                break
    return steps, "settled" if settled else "unsettled"


# A start whose steps come this near (m, turns at LEVER_M) another start's settled end stops
# there: most of the starts end together (the bench's cupboard, fridge and oven at 1.2-2.1 m:
# every start's end within 0.1 mm, 0.01 deg of yaw and 0.1 deg of door of the first's), and
# the steps that remain, under a millimetre, each cost a rendering of the object. An end whose
# steps ran out still moving is no such place: with it known, the bench's fridge at 2.1 m
# (`--seed 3`, its body unseen) stopped a start 2 mm from it that went on to the truth, its
# door written 2.2 deg off. At 2 mm from settled ends, `--seed 1`'s fridge behind a box at
# 2.1 m went 2.18 -> 2.53 deg.
SAME_END_M = 0.0005


def _within(
    state: FitState, object_id: str, joints: list[str], map_from_object: np.ndarray, positions: dict[str, float],
    reach_m: float,
) -> bool:
    """Whether the state's pose of `object_id` and `joints` lie within `reach_m` of
    `map_from_object` and `positions`: the shift, and each turn (the pose's, a hinge's) at LEVER_M."""
    current = state.map_from_objects[object_id]
    if np.linalg.norm(current[:3, 3] - map_from_object[:3, 3]) > reach_m:
        return False
    turn = np.arccos(np.clip((np.trace(current[:3, :3].T @ map_from_object[:3, :3]) - 1) / 2, -1.0, 1.0))
    if turn * LEVER_M > reach_m:
        return False
    model = state.scene.object(object_id).model
    for joint in joints:
        lever = 1.0 if model.joint(joint).type == "prismatic" else LEVER_M
        if abs(state.joint_positions[object_id][joint] - positions[joint]) * lever > reach_m:
            return False
    return True


# The compass search's first steps: shifts, turns (the pose's yaw and revolute joints) and
# slides, halved SEARCH_HALVINGS times at most (Gauss-Newton takes it from there).
SEARCH_SHIFT_M = 0.008
SEARCH_TURN_RAD = np.radians(1.0)
SEARCH_SLIDE_M = 0.008
SEARCH_HALVINGS = 3
SEARCH_ROUNDS = 24
# A second search lets each step that helps double, up to SEARCH_GROWTH times its first.
# Halving alone crawls along a long valley (a body 2 cm off, its drawer's slide and door's
# turn taking the shift back) and the rounds run out there: the bench's cupboard behind a box
# at 2.1 m ended with its drawer 14.2 mm and door 2.9 deg off. Neither search's end is kept
# for its own cost: the grown one's lower cost led the fridge behind a box at 2.5 m, its body
# unseen, to a drawer 26.7 mm off, where Gauss-Newton from the plain one's end found the truth.
# The second runs only when the first ran out of rounds, the valley's sign: where the first
# settled, the bench's 5 view sets wrote every joint within 0.01 deg or mm of what they wrote
# with both, for 5-7 % less of observe's CPU.
SEARCH_GROWTHS = (1.0, 4.0)


def _search_ends(
    state: FitState, view: FitView, background_m: np.ndarray, object_id: str, joints: list[str], motion: _PoseMotion
) -> list[tuple[np.ndarray, dict[str, float]]]:
    """Where compass searches of the object's planar pose (its shifts, yaw about its origin) and
    `joints` on the rendered depth cost (`depth_costs`) end, one for each of SEARCH_GROWTHS, all
    from the state's estimate (left as it was); the same end once. The cost sees the
    silhouettes, which the point-to-plane steps do not, and so finds a slide across the view
    those leave free."""
    model = state.scene.object(object_id).model
    first = np.array([SEARCH_SHIFT_M] * len(motion.shifts) + [SEARCH_TURN_RAD]
                     + [SEARCH_SLIDE_M if model.joint(j).type == "prismatic" else SEARCH_TURN_RAD for j in joints])
    start = (state.map_from_objects[object_id].copy(), dict(state.joint_positions[object_id]))
    ends: list[tuple[np.ndarray, dict[str, float]]] = []
    for growth in SEARCH_GROWTHS:
        state.map_from_objects[object_id], state.joint_positions[object_id] = start[0].copy(), dict(start[1])
        settled = _compass(state, view, background_m, object_id, joints, motion, first, growth=growth)
        end = (state.map_from_objects[object_id].copy(), dict(state.joint_positions[object_id]))
        if not any(np.array_equal(end[0], e[0]) and end[1] == e[1] for e in ends):
            ends.append(end)
        if settled:
            # A search that settled before its rounds ran out did not crawl along a valley:
            # the grown steps are for that case only.
            break
    state.map_from_objects[object_id], state.joint_positions[object_id] = start
    return ends


# An object whose observed pixels fill more than this share of the search view is searched
# (compass searches, grid of starts) on every other pixel of it each way, a quarter of them:
# the searches only choose Gauss-Newton's starts, which then run on the fine view. At 1.2 m
# the bench's cupboard fills a third of the image, and its compass searches, crawling all
# their rounds, took 0.7 of observe's 2.2 CPU-s there. Counted on the pixels with a reading:
# the fridge at 2.1 m behind a box (`--seed 1`) covers 0.30 of the view, 0.26 with one, and
# searched thinned it wrote its door 2.5 deg off instead of 2.2 (its body unseen, both misses).
THIN_SEARCH_SHARE = 0.3


def _search_pixels(
    state: FitState, view: FitView, background_m: np.ndarray, object_id: str
) -> tuple[FitView, np.ndarray]:
    """The search view and background, every other pixel of them each way when the object's
    observed pixels fill more than THIN_SEARCH_SHARE of the view."""
    seen = (object_depth(state, view, object_id) < background_m) & view.valid
    if seen.mean() <= THIN_SEARCH_SHARE:
        return view, background_m
    return view.strided(2), background_m[::2, ::2]


# A wider start set within the map's uncertainty (a few cm, a few degrees) along what the seen
# fronts leave loose, a slide across the view and a yaw: the body moved over a grid of those,
# each joint moved back so its part stays where it was fitted, scored in one batched coarse
# cast; Gauss-Newton runs from the best GRID_KEPT, and the fine depth cost judges every end.
# The doors and drawers are seen better than the body they trade with: from the compass
# searches alone the bench's cupboard at 1.6 m (`--seed 1`) ended with its body 24 mm off and
# its doors 3.3 and 3.4 deg off the other way; from the grid, 6.6 mm, 1.6 and 0.3 deg.
GRID_SLIDES_M = (-0.03, -0.015, 0.0, 0.015, 0.03)
GRID_TURNS_RAD = tuple(np.radians((-4.0, -2.0, 0.0, 2.0, 4.0)))
GRID_KEPT = 2


def _grid_starts(
    state: FitState, view: FitView, background_m: np.ndarray, object_id: str, joints: list[str], motion: _PoseMotion
) -> list[tuple[np.ndarray, dict[str, float]]]:
    """The GRID_KEPT poses of the grid about the state's estimate, with their joints keeping their
    parts in place, that have the lowest depth cost (`depth_costs`)."""
    across = np.cross(view.map_from_camera[:3, 2], [0.0, 0.0, 1.0])
    length = float(np.linalg.norm(across))
    # A camera looking straight down has no horizontal direction across its view: turns only.
    slides = GRID_SLIDES_M if length > 1e-6 else (0.0,)
    across = across / length if length > 1e-6 else across
    axes = [joint_axis_map(state, object_id, joint) for joint in joints]
    moves = []
    for slide in slides:
        for turn in GRID_TURNS_RAD:
            if not (slide or turn):
                continue
            shift = slide * across
            # A yaw turns a door on an upright hinge with the body; a shift carries a drawer along.
            back = [-turn * axis[2] if kind == "revolute" else -float(shift @ axis) for axis, _, kind in axes]
            moves.append(np.array([*(motion.shifts @ shift), turn, *back]))
    candidates = [_moved(state, object_id, joints, move, motion) for move in moves]
    costs = _costs(state, view, background_m, object_id, candidates)
    return [candidates[i] for i in np.argsort(costs)[:GRID_KEPT]]


def _compass(
    state: FitState, view: FitView, background_m: np.ndarray, object_id: str, joints: list[str], motion: _PoseMotion,
    first: np.ndarray, *, growth: float,
) -> bool:
    """At most SEARCH_ROUNDS rounds of the compass search from steps `first`, each scoring every
    parameter one step either way in one batched cast; with `growth` over 1, a step that helps
    doubles, up to `growth` times its first; when none helps, all are halved, SEARCH_HALVINGS
    times at most. True when it settled (no step helps at the smallest), False when the rounds
    ran out first."""
    steps = first.copy()
    smallest, largest = first / 2**SEARCH_HALVINGS, first * growth
    for _ in range(SEARCH_ROUNDS):
        moves = [np.zeros(len(steps))]
        for k in range(len(steps)):
            for sign in (1.0, -1.0):
                moves.append(np.zeros(len(steps)))
                moves[-1][k] = sign * steps[k]
        costs = _costs(state, view, background_m, object_id, [_moved(state, object_id, joints, m, motion) for m in moves])
        best = int(np.argmin(costs))
        if costs[best] < costs[0]:
            state.map_from_objects[object_id], state.joint_positions[object_id] = _moved(state, object_id, joints, moves[best], motion)
            if growth > 1:
                k = (best - 1) // 2
                steps[k] = min(2 * steps[k], largest[k])
        elif (steps <= smallest + 1e-12).all():
            return True
        else:
            steps = np.maximum(steps / 2, smallest)
    return False


def _costs(
    state: FitState, view: FitView, background_m: np.ndarray, object_id: str, candidates: list[tuple[np.ndarray, dict]]
) -> tuple[float, ...]:
    """The depth cost (`depth_costs`) of the object at each (map_from_object, joint positions)
    of `candidates`, all on the same pixels, in one batched cast."""
    parts = state.object_parts(object_id)
    base = state.map_from_parts()
    poses = []
    for map_from_object, positions in candidates:
        links = state.object_from_links(object_id, positions)
        posed = list(base)
        for i in parts:
            posed[i] = map_from_object @ links[state.scene.parts[i].link]
        poses.append(posed)
    stack = state.renderer.depth_stack(poses, view.camera, view.map_from_camera, parts)
    return scene_costs(view, list(stack), background_m)


def _moved(
    state: FitState, object_id: str, joints: list[str], move: np.ndarray, motion: _PoseMotion
) -> tuple[np.ndarray, dict[str, float]]:
    """The object's planar pose shifted along `motion`'s shifts by the first of `move`, turned
    by the next about its origin, and its `joints` moved by the rest within their limits."""
    count = len(motion.shifts)
    c, s = np.cos(move[count]), np.sin(move[count])
    map_from_object = state.map_from_objects[object_id].copy()
    map_from_object[:2, :] = np.array([[c, -s], [s, c]]) @ map_from_object[:2, :]
    map_from_object[:3, 3] = state.map_from_objects[object_id][:3, 3] + move[:count] @ motion.shifts
    positions = dict(state.joint_positions[object_id])
    for joint, change in zip(joints, move[count + 1:]):
        low, high = joint_range(state, object_id, joint)
        positions[joint] = float(np.clip(positions[joint] + change, low, high))
    return map_from_object, positions


def _residuals(
    state: FitState, view: FitView, object_id: str, joints: list[str], background_m: np.ndarray, gate_m: float,
    motion: _PoseMotion,
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(N,) point-to-plane residuals (observed minus model, along the model's normal), the
    (N, P) rates at which the parameters' motions move the model along its normals (`_apply`'s
    order: the pose's, then each joint's; turns at a lever of LEVER_M) and the centre the
    pose turns about (the points' centroid)."""
    parts = state.object_parts(object_id)
    rendering = state.renderer.render(state.map_from_parts(), view.camera, view.map_from_camera, only=parts)
    # The parts of joints not refined here (not seen, or in doubt) say nothing reliable.
    trusted = [i for i in parts if state.scene.parts[i].joint is None
               or any(i in state.moving_parts(object_id, joint) for joint in joints)]
    with np.errstate(invalid="ignore"):
        mask = (np.isin(rendering.part_index, trusted) & (rendering.depth_m < background_m) & view.valid
                & (np.abs(view.depth_m - rendering.depth_m) < gate_m))
    if not mask.any():
        return None
    rotation = view.map_from_camera[:3, :3]
    normals = rendering.normals_camera[mask] @ rotation.T
    model, observed = view.points_map_at(mask, rendering.depth_m, view.depth_m)
    residual = np.einsum("ij,ij->i", observed - model, normals)
    centre = model.mean(axis=0)
    columns = [normals @ axis for axis in motion.shifts]
    for axis in motion.turns:
        columns.append(np.einsum("ij,ij->i", np.cross(axis, model - centre), normals) / LEVER_M)
    part_index = rendering.part_index[mask]
    for joint in joints:
        axis, origin, kind = joint_axis_map(state, object_id, joint)
        carried = np.isin(part_index, state.moving_parts(object_id, joint))
        if kind == "prismatic":
            velocity = np.broadcast_to(axis, model.shape)
        else:
            velocity = np.cross(axis, model - origin) / LEVER_M
        columns.append(np.where(carried, np.einsum("ij,ij->i", velocity, normals), 0.0))
    return residual, np.column_stack(columns), centre


def _step(residual: np.ndarray, jacobian: np.ndarray, kernel_m: float) -> np.ndarray:
    """The Gauss-Newton step (Tukey-weighted) that best explains `residual`, without its part
    along the motions the points constrain less than MIN_CONSTRAINT."""
    weights = np.where(np.abs(residual) < kernel_m, (1 - (residual / kernel_m) ** 2) ** 2, 0.0)
    total = weights.sum()
    if total <= 0:
        return np.zeros(jacobian.shape[1])
    information = (jacobian * weights[:, None]).T @ jacobian / total
    gradient = (jacobian * weights[:, None]).T @ residual / total
    values, vectors = np.linalg.eigh(information)
    kept = values >= MIN_CONSTRAINT
    return vectors[:, kept] @ ((vectors[:, kept].T @ gradient) / values[kept])


def _apply(
    state: FitState, object_id: str, joints: list[str], step: np.ndarray, centre: np.ndarray, motion: _PoseMotion
) -> None:
    """Move the object by the pose's share of `step` (`motion`'s shifts, then its turns about
    `centre`, in the map frame) and its joints by theirs, within their limits."""
    shifts, turns = len(motion.shifts), len(motion.turns)
    rotation = _rotation(step[shifts:shifts + turns] @ motion.turns / LEVER_M)
    moved = np.eye(4)
    moved[:3, :3] = rotation
    moved[:3, 3] = centre + step[:shifts] @ motion.shifts - rotation @ centre
    state.map_from_objects[object_id] = moved @ state.map_from_objects[object_id]
    for joint, change in zip(joints, step[shifts + turns:]):
        low, high = joint_range(state, object_id, joint)
        kind = state.scene.object(object_id).model.joint(joint).type
        scale = 1.0 if kind == "prismatic" else 1.0 / LEVER_M
        position = state.joint_positions[object_id][joint] + change * scale
        state.joint_positions[object_id][joint] = float(np.clip(position, low, high))


def _rotation(rotation_vector: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_rotvec(rotation_vector).as_matrix()


def joint_axis_map(state: FitState, object_id: str, joint: str) -> tuple[np.ndarray, np.ndarray, str]:
    """(unit axis, a point on it, type) of `joint` in the map frame at the current estimates."""
    model = state.scene.object(object_id).model
    model_joint = model.joint(joint)
    map_from_joint = (state.map_from_objects[object_id] @ state.object_from_links(object_id)[model_joint.parent]
                      @ model_joint.parent_from_joint)
    axis = map_from_joint[:3, :3] @ (model_joint.axis / np.linalg.norm(model_joint.axis))
    return axis, map_from_joint[:3, 3], model_joint.type
