"""`observe`: one depth image from the robot's camera, fitted with the map's own models,
gives the map updated by what the camera saw (D3.1 section 5).

For each large object in view, fixed body first: its pose is refined from its fixed links
(ICP, `fit_pose`), then each joint is fitted alone against the rendered depth (`fit_joints`),
parents before children; then the pose again from all its links at the fitted joints, and
the joints once more; last, the pose and the fitted joints at once (`fit_together`). Then
the small objects are looked for (`find_small_objects`).

The map changes only where the camera gave evidence: joints seen well enough, small objects
found, and the pose of each large object refined from enough of its surface. Each change
keeps the old value in the object's history.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Protocol

import numpy as np

from homemodel.core.checks import require_between, require_positive
from homemodel.core.errors import InputError
from homemodel.core.progress import Progress, StageClock
from homemodel.geometry.camera import Camera
from semantic_map.hierarchy import SemanticMap
from semantic_map.nodes import Jointed, LargeObject, ObjectJoint
from tracking.find_small_objects import POSE_DOUBT_M, SmallObjectSearch, find_small_objects
from tracking.fit_joints import (JointSearch, fit_joint, joint_range, moving_depths, position_grid, stack_costs,
                                 static_depth)
from tracking.fit_pose import refine_pose
from tracking.fit_state import FitState
from tracking.fit_together import refine_pose_and_joints
from tracking.fit_view import FitView
from tracking.pose_gate import DOUBT_RAD, PoseGate, PoseVerdict, depth_costs, judge_pose, past_the_doubt, scene_costs
from tracking.report import JointReport, ObjectReport, ObservationReport
from tracking.scene import HomeScene


class Observation(Protocol):
    """What `observe` reads of an observation (`tracking.observation_files`)."""

    camera: Camera
    depth_m: np.ndarray  # (H, W) metres; 0 or NaN = no reading
    map_from_camera: np.ndarray


@dataclass(kw_only=True)
class ObserveOptions:
    """How hard to look. The views are the depth image in blocks of `coarse_factor` and
    `fine_factor` pixels (block medians); residuals are truncated at `tolerance_sigmas`
    times the sensor's axial noise at that depth, never below `min_tolerance_m`."""

    coarse_factor: int = 4
    fine_factor: int = 2
    min_tolerance_m: float = 0.01
    tolerance_sigmas: float = 3.0
    min_object_pixels: int = 40  # observed pixels of the coarse view for an object to be in view
    pose_gates_m: tuple[float, ...] = (0.05, 0.02)
    # The fixed links refine the pose first when they make up this share of the object's
    # observed pixels; fewer (a fridge seen from the front is mostly door) pin it down too
    # weakly, so the joints are fitted first, at the map's pose.
    min_fixed_share: float = 0.1
    rounds: int = 3  # of pose and joints refitted after the first fit of the joints
    together: bool = True  # then the pose and the fitted joints refined at once (`fit_together`)
    # Of a fitted joint's moving part, for it to take part: a joint left out is still rendered
    # at its first fit and anchors the body (an occluded cupboard's drawer 0.47 visible held
    # its door 3.5 deg off). When the fixed body is too little seen (`min_fixed_share`), the
    # moving parts alone pin the pose, and a door half cut off by the image's top turns with
    # it: there `together_min_visible_unseen_body` (a fridge's door 0.47 visible, its body
    # unseen, went 1.8 -> 2.4 deg).
    together_min_visible: float = 0.45
    together_min_visible_unseen_body: float = 0.5
    min_pose_points: int = 150  # fine-view points for a pose refinement
    pose_gate: PoseGate = field(default_factory=PoseGate)  # when a refined pose replaces the map's
    revolute_coarse_step_deg: float = 4.0
    revolute_fine_step_deg: float = 1.0
    prismatic_coarse_step_m: float = 0.015
    prismatic_fine_step_m: float = 0.003
    min_visible_fraction: float = 0.15  # of a moving part, to fit its joint
    # Of a moving part (its whole image, past the image's edges too), for its fitted joint to
    # go into the map: less (a door the image's edge cuts, a drawer front behind a box) is
    # reported "partly seen" with its estimate, the map's position kept. On the bench's views
    # the fitter's figure came within 0.02 of the truth's, and 12 of the 53 joints fitted
    # under half visible were off the targets.
    min_confident_fraction: float = 0.45
    min_joint_pixels: int = 12  # fine-view pixels of a moving part, to fit its joint
    min_contrast: float = 0.02  # share of pixels a far-off position must score worse by
    # ... and at least this many pixels' worth: a knob of 38 pixels with no pointer (a plain
    # cylinder) was written 120 deg off on a 0.021 share, less than one pixel of noise.
    min_contrast_pixels: float = 2.0
    # Of a fitted joint's part, the mean truncated squared residual over the tolerance (0 =
    # every seen pixel explained at the estimate, 1 = none) above which the model explains
    # none of its points: the joint is "doubtful" (its estimate and residual reported, the
    # map's position kept) and the pose it moved is not written. Noise alone leaves a pixel
    # of the right surface beyond the 3 sigma tolerance 3 times in 1000 (the right fits'
    # median: 0.05-0.08); silhouettes and models unlike the furniture take right fits up to
    # 0.998 (a wardrobe door 0.45 visible), so only "none" is refused: a dishwasher's shut
    # flap fitted open at 58.6 deg, its pose then written 52 mm off, was 1.0.
    max_unexplained: float = 0.999
    # A fitted joint whose model leaves more than this share of its part's points unexplained
    # is searched over its whole range again at the final pose: a search near the first
    # estimate cannot leave a wrong one (a shut door of a neighbour seen 27 mm off at the
    # first pose was fitted open 88 deg, 0.99 unexplained, and stayed so as the pose came
    # right). The right fits' 90th percentile on the bench: 0.11-0.19.
    search_again_unexplained: float = 0.3
    small_objects: SmallObjectSearch = field(default_factory=SmallObjectSearch)

    def check(self) -> None:
        for name in ("coarse_factor", "fine_factor"):
            require_between(name, getattr(self, name), 1, 16)
        for name in (
            "min_tolerance_m", "tolerance_sigmas", "revolute_coarse_step_deg", "revolute_fine_step_deg",
            "prismatic_coarse_step_m", "prismatic_fine_step_m", "min_object_pixels", "min_pose_points",
            "min_joint_pixels", "rounds", "min_contrast_pixels",
        ):
            require_positive(name, getattr(self, name))
        if not self.pose_gates_m or any(not g > 0 for g in self.pose_gates_m):
            raise InputError(f"pose_gates_m: {self.pose_gates_m!r} must be one or more positive distances")
        for name in ("min_visible_fraction", "min_confident_fraction", "min_contrast", "min_fixed_share", "max_unexplained",
                     "search_again_unexplained",
                     "together_min_visible", "together_min_visible_unseen_body"):
            require_between(name, getattr(self, name), 0.0, 1.0)
        self.small_objects.check()
        self.pose_gate.check()

    def search(self, joint: ObjectJoint) -> JointSearch:
        detents = _detents(joint)
        if joint.type == "prismatic":
            return JointSearch(coarse_step=self.prismatic_coarse_step_m, fine_step=self.prismatic_fine_step_m,
                               detents=detents)
        return JointSearch(
            coarse_step=np.radians(self.revolute_coarse_step_deg), fine_step=np.radians(self.revolute_fine_step_deg),
            detents=detents,
        )


def _detents(joint: ObjectJoint) -> tuple[float, ...]:
    """The positions a joint rests at, when it rests only at named states: three or more,
    from one limit to the other (an oven knob's off, 1, ..., 9); else none."""
    positions = sorted(state.position for state in joint.states)
    if len(positions) < 3 or joint.limits is None:
        return ()
    low, high = joint.limits
    if abs(positions[0] - low) > 1e-6 or abs(positions[-1] - high) > 1e-6:
        return ()
    return tuple(positions)


@dataclass(kw_only=True)
class ObserveResult:
    """The updated map (the input map when nothing was seen) and the report."""

    smap: SemanticMap
    report: ObservationReport


def observe(
    map: Path | HomeScene,
    observation: Path | Observation,
    options: ObserveOptions | None = None,
    *,
    progress: Progress | None = None,
    at: datetime | None = None,
) -> ObserveResult:
    """Fit the map's models (a map file, or its loaded `HomeScene`) to one observation (an
    observation folder, or one read) and return the updated map and the report; `at`
    (default now, UTC) stamps the history records of what changed. Nothing is written."""
    from threadpoolctl import threadpool_limits

    options = options or ObserveOptions()
    options.check()
    # Thousands of 4x4 inversions: BLAS threads only cost wake-ups (2 ms each under load).
    with threadpool_limits(1, user_api="blas"):
        return _observe(map, observation, options, progress, at)


def _observe(
    map: Path | HomeScene, observation: Path | Observation, options: ObserveOptions, progress: Progress | None,
    at: datetime | None,
) -> ObserveResult:
    clock = StageClock(progress)
    clock.start("read")
    name, observation = _read(observation)
    scene = map if isinstance(map, HomeScene) else HomeScene.load(Path(map))
    depth = np.asarray(observation.depth_m, dtype=np.float64)
    if not (np.isfinite(depth) & (depth > 0)).any():
        clock.stop()
        return ObserveResult(smap=scene.smap, report=ObservationReport(observation=name, nothing_seen=True, times_s=clock.times_s))

    state = FitState.start(scene)
    views = {
        factor: FitView.from_depth(
            observation.camera, observation.map_from_camera, depth, factor=factor,
            min_tolerance_m=options.min_tolerance_m, tolerance_sigmas=options.tolerance_sigmas,
            color_rgb=getattr(observation, "color_rgb", None),
        )
        for factor in {options.coarse_factor, options.fine_factor, 1}
    }
    coarse, fine = views[options.coarse_factor], views[options.fine_factor]
    in_view = _objects_in_view(state, coarse, options)
    reports: list[ObjectReport] = []
    clock.start("large objects", len(in_view))
    for done, (object_id, pixels) in enumerate(in_view.items()):
        reports.append(_fit_large_object(state, coarse, fine, object_id, pixels, options))
        clock.tick(done + 1, len(in_view))
    clock.start("small objects")
    small = find_small_objects(state, views[1], [r.id for r in reports], options.small_objects)
    for report in reports:
        report.small_objects = [s for s in small if s.parent == report.id or s.previous_parent == report.id]
    clock.stop()
    smap = _updated_map(scene, state, reports, at or datetime.now(timezone.utc))
    return ObserveResult(smap=smap, report=ObservationReport(observation=name, nothing_seen=False, objects=reports,
                                                             times_s=clock.times_s))


def _read(observation: Path | Observation) -> tuple[str, Observation]:
    if isinstance(observation, str | Path):
        from tracking.observation_files import read_observation

        return str(observation), read_observation(Path(observation))
    return "(in memory)", observation


def _objects_in_view(state: FitState, view: FitView, options: ObserveOptions) -> dict[str, int]:
    """Large objects with enough observed pixels where the map puts them first, with those counts."""
    rendering = state.renderer.render(state.map_from_parts(), view.camera, view.map_from_camera, only=state.context_parts)
    owner = np.array([p.object_id or "" for p in state.scene.parts], dtype=object)
    seen = rendering.hit & view.valid
    ids, counts = np.unique(owner[rendering.part_index[seen]], return_counts=True)
    return {str(i): int(c) for i, c in zip(ids, counts) if i and c >= options.min_object_pixels}


def _upright(map_from_object: np.ndarray) -> bool:
    return bool(map_from_object[2, 2] > np.cos(np.radians(1.0)))


def _fit_large_object(
    state: FitState, coarse: FitView, fine: FitView, object_id: str, pixels: int, options: ObserveOptions
) -> ObjectReport:
    start = time.perf_counter()
    obj = state.scene.object(object_id)
    previous_pose = state.map_from_objects[object_id].copy()
    previous_joints = dict(state.joint_positions[object_id])
    planar = _upright(previous_pose)
    kernel = _kernel_m(state, fine, object_id, options)
    pose_kwargs = dict(gates_m=options.pose_gates_m, kernel_m=kernel, min_points=options.min_pose_points, planar=planar)
    background = state.background_depth(fine, object_id)
    joint_views = [(coarse, state.background_depth(coarse, object_id)), (fine, background)]
    fit = None
    fixed = state.object_parts(object_id, fixed_only=True)
    if _share_seen(state, fine, object_id, fixed, background) >= options.min_fixed_share:
        fit = refine_pose(state, fine, object_id, fixed, background, **pose_kwargs)
    joints = _joint_order(state, object_id)
    results = {joint: _fit_one_joint(state, joint_views, object_id, joint, options) for joint in joints}
    if joints:
        # Again with the turning parts at their fitted angles (a door constrains the pose
        # too; a drawer front, parallel to the body's, would trade its slide for the body's
        # shift), then the fitted joints once more, near where they are, and the others
        # searched again at the better pose.
        # The joints not fitted are searched again only after the last round, or once the
        # pose and the fitted joints have settled.
        steady = [i for i in state.object_parts(object_id) if not _slides(state, object_id, i)]
        for round_ in range(options.rounds):
            before = (state.map_from_objects[object_id].copy(), dict(state.joint_positions[object_id]))
            refined = refine_pose(state, fine, object_id, steady, background, **pose_kwargs)
            if refined is not None and refined.inlier_fraction < options.pose_gate.min_inliers:
                # Most of its points do not fit there (a body seen through its door alone, the
                # door at a wrong angle): the joints would follow the pose off.
                state.map_from_objects[object_id] = before[0]
                refined = None
            fit = refined or fit
            settled = _settled(state, object_id, *before)
            last = settled or round_ == options.rounds - 1
            for joint in joints:
                refit = results[joint][0] == "fitted"
                if refit or last:
                    results[joint] = _fit_one_joint(state, joint_views, object_id, joint, options, refit=refit)
            if last and _settled(state, object_id, *before):
                break
        if options.together:
            # The pose and the joints settled by turns still trade along what they share (the
            # body's shift and a drawer's slide): the last word is a fit of all of them at once.
            body_seen = _share_seen(state, fine, object_id, fixed, background) >= options.min_fixed_share
            min_visible = options.together_min_visible if body_seen else options.together_min_visible_unseen_body
            together = [j for j in joints if results[j][0] == "fitted" and not options.search(obj.node.joint(j)).detents
                        and results[j][1]["visible_fraction"] >= min_visible]
            # The other parts fitted stay where they were seen as the body moves.
            in_place = tuple(j for j in joints if results[j][0] in ("fitted", "partly seen") and j not in together)
            refine_pose_and_joints(state, fine, object_id, together, background, gates_m=options.pose_gates_m,
                                   kernel_m=kernel, planar=planar, min_points=options.min_pose_points,
                                   edge_margin_px=options.pose_gate.edge_margin_px, search_view=joint_views[0],
                                   kept_in_place=in_place)
    searched_again = _search_again(state, joint_views, object_id, joints, results, options)
    _hidden_elsewhere(state, fine, object_id, results, previous_joints, background, options)
    _turned_with_the_body(state, fine, object_id, results, background, options, previous_pose)
    doubtful = _doubtful(state, object_id, results, previous_joints, options.max_unexplained)
    _unexplained_changes(state, object_id, results, previous_joints)
    fitted_pose = state.map_from_objects[object_id].copy()  # the pose the joints were fitted at
    if doubtful:
        verdict = PoseVerdict(accepted=False, note=f"{doubtful[0]} fitted where its model explains none of its "
                                                   f"points: the pose it moved is not written")
    elif searched_again:
        # The pose was refined with that joint far off: a microwave's door found again 8 deg
        # from where it had been fitted let a pose turned 8 deg the wrong way pass the gate.
        verdict = PoseVerdict(accepted=False, note=f"{searched_again[0]} was far off as the pose was refined: "
                                                   f"the pose is not written")
    elif not joints or _share_seen(state, fine, object_id, fixed, background) >= options.min_fixed_share:
        verdict = _judged_as_written(state, fine, object_id, previous_pose, fit.inlier_fraction if fit else None,
                                     background, options, results, previous_joints)
    else:
        # Seen through its doors alone, the body may turn about a hinge as the door turns
        # back: the pose is not pinned down (a fridge seen from the front wandered 4-35 mm).
        verdict = PoseVerdict(accepted=False, note="its fixed body too little seen")
        _common_slide_off_the_drawers(state, object_id, [j for j in joints if results[j][0] in ("fitted", "partly seen")])
    if not verdict.accepted:
        # The joints keep the angles fitted at the refined pose: relative to the body the
        # parts were seen at, they are the better estimate even where the pose is in doubt.
        # Not where that pose was refused as wrong (moved by a doubtful joint or one far off,
        # or far past the map's doubt): a joint that reads differently at the kept pose is not
        # written.
        gone_wrong = past_the_doubt(state, object_id, previous_pose, options.pose_gate)
        state.map_from_objects[object_id] = previous_pose
        if doubtful or searched_again or gone_wrong:
            _same_at_the_kept_pose(state, joint_views, object_id, joints, results, previous_joints, options)
            # The view put the body elsewhere, and the map's pose is as far off as its doubt:
            # a joint is written only where the view tells the kept body from one moved by that
            # much with the part held where it was seen.
            _turned_with_the_body(state, fine, object_id, results, background, options, previous_pose, slides=True)
    # A pose written is no surer than the view pins it: a fridge seen by its side had its
    # pose refined 14-21 mm off along its freezer drawer's slide and the shut drawer
    # written 10-21 mm out.
    _joints_or_the_body(state, fine, object_id, results, previous_joints, background, options)
    _all_shut_in_a_refitted_body(state, fine, object_id, results, previous_joints, background, options, pose_kwargs,
                                 fitted_pose, previous_pose)
    report = ObjectReport(
        id=object_id,
        type=obj.node.type,
        pixels=pixels,
        map_from_object=state.map_from_objects[object_id].copy(),
        previous_map_from_object=previous_pose,
        pose_refined=verdict.accepted,
        pose_note=verdict.note,
        pose_inlier_fraction=fit.inlier_fraction if fit else 0.0,
        pose_rmse_m=fit.rmse_m if fit else float("nan"),
    )
    for joint in joints:
        fitted = results[joint]
        node_joint = obj.node.joint(joint)
        report.joints.append(
            JointReport(
                name=joint,
                type=node_joint.type,
                status=fitted[0],
                position=state.joint_positions[object_id][joint] if fitted[0] == "fitted" else previous_joints[joint],
                previous=previous_joints[joint],
                **fitted[1],
            )
        )
    report.seconds = time.perf_counter() - start
    return report


def _judged_as_written(
    state: FitState, view: FitView, object_id: str, map_from_before: np.ndarray, inlier_fraction: float | None,
    background: np.ndarray, options: ObserveOptions, results: dict[str, tuple[str, dict]], previous: dict[str, float],
) -> PoseVerdict:
    """`judge_pose` of the refined pose, and again with the joints that do not go into the
    map (partly seen) at the map's positions where their estimates differ by more than the
    targets: the pose must be the better one as the map will hold it. A fridge cut by the
    image's edge, its door 0.22 visible fitted 6 deg open (truth shut), was refined turned
    6 deg with it, the door's place kept, and written so, its door shut in the map."""
    refined = state.map_from_objects[object_id].copy()
    verdict = judge_pose(state, view, object_id, map_from_before, inlier_fraction, background, options.pose_gate)
    node = state.scene.object(object_id).node
    positions = state.joint_positions[object_id]
    unwritten = {name: previous[name] for name, (status, _) in results.items()
                 if status != "fitted" and _disagree(node, name, positions[name], previous[name])}
    if not verdict.accepted or not unwritten:
        return verdict
    with _object_at(state, object_id, refined, unwritten):
        as_written = judge_pose(state, view, object_id, map_from_before, inlier_fraction, background, options.pose_gate)
    if as_written.accepted:
        return verdict
    return PoseVerdict(accepted=False, note=f"{as_written.note} with {', '.join(unwritten)} at the map's position",
                       cost_before=as_written.cost_before, cost_after=as_written.cost_after)


# Of a fitted joint's part's points, the share its model may leave unexplained at the
# estimate for the estimate to be written off the map's position.
NEAR_NONE_EXPLAINED = 0.95


def _unexplained_changes(
    state: FitState, object_id: str, results: dict[str, tuple[str, dict]], previous: dict[str, float],
) -> None:
    """A fitted joint whose model explains almost none of its part's points at the estimate
    (over NEAR_NONE_EXPLAINED unexplained) and whose estimate is off the map's position by
    more than the targets is "ambiguous", the map's position kept: the view does not show the
    part where the estimate puts it. A glass-fronted door open 40 deg, its pane seen through,
    was best fitted where it stood out of the way, 91 deg, 0.995 of its points unexplained.
    On the real-piece sets the right fits that far unexplained (a shut fridge drawer 0.53
    visible, 0.995) were at the map's position."""
    node = state.scene.object(object_id).node
    positions = state.joint_positions[object_id]
    for name, (status, support) in list(results.items()):
        if (status == "fitted" and support["unexplained"] > NEAR_NONE_EXPLAINED
                and _disagree(node, name, positions[name], previous[name])):
            results[name] = ("ambiguous", support)
            positions[name] = previous[name]


def _search_again(
    state: FitState, views: list[tuple[FitView, np.ndarray]], object_id: str, joints: list[str],
    results: dict[str, tuple[str, dict]], options: ObserveOptions,
) -> list[str]:
    """The fitted joints that explain too few of their points (`search_again_unexplained`)
    searched over their whole range at the final pose: a minimum found more than two coarse
    steps away replaces the estimate in `results` and `state`; else the estimate stays.
    Returns the joints whose estimate was replaced."""
    node = state.scene.object(object_id).node
    replaced = []
    for joint in joints:
        status, support = results[joint]
        search = options.search(node.joint(joint))
        if status != "fitted" or search.detents or not support["unexplained"] > options.search_again_unexplained:
            continue
        before = state.joint_positions[object_id][joint]
        again = _fit_one_joint(state, views, object_id, joint, options)
        if again[0] == "fitted" and abs(state.joint_positions[object_id][joint] - before) > 2 * search.coarse_step:
            results[joint] = again
            replaced.append(joint)
        else:
            state.joint_positions[object_id][joint] = before
    return replaced


def _hidden_elsewhere(
    state: FitState, view: FitView, object_id: str, results: dict[str, tuple[str, dict]], previous: dict[str, float],
    background: np.ndarray, options: ObserveOptions,
) -> None:
    """A fitted joint whose part the camera sees through at the estimate (more than
    `search_again_unexplained` of its points behind it, after the search again) while at
    some position in its range nothing of it would be seen (nearer surfaces hide it all),
    or it would be out of the image and the view explains no worse: the view cannot tell
    where it is, and it is "ambiguous". A microwave's door behind a box that hid all of it
    was fitted at its limit, 27 deg off, where it stuck out past the box, 0.89 of its points
    seen through it; a dishwasher's flap open 80 deg, below the image, was fitted (and
    written) shut, 0.91 of its points unexplained, the flap out of the image as likely."""
    node = state.scene.object(object_id).node
    for name, (status, support) in list(results.items()):
        search = options.search(node.joint(name))
        if status != "fitted" or search.detents or not support["unexplained"] > options.search_again_unexplained:
            continue
        moving = state.moving_parts(object_id, name)
        static = static_depth(state, view, background, object_id, moving)
        estimate = state.joint_positions[object_id][name]
        values = np.append(position_grid(*joint_range(state, object_id, name), search.coarse_step), estimate)
        own = moving_depths(state, view, object_id, name, moving, values)
        with np.errstate(invalid="ignore"):
            in_sight = (own < static) & ~(np.isfinite(view.depth_m) & (view.depth_m < own - view.tolerance_m))
        in_image, seen = (counts.reshape(len(values), -1).sum(axis=1) for counts in (np.isfinite(own), in_sight))
        hidden = np.any((in_image >= options.min_joint_pixels) & (seen < options.min_joint_pixels))
        out = in_image < options.min_joint_pixels
        costs = stack_costs(view, static, own) if out.any() else None
        if hidden or (costs is not None and costs[out].min() < costs[-1] + options.min_contrast):
            results[name] = ("ambiguous", support)
            state.joint_positions[object_id][name] = previous[name]


# A joint read at two poses agrees when its estimates differ by no more than the issue's
# targets: 2 deg for a hinge, 5 mm for a slide.
AGREE_RAD, AGREE_M = np.radians(2.0), 0.005


def _disagree(node: Jointed, joint: str, position: float, other: float) -> bool:
    """Whether two positions of the node's joint differ by more than its target (AGREE_*)."""
    return abs(position - other) > (AGREE_M if node.joint(joint).type == "prismatic" else AGREE_RAD)


def _same_at_the_kept_pose(
    state: FitState, views: list[tuple[FitView, np.ndarray]], object_id: str, joints: list[str],
    results: dict[str, tuple[str, dict]], previous: dict[str, float], options: ObserveOptions,
) -> None:
    """Each fitted joint searched again with the object at its kept (map) pose: one that
    reads differently there than at the refused pose depends on which pose is right, so it
    is "ambiguous" and put back at the map's position (a wardrobe whose doubtful door took
    its body 62 mm off had its drawers written 63 mm out at that pose)."""
    node = state.scene.object(object_id).node
    for joint in joints:
        if results[joint][0] != "fitted":
            continue
        before = state.joint_positions[object_id][joint]
        _fit_one_joint(state, views, object_id, joint, options)
        if _disagree(node, joint, state.joint_positions[object_id][joint], before):
            results[joint] = ("ambiguous", results[joint][1])
            state.joint_positions[object_id][joint] = previous[joint]
        else:
            state.joint_positions[object_id][joint] = before


def _joints_or_the_body(
    state: FitState, view: FitView, object_id: str, results: dict[str, tuple[str, dict]], previous: dict[str, float],
    background: np.ndarray, options: ObserveOptions,
) -> None:
    """Whether its pose is written or not, an object's place is known only so well (the
    map's doubt; a refined pose no better than its view pins it): its drawers all out
    along one axis by at least some slide no more than that (POSE_DOUBT_M), or a door open
    by no more than twice the map's turn (about its hinge, off the origin),
    may as well be that much less out, or shut, in a body moved by as much along the slide
    or about the hinge. Where the depth says so (that body, those parts, explain it no worse
    than `min_contrast`), the joints are "ambiguous" and keep the map's positions: a fridge
    seen by its side had its shut freezer drawer written 7-23 mm out in 7 of 60 views, its
    shut door 2.2-3.1 deg open in 4, the body's error; a wardrobe's two drawers, one shut,
    both 15 mm out. A joint off by no more than the targets (AGREE_M, AGREE_RAD) is right
    either way."""
    node = state.scene.object(object_id).node
    model = state.scene.object(object_id).model
    positions = state.joint_positions[object_id]
    # A drawer partly seen keeps its estimate in the fit and moves with the others.
    candidates = [name for name, (status, _) in results.items() if status in ("fitted", "partly seen")
                  and node.joint(name).limits is not None and model.joint(name).parent == model.root_link]
    groups: list[list[str]] = []  # each: the joints one move of the body would take up
    for name in candidates:
        joint = node.joint(name)
        if joint.type != "prismatic":
            groups.append([name])
            continue
        direction = _slide_direction(joint)
        for group in groups:
            other = node.joint(group[0])
            if other.type == "prismatic" and direction @ _slide_direction(other) > ONE_AXIS_COS:
                group.append(name)
                break
        else:
            groups.append([name])
    parts = state.object_parts(object_id)
    for group in groups:
        if all(results[name][0] != "fitted" for name in group):
            continue
        offs = {name: positions[name] - node.joint(name).limits[0] for name in group}
        reference = min(offs, key=offs.get)
        agree, reach = (AGREE_M, POSE_DOUBT_M) if node.joint(reference).type == "prismatic" else (AGREE_RAD, 2 * DOUBT_RAD)
        if not agree < offs[reference] <= reach:
            continue
        less = {**positions, **{name: positions[name] - offs[reference] for name in group}}
        as_fitted = _object_depth(state, view, parts)
        with _object_at(state, object_id, state.map_from_objects[object_id] @ _holding(state, object_id, reference, less),
                        less):
            body_moved = _object_depth(state, view, parts)
        fitted_cost, moved_cost = scene_costs(view, [as_fitted, body_moved], background)
        if moved_cost <= fitted_cost + options.min_contrast:
            for name in group:
                if results[name][0] == "fitted":
                    results[name] = ("ambiguous", results[name][1])
                    positions[name] = previous[name]


@contextmanager
def _object_at(state: FitState, object_id: str, map_from_object: np.ndarray, positions: dict[str, float]) -> Iterator[None]:
    """The object at `map_from_object`, its joints at `positions`, for the block: a hypothesis
    rendered or judged; then back as it was."""
    pose, joints = state.map_from_objects[object_id].copy(), dict(state.joint_positions[object_id])
    state.map_from_objects[object_id] = map_from_object
    state.joint_positions[object_id].update(positions)
    try:
        yield
    finally:
        state.map_from_objects[object_id] = pose
        state.joint_positions[object_id].update(joints)


def _holding(state: FitState, object_id: str, joint: str, positions: dict[str, float]) -> np.ndarray:
    """The body's move (object from moved object) that keeps `joint`'s part where it is now
    when the joints go to `positions`: the body turned about a hinge, or slid along a slide."""
    child = state.scene.object(object_id).model.joint(joint).child
    return state.object_from_links(object_id)[child] @ np.linalg.inv(state.object_from_links(object_id, positions)[child])


# The turns of the body about a door's hinge tried against its fitted angle: past the 2 deg
# target, and twice the map's doubt.
HINGE_TURNS_RAD = (np.radians(2.5), 2 * DOUBT_RAD)
# The body's shifts along a drawer's slide tried against its fitted slide, at a pose the map
# keeps: past the 5 mm target, and the map's doubt about a large object's place.
SLIDE_SHIFTS_M = (2 * AGREE_M, POSE_DOUBT_M)


def _turned_with_the_body(
    state: FitState, view: FitView, object_id: str, results: dict[str, tuple[str, dict]], background: np.ndarray,
    options: ObserveOptions, map_from_before: np.ndarray, *, slides: bool = False,
) -> None:
    """A door's angle is no surer than its body's turn: the body turned about the hinge by
    HINGE_TURNS_RAD either way (within twice the map's doubt of `map_from_before`), the door
    turned back by as much, leaves the door where it was seen. Only the body's pixels can
    tell the two apart: where on those one of them explains the depth no worse than the fit
    (`min_contrast`, `min_contrast_pixels`), the door's angle off by more than the target
    explains it as well, and it is "ambiguous". A fridge seen through its door, its body
    little seen, was fitted turned 3.6-4 deg the wrong way, its door written as much open;
    turned back 2.5 deg it explained the depth better (0.31-0.45 of the body's pixels).
    The estimate stays in the fit, as a part partly seen does: within a few degrees, it is
    nearer than the map's for the objects fitted after (a cupboard's door put back 20 deg
    off the seen one turned the fridge beside it 3.2 deg the wrong way, then written).
    With `slides` (at the map's pose, kept where the view put the body past its doubt), a
    drawer's slide likewise, the body shifted along it by SLIDE_SHIFTS_M: a bedside table kept
    at the map's pose 24 mm off had its drawer written 29 mm short, the body's error."""
    node = state.scene.object(object_id).node
    model = state.scene.object(object_id).model
    positions = state.joint_positions[object_id]
    parts = state.object_parts(object_id)
    for name, (status, _) in list(results.items()):
        joint = node.joint(name)
        moves = SLIDE_SHIFTS_M if joint.type == "prismatic" else HINGE_TURNS_RAD
        if (status != "fitted" or (joint.type == "prismatic" and not slides) or joint.limits is None
                or model.joint(name).parent != model.root_link or options.search(joint).detents):
            continue
        as_fitted = np.minimum(_object_depth(state, view, parts), background)
        for move in (sign * m for m in moves for sign in (-1.0, 1.0)):
            back = {**positions, name: positions[name] - move}
            if not joint.limits[0] <= back[name] <= joint.limits[1]:
                continue
            with _object_at(state, object_id, state.map_from_objects[object_id] @ _holding(state, object_id, name, back),
                            back):
                moved = None if past_the_doubt(state, object_id, map_from_before, options.pose_gate) else \
                    np.minimum(_object_depth(state, view, parts), background)
            if moved is not None and not _told_apart(view, as_fitted, moved, background, options):
                results[name] = ("ambiguous", results[name][1])
                break


# Renderings nearer than this to each other show the same surface there.
SAME_SURFACE_M = 0.002


def _told_apart(view: FitView, fitted: np.ndarray, other: np.ndarray, background: np.ndarray,
                options: ObserveOptions) -> bool:
    """Whether the object rendered at `fitted` explains the depth better than at `other` (both
    in front of `background`) on the pixels where they differ, by `min_contrast` of them and
    `min_contrast_pixels` pixels' worth."""
    with np.errstate(invalid="ignore"):  # inf - inf where neither hits and nothing is behind: not the same surface
        differ = ((fitted < background) | (other < background)) & ~(np.abs(fitted - other) < SAME_SURFACE_M)
    fitted_cost, other_cost = depth_costs(view, [fitted, other], differ)
    contrast = other_cost - fitted_cost
    return bool(contrast > options.min_contrast and contrast * differ.sum() >= options.min_contrast_pixels)


def _all_shut_in_a_refitted_body(
    state: FitState, view: FitView, object_id: str, results: dict[str, tuple[str, dict]], previous: dict[str, float],
    background: np.ndarray, options: ObserveOptions, pose_kwargs: dict, map_from_fitted: np.ndarray,
    map_from_before: np.ndarray,
) -> None:
    """An object's parts near shut, or fitted where their model explains too few of their
    points (`search_again_unexplained`), may all be shut in a body elsewhere within twice
    the map's doubt (`past_the_doubt`) of its pose, written or kept: one
    hypothesis for all of them, the body refitted (ICP) with them shut. Where that explains
    the depth no worse (`min_contrast`), those written off shut by more than the targets are
    "ambiguous". A door and a drawer pin each other, so the one-part-at-a-time test
    (`_joints_or_the_body`) misses them: a fridge kept at the map's 2 deg turn had its shut
    door written 2.8-5.2 deg open and its shut freezer drawer 11.5-15 mm out; a fridge's shut
    door with a bar handle, 2 cm off, 0.76 unexplained at its best, 54 deg open.
    The refit may not find that body (a fridge seen through its drawer and a sliver of its
    door, refitted with them shut, drifted into the oven beside it): so the body that holds
    each of those parts, shut, where it was fitted (at `map_from_fitted`, within twice the
    map's doubt of `map_from_before`) is tried too; its shut drawer was written 11-13 mm out."""
    node = state.scene.object(object_id).node
    model = state.scene.object(object_id).model
    positions = state.joint_positions[object_id]

    def off(name: str) -> float:
        return positions[name] - node.joint(name).limits[0]

    def reach(name: str) -> tuple[float, float]:  # (right either way, as far as the body's error takes it)
        return (AGREE_M, NEAR_SHUT_M) if node.joint(name).type == "prismatic" else (AGREE_RAD, NEAR_SHUT_RAD)

    near = [name for name, (status, support) in results.items() if status in ("fitted", "partly seen")
            and node.joint(name).limits is not None and model.joint(name).parent == model.root_link
            and 0.0 < off(name) and (off(name) <= reach(name)[1] or support["unexplained"] > options.search_again_unexplained)]
    written_off = [name for name in near if results[name][0] == "fitted" and off(name) > reach(name)[0]]
    if not written_off:
        return
    # Both with the body refitted the same way: the shut parts are judged, not the pose.
    as_fitted, _ = _refitted_depth(state, view, object_id, background, options, pose_kwargs)
    shut = {**positions, **{name: node.joint(name).limits[0] for name in near}}
    with _object_at(state, object_id, state.map_from_objects[object_id], shut):
        all_shut, within = _refitted_depth(state, view, object_id, background, options, pose_kwargs)
    hypotheses = [all_shut] if within else []
    for name in near:
        with _object_at(state, object_id, map_from_fitted @ _holding(state, object_id, name, shut), shut):
            if not past_the_doubt(state, object_id, map_from_before, options.pose_gate):
                hypotheses.append(_object_depth(state, view, state.object_parts(object_id)))
    if not hypotheses:
        return
    fitted_cost, *shut_costs = scene_costs(view, [as_fitted, *hypotheses], background)
    if min(shut_costs) <= fitted_cost + options.min_contrast:
        for name in written_off:
            results[name] = ("ambiguous", results[name][1])
            positions[name] = previous[name]


def _refitted_depth(
    state: FitState, view: FitView, object_id: str, background: np.ndarray, options: ObserveOptions, pose_kwargs: dict,
) -> tuple[np.ndarray, bool]:
    """The object's depth with its body refitted (ICP of all its parts at their current
    joints, from its current pose, left unchanged), and whether that refit stays within twice
    the map's doubt."""
    parts = state.object_parts(object_id)
    pose = state.map_from_objects[object_id].copy()
    refits = 0
    for _ in range(options.rounds):  # ICP from 2 cm off takes a few rounds to settle
        before = state.map_from_objects[object_id].copy()
        if refine_pose(state, view, object_id, parts, background, **pose_kwargs) is None:
            break
        refits += 1
        if _settled(state, object_id, before, {}):
            break
    within = refits > 0 and not past_the_doubt(state, object_id, pose, options.pose_gate)
    depth = _object_depth(state, view, parts)
    state.map_from_objects[object_id] = pose
    return depth, within


# A part this near shut may be shut in a body within twice the map's doubt: a door by its
# turn and the shift across its width (2 x 2 cm over 60 cm turns its front about 2 deg), a
# drawer by the shift and the turn's swing at its front (a fridge's shut drawer was written
# 32 mm out, its pose refined along the view only).
NEAR_SHUT_RAD, NEAR_SHUT_M = 3 * DOUBT_RAD, 2 * POSE_DOUBT_M


def _doubtful(state: FitState, object_id: str, results: dict[str, tuple[str, dict]], previous: dict[str, float],
              max_unexplained: float) -> list[str]:
    """The fitted joints whose model, at the estimate, leaves more than `max_unexplained` of
    their part's points unexplained: marked "doubtful" in `results` and put back at the map's
    position (a wrong value written is worse than "not seen")."""
    doubtful = [name for name, (status, support) in results.items()
                if status == "fitted" and support["unexplained"] > max_unexplained]
    for name in doubtful:
        results[name] = ("doubtful", results[name][1])
        state.joint_positions[object_id][name] = previous[name]
    return doubtful


# A round that moves the pose and the joints less than these changes nothing that matters.
SETTLED_M = 0.0005
SETTLED_RAD = np.radians(0.1)


def _settled(state: FitState, object_id: str, map_from_object: np.ndarray, joints: dict[str, float]) -> bool:
    """Whether the object's pose and joints are where they were (`map_from_object`, `joints`)."""
    change = np.linalg.inv(map_from_object) @ state.map_from_objects[object_id]
    turned = np.arccos(np.clip((np.trace(change[:3, :3]) - 1) / 2, -1.0, 1.0))
    node = state.scene.object(object_id).node
    moved = [
        abs(state.joint_positions[object_id][name] - value) / (SETTLED_M if node.joint(name).type == "prismatic" else SETTLED_RAD)
        for name, value in joints.items()
    ]
    return bool(np.linalg.norm(change[:3, 3]) < SETTLED_M and turned < SETTLED_RAD and max(moved, default=0.0) < 1.0)


def _common_slide_off_the_drawers(state: FitState, object_id: str, fitted: list[str]) -> None:
    """Seen through its drawers alone (a chest of drawers from the front), the body's depth
    trades with every slide at once: where two or more drawers along one axis all come out,
    the least by no more than the map's doubt about the body's place, that common slide is
    the body's error, not every drawer ajar by the same (each 9-11 mm out, one of them
    shut): it is taken off the slides. The body's pose, which this view does not pin, stays
    the map's (the caller writes no pose for it)."""
    node = state.scene.object(object_id).node
    slides: dict[str, tuple[np.ndarray, float]] = {}
    for name in fitted:
        joint = node.joint(name)
        if joint.type == "prismatic" and joint.limits is not None:
            slides[name] = (_slide_direction(joint), state.joint_positions[object_id][name] - joint.limits[0])
    if len(slides) < 2:
        return
    directions = np.array([d for d, _ in slides.values()])
    common = min(s for _, s in slides.values())
    if np.any(directions @ directions[0] < ONE_AXIS_COS) or not 0.0 < common <= POSE_DOUBT_M:
        return
    for name in slides:
        state.joint_positions[object_id][name] -= common


# Slides within 5 deg of one another move along one axis: a move of the body takes up all of them.
ONE_AXIS_COS = np.cos(np.radians(5.0))


def _slide_direction(joint: ObjectJoint) -> np.ndarray:
    """A prismatic joint's direction of travel in its object's frame."""
    return joint.object_from_joint.matrix()[:3, :3] @ np.asarray(joint.axis, dtype=float)


def _slides(state: FitState, object_id: str, part: int) -> bool:
    """Whether a prismatic joint carries the part."""
    model = state.scene.object(object_id).model
    parent_joint = {j.child: j for j in model.joints}
    link = state.scene.parts[part].link
    while link in parent_joint:
        if parent_joint[link].type == "prismatic":
            return True
        link = parent_joint[link].parent
    return False


def _share_seen(state: FitState, view: FitView, object_id: str, parts: list[int], background: np.ndarray) -> float:
    """The share of the object's observed pixels (at the current joint estimates) that `parts` cover."""
    whole = _object_depth(state, view, state.object_parts(object_id))
    seen = np.isfinite(whole) & (whole < background) & view.valid
    return float((_object_depth(state, view, parts)[seen] <= whole[seen]).mean()) if seen.any() else 0.0


def _kernel_m(state: FitState, view: FitView, object_id: str, options: ObserveOptions) -> float:
    """The robust kernel's width for an object: the tolerance at its median observed depth."""
    whole = _object_depth(state, view, state.object_parts(object_id))
    tolerance = view.tolerance_m[np.isfinite(whole) & view.valid]
    return float(np.median(tolerance)) if tolerance.size else options.min_tolerance_m


def _object_depth(state: FitState, view: FitView, parts: list[int]) -> np.ndarray:
    """Depth of `parts` at the current estimates (inf where none is hit)."""
    return state.renderer.depth(state.map_from_parts(), view.camera, view.map_from_camera, parts)


def _joint_order(state: FitState, object_id: str) -> list[str]:
    """The object's movable joints, each after the joints that carry it."""
    obj = state.scene.object(object_id)
    if not isinstance(obj.node, Jointed):
        return []
    model = obj.model
    parent_joint = {j.child: j for j in model.joints}

    def depth(joint_name: str) -> int:
        link, count = model.joint(joint_name).parent, 0
        while link in parent_joint:
            link, count = parent_joint[link].parent, count + 1
        return count

    names = [j.name for j in obj.node.joints]
    return sorted(names, key=depth)


def _fit_one_joint(
    state: FitState,
    views: list[tuple[FitView, np.ndarray]],
    object_id: str,
    joint: str,
    options: ObserveOptions,
    *,
    refit: bool = False,
) -> tuple[str, dict]:
    """(status, support figures); the estimate stays in `state` when fitted or partly seen. A `refit`
    searches near the current estimate only."""
    before = state.joint_positions[object_id][joint]
    node_joint = state.scene.object(object_id).node.joint(joint)
    fit = fit_joint(state, views, object_id, joint, options.search(node_joint), near=before if refit else None)
    if fit is None:
        return "not seen", {}
    support = {"visible_fraction": fit.visible_fraction, "residual_m": fit.residual_m, "unexplained": fit.unexplained,
               "pixels": fit.pixels,
               "estimate": state.joint_positions[object_id][joint]}
    status = "fitted"
    if fit.visible_fraction < options.min_visible_fraction or fit.pixels < options.min_joint_pixels:
        status = "not seen"
    elif not refit and (fit.contrast < options.min_contrast or fit.contrast * fit.pixels < options.min_contrast_pixels):
        status = "ambiguous"
    elif fit.visible_fraction < options.min_confident_fraction:
        status = "partly seen"
    # A part partly seen keeps its estimate while the object is fitted (the scene is nearer
    # the truth with it than with the map's position) but does not go into the map.
    if status in ("not seen", "ambiguous"):
        state.joint_positions[object_id][joint] = before
    return status, support


def _updated_map(scene: HomeScene, state: FitState, reports: list[ObjectReport], at: datetime) -> SemanticMap:
    """The map with what was seen: refined large-object poses, fitted joints, found small objects."""
    smap = scene.smap
    for report in reports:
        if report.pose_refined:
            smap.update_pose(report.id, report.map_from_object, at)
        for joint in report.joints:
            if joint.status == "fitted" and joint.position != joint.previous:
                node = smap.node(report.id)
                assert isinstance(node, LargeObject) and isinstance(node, Jointed)
                smap.set_joint_state(report.id, joint.name, float(np.clip(joint.position, *_limits(node, joint.name))), at)
    found = {s.id: s for report in reports for s in report.small_objects if s.status == "found"}
    for small in found.values():
        if small.parent == small.previous_parent:
            smap.update_pose(small.id, small.parent_from_object, at)
        else:
            smap.move_object(small.id, parent_id=small.parent, relation=small.relation,
                             parent_from_object=small.parent_from_object, time=at)
    return smap


def _limits(node: Jointed, joint: str) -> tuple[float, float]:
    limits = node.joint(joint).limits
    return (-np.pi, np.pi) if limits is None else limits


def write_observed(result: ObserveResult, map_path: Path, out_path: Path, report_path: Path | None = None) -> None:
    """Save the updated map as `out_path`, its model references rewritten relative to the new
    file's folder, and the report JSON; each atomically, replacing what is there (the robot
    writes each observation's map over the last, or over `map_path` itself)."""
    from homemodel.core.atomic import write_json
    from homemodel.exchange.map_xml import save_map

    out_path, map_path = Path(out_path), Path(map_path)
    rebase_model_refs(result.smap, map_path, out_path)
    save_map(result.smap, out_path)
    if report_path is not None:
        write_json(Path(report_path), result.report.to_json())


def rebase_model_refs(smap: SemanticMap, map_path: Path, out_path: Path) -> None:
    """Make the model references of `smap`, read from `map_path`, relative to `out_path`'s
    folder, so the map still finds its models when saved there."""
    import os

    for node in smap.objects():
        if node.model_ref is not None:
            model = (Path(map_path).parent / node.model_ref).resolve()
            node.model_ref = Path(os.path.relpath(model, Path(out_path).resolve().parent)).as_posix()
