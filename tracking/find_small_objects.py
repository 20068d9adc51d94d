"""Small objects looked for on the surfaces of the large objects in view.

Once the large objects are fitted, the observed points the rendered scene does not explain
(in front of it by more than the tolerance) and that stand on an upward surface of a large
object in view are clustered. Each small object whose parent is in view is first looked for
in the clusters on its parent near its map pose, then, if not there, in any other cluster
that stands clear of the large objects' sides (it has moved: the cup from the table to the
worktop). A candidate is its own model placed
on the cluster's surface, tried at several yaws, each refined by ICP in x, y and yaw, then
moved down the misfit in x and y (ICP slides a flat object along its support); it is
accepted only if the model explains most of its visible pixels and of the cluster's points,
no place 2 cm off explains them as well (the view pins the place), and its own relief
explains them clearly better than a flat slab would (a plate fits any flat thing).
Its yaw is written only when the view pins it (the cup's handle seen); otherwise the map's
is kept, or the nearest the view allows, and the report says "yaw not seen".
Otherwise the object is "not found" (its map place is in view and empty) or "not seen" (that
place is out of view or covered), never guessed.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TypeGuard

import numpy as np
import trimesh

from homemodel.core.checks import require_between, require_positive
from homemodel.geometry.open3d_loader import load_open3d
from semantic_map.nodes import SmallObject
from tracking.fit_pose import fit_quality, icp_correction, yaw_of
from tracking.fit_state import FitState
from tracking.fit_view import FitView, chromaticity
from tracking.report import SmallObjectReport
from tracking.scene import SceneObject, box_corners


# A small object stands at most this high on its surface.
MAX_HEIGHT_M = 0.35


@dataclass(kw_only=True)
class SmallObjectSearch:
    """How small objects are looked for."""

    search_radius_m: float = 0.5  # around the map pose, on the parent: the object has not moved
    yaw_candidates: int = 8
    sure: float = 0.97  # a candidate explaining this much of both ends the search
    max_colour_difference: float = 0.12  # L1 distance of chromaticities, when there is a colour image
    cluster_gap_m: float = 0.02  # points closer than this belong to one cluster
    min_cluster_points: int = 15  # full-resolution points
    min_explained: float = 0.6  # of the model's visible pixels, observed where it renders them
    min_cluster_explained: float = 0.5  # of the cluster's points, within the tolerance of the model
    gates_m: tuple[float, ...] = (0.05, 0.03, 0.015)
    yaw_checks: int = 48  # yaws the found object is judged at, to tell whether the view pins its yaw
    min_yaw_turn: float = np.radians(20)
    yaw_margin: float = 0.015  # of the cluster's points: a misfit this close to the least is as good
    settle_steps_m: tuple[float, ...] = (0.02, 0.01, 0.005)  # the misfit's descent after ICP, in x and y
    pinned_shift_m: float = 0.02  # a place this far off explaining the view as well: the view pins none
    max_flat_cost: float = 0.8  # of a flat slab's: the model's own relief must explain the view better
    # Of an object's visible pixels, the share read with nothing in front for a moved one to be
    # written there, or for its place in the map to be judged empty (`_place_in_view`).
    min_uncovered: float = 0.5

    def check(self) -> None:
        for name in ("search_radius_m", "yaw_candidates", "cluster_gap_m", "min_cluster_points", "yaw_checks",
                     "min_yaw_turn", "pinned_shift_m"):
            require_positive(name, getattr(self, name))
        for step in self.settle_steps_m:
            require_positive("settle_steps_m", step)
        for name in ("min_explained", "min_cluster_explained", "sure", "max_colour_difference", "yaw_margin",
                     "max_flat_cost", "min_uncovered"):
            require_between(name, getattr(self, name), 0.0, 1.0)


@dataclass(kw_only=True)
class _Cluster:
    points: np.ndarray  # (N, 3) map frame
    owner: str  # the large object whose surface it stands on
    height_m: float  # of that surface, map frame
    relation: str  # "on" its top, "in" it (a shelf)
    used: bool = False

    @property
    def centre_xy(self) -> np.ndarray:
        return self.points[:, :2].mean(axis=0)


@dataclass(kw_only=True)
class _Candidate:
    map_from_object: np.ndarray
    explained: float
    cluster_explained: float
    rmse_m: float
    misfit: int  # model pixels seen empty plus cluster points the model leaves unexplained
    kernel_m: float  # the tolerance it was judged with
    # L1 distance of the seen and the model's mean chromaticities (0 without a colour image)
    colour_difference: float = 0.0
    yaw_seen: bool = True
    uncovered: float = 1.0  # of the model's visible pixels, those read and with nothing in front

    @property
    def score(self) -> float:
        return min(self.explained, self.cluster_explained)


def find_small_objects(
    state: FitState, full: FitView, in_view: list[str], search: SmallObjectSearch
) -> list[SmallObjectReport]:
    """A report for each small object whose parent is in view, and for each found on an
    object in view though its parent is not; found ones get their pose in `state`."""
    smalls = [obj for obj in state.scene.objects.values() if isinstance(obj.node, SmallObject)]
    if not smalls or not in_view:
        return []
    faces = {owner: _faces(state, owner) for owner in in_view}
    surfaces = {owner: (triangles[up], top) for owner, (triangles, up, top) in faces.items() if up.any()}
    clusters = _clusters(state, full, surfaces, search)
    off_sides = _off_their_sides(list(faces.values()), clusters)
    bounds = {obj.id: obj.model.world_mesh().bounds for obj in smalls}
    reports: dict[str, SmallObjectReport] = {}
    tried: set[tuple[int, str]] = set()  # (cluster index, object id) fitted and not taken
    # Where the map has them first, for all of them; then the moved ones anywhere else (an
    # object whose parent is out of view can only have moved into view). Twice: a place
    # another object held is free once that one is found elsewhere (two objects swapped).
    for moved in (False, True) * 2:
        for obj in smalls:
            if obj.id in reports or (not moved and obj.node.parent not in in_view):
                continue
            home = state.map_from_objects[obj.id][:2, 3]
            size = bounds[obj.id][1] - bounds[obj.id][0]
            # A moved object must stand clear of the large objects' sides: a wrong move is
            # written as a new parent, and their own surfaces seen off their estimates are
            # no small object (`--seed 3` of the bench put the sugar container on a fridge's
            # shelf twice, its body 38 mm off).
            # Nor onto another's place in the map while that one is not found and not yet
            # fitted to it: the points there are that object's as likely (a bowl taken away
            # was "found" on a cup and a pill box beside it, the cup's cluster too wide for the
            # cup alone). Once that one's fit failed there, they are not (two objects that
            # swapped places).
            others = [o for o in smalls if o.id != obj.id and o.id not in reports]
            choices = [
                (k, c) for k, (c, clear) in enumerate(zip(clusters, off_sides))
                if not c.used and (k, obj.id) not in tried and _fits(c, size) and (clear or not moved)
                and (c.owner == obj.node.parent and np.linalg.norm(c.centre_xy - home) < search.search_radius_m) != moved
                and not any(_holds_the_place(state, c, other) and (k, other.id) not in tried for other in others)
            ]
            choices.sort(key=lambda choice: np.linalg.norm(choice[1].centre_xy - home))
            for k, cluster in choices:
                candidate = _fit_on_cluster(state, full, obj.id, bounds[obj.id], cluster, search)
                # A moved object is written only where the view shows most of it: behind things
                # the map does not have, the few pixels left fit anything (check26b's cup 'found'
                # on the cooker behind a toaster, 2.6 m from where it stood: 0.46 of it uncovered).
                if candidate is None or (moved and candidate.uncovered < search.min_uncovered):
                    tried.add((k, obj.id))
                    continue
                cluster.used = True
                state.map_from_objects[obj.id] = candidate.map_from_object
                parent_from_object = np.linalg.inv(state.map_from_objects[cluster.owner]) @ candidate.map_from_object
                reports[obj.id] = SmallObjectReport(
                    id=obj.id, status="found", parent=cluster.owner, previous_parent=obj.node.parent,
                    relation=cluster.relation if cluster.owner != obj.node.parent else obj.node.relation,
                    map_from_object=candidate.map_from_object, parent_from_object=parent_from_object,
                    inlier_fraction=candidate.explained, rmse_m=candidate.rmse_m, yaw_seen=candidate.yaw_seen,
                )
                break
    for obj in smalls:
        if obj.id not in reports and obj.node.parent in in_view:
            # Points standing at its place that no fit took are not an empty place.
            held = any(not c.used and _holds_the_place(state, c, obj) for c in clusters)
            status = "not found" if not held and _place_in_view(state, full, obj.id, bounds[obj.id], search) else "not seen"
            reports[obj.id] = SmallObjectReport(id=obj.id, status=status, parent=obj.node.parent,
                                                previous_parent=obj.node.parent, relation=obj.node.relation)
    return [reports[obj.id] for obj in smalls if obj.id in reports]


def _holds_the_place(state: FitState, cluster: _Cluster, obj: SceneObject) -> bool:
    """Whether the cluster stands on the object's parent over the object's place in the map."""
    low, high = cluster.points[:, :2].min(axis=0), cluster.points[:, :2].max(axis=0)
    place = state.map_from_objects[obj.id][:2, 3]
    return cluster.owner == obj.node.parent and bool(np.all((low <= place) & (place <= high)))


def _fits(cluster: _Cluster, size_m: np.ndarray, margin_m: float = 0.05) -> bool:
    """Whether the cluster could be the object: no wider than its footprint's diagonal, no
    taller than it (a box in front of a cupboard is not a cup)."""
    low, high = cluster.points.min(axis=0), cluster.points.max(axis=0)
    wide = np.hypot(*size_m[:2]) + margin_m
    return bool((high[:2] - low[:2] <= wide).all() and high[2] - cluster.height_m <= size_m[2] + margin_m)


def _render_object(state: FitState, view: FitView, object_id: str, map_from_object: np.ndarray):
    saved = state.map_from_objects[object_id]
    state.map_from_objects[object_id] = map_from_object
    try:
        return state.renderer.render(
            state.map_from_parts(), view.camera, view.map_from_camera, only=state.object_parts(object_id)
        )
    finally:
        state.map_from_objects[object_id] = saved


def _faces(state: FitState, object_id: str) -> tuple[np.ndarray, np.ndarray, float]:
    """(F, 3, 3) map-frame triangles of the object's parts at its estimates, (F,) whether each
    faces up, and the object's top height."""
    poses = state.map_from_parts()
    triangles, up, top = [], [], -np.inf
    for i in state.object_parts(object_id):
        part = state.scene.parts[i]
        vertices = part.vertices_link @ poses[i][:3, :3].T + poses[i][:3, 3]
        tri = vertices[part.faces]
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        length = np.linalg.norm(normal, axis=1)
        proper = length > 1e-12
        triangles.append(tri[proper])
        up.append(normal[proper, 2] > 0.97 * length[proper])
        top = max(top, float(vertices[:, 2].max()))
    if not triangles:
        return np.empty((0, 3, 3)), np.empty(0, dtype=bool), top
    return np.concatenate(triangles), np.concatenate(up), top


# How far off its estimate a large object may be seen: the map's pose 2-3 cm off, kept when
# the view does not pin it down.
POSE_DOUBT_M = 0.03


def _off_their_sides(faces: list[tuple[np.ndarray, np.ndarray, float]], clusters: list[_Cluster]) -> list[bool]:
    """Whether each cluster lies, by the median of its points, farther than POSE_DOUBT_M from
    the faces of the large objects in view (their `_faces`) that do not face up (fronts, sides,
    backs and the undersides of shelves and tops): nearer, it is as well one of
    them seen a little off its estimate (an oven kept 2 cm off showed its three knobs and two
    edges as six clusters standing on its surfaces, each then searched for every small object)."""
    from homemodel.geometry.raycast import RayCaster

    sides = np.concatenate([triangles[~up] for triangles, up, _ in faces])
    if not len(sides) or not clusters:
        return [True] * len(clusters)
    caster = RayCaster(trimesh.Trimesh(sides.reshape(-1, 3), np.arange(3 * len(sides)).reshape(-1, 3), process=False))
    return [bool(np.median(caster.distances(c.points)) > POSE_DOUBT_M) for c in clusters]


def _scene_depth(state: FitState, view: FitView) -> np.ndarray:
    """Depth of the large objects, floor and walls at their estimates in `view` (a window)."""
    return state.renderer.depth(state.map_from_parts(), view.camera, view.map_from_camera, state.context_parts)


def _support_heights(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(N,) height of the highest of the upward `triangles` 3 mm to MAX_HEIGHT_M below each
    point (NaN where there is none): a ray cast straight down from each point."""
    from homemodel.geometry.raycast import RayCaster

    mesh = trimesh.Trimesh(triangles.reshape(-1, 3), np.arange(3 * len(triangles)).reshape(-1, 3), process=False)
    hits = RayCaster(mesh).first_hits(points - [0.0, 0.0, 0.003], np.array([0.0, 0.0, -1.0]))
    heights = triangles[:, :, 2].mean(axis=1)
    found = hits.hit & (hits.t < MAX_HEIGHT_M - 0.003)
    return np.where(found, heights[np.maximum(hits.triangle, 0)], np.nan)


def _clusters(
    state: FitState, full: FitView, surfaces: dict[str, tuple[np.ndarray, float]], search: SmallObjectSearch
) -> list[_Cluster]:
    """Clusters of unexplained points standing on an upward surface (`surfaces`: the
    triangles and top height of each object in view). The scene is rendered only at the
    pixels of the points that stand on a surface: what the rest shows is no small object."""
    o3d = load_open3d()

    if not surfaces:
        return []
    corners = np.concatenate([_space_above(triangles) for triangles, _ in surfaces.values()])
    window = full.around(box_corners(corners))
    if window is None:
        return []
    view = window[0]
    v, u = np.nonzero(view.valid)
    points = view.points_map(view.depth_m, view.valid)
    clusters: list[_Cluster] = []
    for owner, (triangles, top) in surfaces.items():
        low, high = _space_above(triangles)
        inside = np.flatnonzero(((points > low) & (points < high)).all(axis=1))
        support = _support_heights(points[inside], triangles) if len(inside) else np.empty(0)
        inside, support = inside[np.isfinite(support)], support[np.isfinite(support)]
        if len(inside) < search.min_cluster_points:
            continue
        rows = slice(int(v[inside].min()), int(v[inside].max()) + 1)
        columns = slice(int(u[inside].min()), int(u[inside].max()) + 1)
        crop = view.crop(rows, columns)
        # Cast at those points' pixels alone, not their whole window (the oven at 1.2 m: 45k of 136k).
        pixels = (v[inside] - rows.start) * crop.camera.width + (u[inside] - columns.start)
        scene_depth = state.renderer.depth_at(state.map_from_parts(), crop.camera, crop.map_from_camera,
                                              state.context_parts, pixels)
        with np.errstate(invalid="ignore"):
            unexplained = view.depth_m[v[inside], u[inside]] < scene_depth - view.tolerance_m[v[inside], u[inside]]
        near, support = points[inside[unexplained]], support[unexplained]
        for height in np.unique(np.round(support, 3)):
            chosen = near[np.abs(support - height) < 0.0015]
            if len(chosen) < search.min_cluster_points:
                continue
            cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(chosen))
            labels = np.asarray(cloud.cluster_dbscan(eps=search.cluster_gap_m, min_points=4))
            for label in range(labels.max() + 1 if len(labels) else 0):
                member = chosen[labels == label]
                if len(member) >= search.min_cluster_points:
                    relation = "on" if height >= top - 0.01 else "in"
                    clusters.append(_Cluster(points=member, owner=owner, height_m=float(height), relation=relation))
    return clusters


def _space_above(triangles: np.ndarray) -> np.ndarray:
    """(2, 3) low and high corner of the box a small object standing on `triangles` stays in."""
    corners = triangles.reshape(-1, 3)
    return np.array([corners.min(axis=0), corners.max(axis=0) + [0.0, 0.0, MAX_HEIGHT_M]])


def _planar_pose(x: float, y: float, z: float, yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    pose = np.eye(4)
    pose[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
    pose[:3, 3] = (x, y, z)
    return pose


# A start's refined place is where it will settle from yaws not tried yet: this near one
# found before (the bench's cups ended within 2 mm of each other from all 16 starts, their
# yaws where they started), SAME_PLACE_REPEATS such ends stop the starts, and the yaw scan
# (`_yaw_as_seen`) turns the best to every yaw at its place. Two of the bench's cups took
# all 16 starts (0.03 CPU-s each) for a best score 0.93-0.96 that the scan took to 0.98-0.99.
SAME_PLACE_M = 0.003
SAME_PLACE_REPEATS = 2
# A colour this many times `max_colour_difference` off is another object's (see the loop).
FAR_COLOUR = 4.0


def _acceptable(candidate: _Candidate, search: SmallObjectSearch) -> bool:
    return candidate.explained >= search.min_explained and candidate.cluster_explained >= search.min_cluster_explained


def _of_its_colour(candidate: _Candidate | None, search: SmallObjectSearch) -> TypeGuard[_Candidate]:
    """Whether `candidate` was judged and its colour is the one seen (within `max_colour_difference`)."""
    return candidate is not None and candidate.colour_difference <= search.max_colour_difference


def _fit_on_cluster(
    state: FitState, view: FitView, object_id: str, bounds: np.ndarray, cluster: _Cluster, search: SmallObjectSearch
) -> _Candidate | None:
    """The object on the cluster's surface at its best yaw, or None when no yaw explains it.

    The camera sees the near side, so the centre lies beyond the points' centroid by up to
    half a footprint (a cup) or about on it (a bowl, whose inside is seen too): both start."""
    radius = float(np.linalg.norm(bounds[1, :2] - bounds[0, :2])) / 4
    # Every candidate stays within the gates' reach of its start: only that window is rendered.
    reach = 4 * radius + sum(search.gates_m)
    low, high = cluster.points.min(axis=0) - reach, cluster.points.max(axis=0) + reach
    low[2], high[2] = cluster.height_m - 0.01, cluster.height_m + bounds[1, 2] - bounds[0, 2] + 0.01
    window = view.around(box_corners(np.array([low, high])))
    if window is None:
        return None
    view = window[0]
    scene_depth = _scene_depth(state, view)
    away = cluster.centre_xy - view.map_from_camera[:2, 3]
    away /= max(np.linalg.norm(away), 1e-9)
    best: _Candidate | None = None
    starts = [(xy, yaw) for xy in (cluster.centre_xy, cluster.centre_xy + radius * away)
              for yaw in np.linspace(0, 2 * np.pi, search.yaw_candidates, endpoint=False)]
    repeats = 0
    for start_xy, yaw in starts:
        pose = _planar_pose(*start_xy, cluster.height_m, yaw)
        candidate = _refine(state, view, scene_depth, object_id, pose, cluster, search)
        if best is None and candidate is not None and candidate.colour_difference > FAR_COLOUR * search.max_colour_difference:
            # Another object's colour: every start on the cluster sees it (the bench's red cup
            # on the blue cup's cluster differed by 0.9-1.7 at all 16, the right objects by
            # 0.03 at most), and each costs three renders and ICPs. Not once one start has
            # found its colour: a later one may have slid onto a neighbour of another.
            return None
        if not _of_its_colour(candidate, search):
            continue
        if best is not None and np.linalg.norm(candidate.map_from_object[:2, 3] - best.map_from_object[:2, 3]) < SAME_PLACE_M:
            repeats += 1
        if best is None or candidate.score > best.score:
            best = candidate
        if best.score > search.sure or (repeats >= SAME_PLACE_REPEATS and _acceptable(best, search)):
            break
    if best is None or not _acceptable(best, search):
        return None
    best = _settled(state, view, scene_depth, object_id, best, cluster, search)
    found = _yaw_as_seen(state, view, scene_depth, object_id, best, cluster, search)
    if not _acceptable(found, search) or not _pinned(state, view, scene_depth, object_id, found, cluster, search):
        return None
    if not _own_relief_seen(state, view, scene_depth, object_id, found, cluster.height_m, bounds, search):
        return None
    return found


def _shifted(pose: np.ndarray, dx: float, dy: float) -> np.ndarray:
    moved = pose.copy()
    moved[:2, 3] += (dx, dy)
    return moved


def _around(step_m: float) -> list[tuple[float, float]]:
    return [(step_m * np.cos(a), step_m * np.sin(a)) for a in np.linspace(0, 2 * np.pi, 8, endpoint=False)]


def _settled(
    state: FitState, view: FitView, scene_depth: np.ndarray, object_id: str, best: _Candidate, cluster: _Cluster,
    search: SmallObjectSearch,
) -> _Candidate:
    """`best` moved in x and y down the misfit (pixels and points the object leaves
    unexplained) by `settle_steps_m`, each until no neighbour is better. ICP pulls the
    model's surfaces onto the nearest points: a flat object slides on its support (a rimmed
    plate's ICP settled 48-111 mm off, its true place explaining 0.92 of its pixels against 0.64).
    ICP's place is left only for one better by `yaw_margin` (the bench's cups and boxes: a
    misfit a few pixels less 2-3 mm off theirs)."""
    margin = search.yaw_margin * len(cluster.points)
    start = best
    for step in search.settle_steps_m:
        for _ in range(8):
            moved = [_evaluate(state, view, scene_depth, object_id, _shifted(best.map_from_object, dx, dy), cluster,
                               best.kernel_m, search) for dx, dy in _around(step)]
            least = best.misfit - (margin if best is start else 0.0)
            better = [c for c in moved if _of_its_colour(c, search) and c.misfit < least]
            if not better:
                break
            best = min(better, key=lambda c: c.misfit)
    if best is start:
        return best
    # ICP from there puts it to the millimetre the misfit's steps do not; only that near.
    refined = _refine(state, view, scene_depth, object_id, best.map_from_object, cluster, search)
    near = _of_its_colour(refined, search) and np.linalg.norm(
        refined.map_from_object[:2, 3] - best.map_from_object[:2, 3]) <= search.settle_steps_m[-1]
    return refined if near and refined.misfit <= best.misfit + margin else best


def _pinned(
    state: FitState, view: FitView, scene_depth: np.ndarray, object_id: str, found: _Candidate, cluster: _Cluster,
    search: SmallObjectSearch,
) -> bool:
    """Whether the view pins the found place: no place `pinned_shift_m` off explains it
    within `yaw_margin` of as well."""
    margin = search.yaw_margin * len(cluster.points)
    for dx, dy in _around(search.pinned_shift_m):
        other = _evaluate(state, view, scene_depth, object_id, _shifted(found.map_from_object, dx, dy), cluster,
                          found.kernel_m, search)
        if _of_its_colour(other, search) and other.misfit <= found.misfit + margin:
            return False
    return True


def _own_relief_seen(
    state: FitState, view: FitView, scene_depth: np.ndarray, object_id: str, found: _Candidate, support_m: float,
    bounds: np.ndarray, search: SmallObjectSearch,
) -> bool:
    """Whether the object's own relief explains its pixels clearly better than a flat slab
    over its footprint at the best height: a flat object fits any flat thing it lies on (the
    plate 'found' on the floor of an open drawer's box, 2 cm above the model's)."""
    rendering = _render_object(state, view, object_id, found.map_from_object)
    visible = rendering.hit & (rendering.depth_m < scene_depth)
    observed, model, tolerance = view.depth_m[visible], rendering.depth_m[visible], view.tolerance_m[visible]
    with np.errstate(invalid="ignore"):
        judged = np.isfinite(observed) & ~(observed < model - tolerance)
    observed, model, tolerance = observed[judged], model[judged], tolerance[judged]
    directions = view.directions_map(visible)[judged]
    origin = view.map_from_camera[2, 3]

    def cost(depth: np.ndarray) -> float:  # truncated squared residual, over the tolerance's
        return float(np.mean(np.minimum((observed - depth) ** 2, tolerance**2) / tolerance**2))

    with np.errstate(divide="ignore", invalid="ignore"):
        flats = [np.where(directions[:, 2] < 0, (height - origin) / directions[:, 2], np.inf)
                 for height in support_m + np.linspace(0.0, bounds[1, 2] - bounds[0, 2], 11)]
    flat = min(cost(depth) for depth in flats)
    return cost(model) < search.max_flat_cost * flat


def _yaw_as_seen(
    state: FitState, view: FitView, scene_depth: np.ndarray, object_id: str, best: _Candidate, cluster: _Cluster,
    search: SmallObjectSearch,
) -> _Candidate:
    """The found object at the yaw the view pins, or, when it pins none, at the yaw nearest
    the map's among those that explain the view as well, marked not seen.

    The ICP from a few starting yaws settles on the body and may leave the handle anywhere
    (the README's view: 164 deg off). So the found object is turned about its own axis to
    `yaw_checks` yaws and each judged as it stands; the fit decides, not the object's kind:
    when the yaws within `yaw_margin` of the least misfit all lie within `min_yaw_turn` of it,
    the view pins the yaw (the handle seen), which ICP then refines; when they spread wider,
    it does not (the handle behind the cup or a few pixels, a body of revolution)."""
    map_yaw = yaw_of(state.map_from_objects[object_id])
    # The map's own yaw is judged too: kept exactly when the view cannot tell it apart.
    turns = [*np.linspace(0, 2 * np.pi, search.yaw_checks, endpoint=False), map_yaw - yaw_of(best.map_from_object)]
    turned = [_evaluate(state, view, scene_depth, object_id, best.map_from_object @ _planar_pose(0, 0, 0, turn),
                        cluster, best.kernel_m, search) for turn in turns]
    judged = [candidate for candidate in turned if _of_its_colour(candidate, search)]
    if not judged:
        return best
    least = min(judged, key=lambda candidate: candidate.misfit)
    margin = search.yaw_margin * len(cluster.points)
    alike = [candidate for candidate in judged if candidate.misfit <= least.misfit + margin]
    if max(abs(_turn_between(least.map_from_object, c.map_from_object)) for c in alike) < search.min_yaw_turn:
        chosen, yaw_seen = least, True
    else:
        chosen, yaw_seen = min(alike, key=lambda c: abs(_turn_between(c.map_from_object, map_yaw))), False
        if abs(_turn_between(chosen.map_from_object, map_yaw)) < 1e-9:
            return replace(chosen, yaw_seen=False)
    # On the scan's grid: ICP settles the yaw within what the view allows (a box's yaw
    # modulo its symmetry, exact again).
    refined = _refine(state, view, scene_depth, object_id, chosen.map_from_object, cluster, search)
    if _of_its_colour(refined, search) and refined.misfit <= least.misfit + margin:
        chosen = refined
    return replace(chosen, yaw_seen=yaw_seen)


def _turn_between(a: np.ndarray, b: np.ndarray | float) -> float:
    """The yaw from pose `a` to pose (or yaw) `b`, in (-pi, pi]."""
    return float(np.angle(np.exp(1j * ((b if isinstance(b, float) else yaw_of(b)) - yaw_of(a)))))


def _refine(
    state: FitState, view: FitView, scene_depth: np.ndarray, object_id: str, pose: np.ndarray, cluster: _Cluster,
    search: SmallObjectSearch,
) -> _Candidate | None:
    rotation = view.map_from_camera[:3, :3]
    from scipy.spatial import cKDTree

    kernel = view.tolerance_m.min()
    for gate in search.gates_m:
        rendering = _render_object(state, view, object_id, pose)
        visible = rendering.hit & (rendering.depth_m < scene_depth)
        if visible.sum() < 4:
            return None
        kernel = float(np.median(view.tolerance_m[visible]))
        target = view.points_map(rendering.depth_m, visible)
        normals = rendering.normals_camera[visible] @ rotation.T
        distance, _ = cKDTree(target).query(cluster.points)
        source = cluster.points[distance < gate]
        if len(source) < 4:
            return None
        correction = icp_correction(source, target, normals, gate_m=gate, kernel_m=max(kernel, gate / 2), planar=True)
        if correction is None:
            return None
        pose = np.linalg.inv(correction) @ pose
        pose[2, 3] = cluster.height_m
    return _evaluate(state, view, scene_depth, object_id, pose, cluster, kernel, search)


def _evaluate(
    state: FitState, view: FitView, scene_depth: np.ndarray, object_id: str, pose: np.ndarray, cluster: _Cluster,
    kernel_m: float, search: SmallObjectSearch,
) -> _Candidate | None:
    """How well the object at `pose` explains the view, and how far its colour is from the
    one seen; None when it cannot be judged."""
    rotation = view.map_from_camera[:3, :3]
    rendering = _render_object(state, view, object_id, pose)
    visible = rendering.hit & (rendering.depth_m < scene_depth)
    if not visible.any():
        return None
    observed, model, tolerance = view.depth_m[visible], rendering.depth_m[visible], view.tolerance_m[visible]
    with np.errstate(invalid="ignore"):
        covered = observed < model - tolerance  # something in front: no evidence either way
        explained = np.abs(observed - model) < tolerance
    judged = np.isfinite(observed) & ~covered
    if judged.sum() < 4:
        return None
    difference = 0.0
    seen = judged & explained
    if view.color_rgb is not None and seen.any():
        # A red cup is not the white bowl of the same size: the colour image tells them apart.
        difference = float(np.abs(
            chromaticity(view.color_rgb[visible][seen]).mean(axis=0) - chromaticity(rendering.rgb[visible][seen]).mean(axis=0)
        ).sum())
    target = view.points_map(rendering.depth_m, visible)
    normals = rendering.normals_camera[visible] @ rotation.T
    quality = fit_quality(cluster.points, target, normals, np.eye(4), kernel_m)
    residual = (observed - model)[judged & explained]
    return _Candidate(
        map_from_object=pose,
        explained=float(explained[judged].mean()),
        cluster_explained=quality.inlier_fraction,
        rmse_m=float(np.sqrt(np.mean(residual**2))) if residual.size else float("nan"),
        misfit=int((~explained[judged]).sum()) + round((1.0 - quality.inlier_fraction) * len(cluster.points)),
        kernel_m=kernel_m,
        colour_difference=difference,
        uncovered=float(judged.mean()),
    )


def _place_in_view(state: FitState, view: FitView, object_id: str, bounds: np.ndarray, search: SmallObjectSearch) -> bool:
    """Whether the map's place of the object is in the image, in front of the scene and not covered."""
    map_from_object = state.map_from_objects[object_id]
    corners = box_corners(bounds) @ map_from_object[:3, :3].T + map_from_object[:3, 3]
    window = view.around(corners)
    if window is None:
        return False
    view = window[0]
    scene_depth = _scene_depth(state, view)
    rendering = _render_object(state, view, object_id, map_from_object)
    visible = rendering.hit & (rendering.depth_m < scene_depth)
    if visible.sum() < search.min_cluster_points:
        return False
    with np.errstate(invalid="ignore"):
        covered = view.depth_m[visible] < rendering.depth_m[visible] - view.tolerance_m[visible]
    return bool(np.mean(np.isfinite(view.depth_m[visible]) & ~covered) >= search.min_uncovered)
