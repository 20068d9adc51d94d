"""An object's pose refined against the observed points: Open3D's point-to-plane ICP with a
robust (Tukey) kernel, the observed points as the source and the object's own rendered
surface (its visible side, with the model's exact normals) as the target.

Only pixels where the object is the first surface of the rendered scene and the
observation lies within a gate of the rendered depth take part, so occluders, the floor and
moved neighbours stay out; the kernel discounts what is left of them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from homemodel.geometry.open3d_loader import load_open3d
from tracking.fit_state import FitState
from tracking.fit_view import FitView


@dataclass(kw_only=True)
class PoseFit:
    """How well the refined pose explains the object's observed points."""

    points: int  # observed points that took part
    inlier_fraction: float  # of those, the share within the kernel's width after the fit
    rmse_m: float  # of the inliers


def refine_pose(
    state: FitState,
    view: FitView,
    object_id: str,
    parts: list[int],
    background_m: np.ndarray,
    *,
    gates_m: tuple[float, ...],
    kernel_m: float,
    min_points: int,
    planar: bool,
) -> PoseFit | None:
    """Refine `state.map_from_objects[object_id]` from the observed points of `parts` (the
    object's fixed links, or all of them at their estimated joints) where they are in front
    of `background_m` (the rest of the scene's depth in `view`), one ICP per gate, the object
    re-rendered before each; `planar` keeps the motion to x, y and yaw (an object
    standing on the floor or on a surface). None, pose unchanged, when fewer than
    `min_points` points are seen."""
    last = None  # the last correction's points, for how well the pose fits
    rotation = view.map_from_camera[:3, :3]
    for gate_m in gates_m:
        rendering = state.renderer.render(
            state.map_from_parts(), view.camera, view.map_from_camera, only=state.object_parts(object_id)
        )
        mine = np.isin(rendering.part_index, parts) & (rendering.depth_m < background_m)
        close = np.abs(np.nan_to_num(view.depth_m, nan=-1.0) - rendering.depth_m) < gate_m
        source_mask = mine & view.valid & close
        if source_mask.sum() < min_points:
            break
        source = view.points_map(view.depth_m, source_mask)
        target = view.points_map(rendering.depth_m, mine)
        target_normals = rendering.normals_camera[mine] @ rotation.T
        # A kernel narrower than the misalignment gives every point zero weight: it narrows
        # with the gate, down to the noise.
        target_from_source = icp_correction(
            source, target, target_normals, gate_m=gate_m, kernel_m=max(kernel_m, gate_m / 2), planar=planar
        )
        if target_from_source is None:
            # Wandered off: the next, narrower gate starts again from the same pose.
            continue
        # The source is the object where it is, the target where the map has it.
        state.map_from_objects[object_id] = np.linalg.inv(target_from_source) @ state.map_from_objects[object_id]
        last = (source, target, target_normals, target_from_source)
    return None if last is None else fit_quality(*last, kernel_m)


def icp_correction(
    source: np.ndarray, target: np.ndarray, target_normals: np.ndarray, *, gate_m: float, kernel_m: float, planar: bool
) -> np.ndarray | None:
    """`target_from_source`: Open3D's point-to-plane ICP with a Tukey kernel of width
    `kernel_m`, correspondences up to `gate_m` apart, from the identity; None when it moved
    the points implausibly far.

    It runs about the target's centroid: about the map's origin, metres away, a turn the
    points leave free (a cylinder about its axis) would come out as a shift."""
    o3d = load_open3d()

    reg = o3d.pipelines.registration
    centre = target.mean(axis=0)
    # Every few pixels' points pin the motion down as well as all of them, at a fraction
    # of the nearest-neighbour searches (the pixels come row by row: a stride spreads them).
    source = source[_spread(len(source), MAX_SOURCE_POINTS)]
    kept = _spread(len(target), MAX_TARGET_POINTS)
    target, target_normals = target[kept], target_normals[kept]
    source_cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(source - centre))
    target_cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(target - centre))
    target_cloud.normals = o3d.utility.Vector3dVector(target_normals)
    # Open3D's ICP sums its normal equations over threads in whatever order they finish: one
    # thread gives the same correction for the same points (a few thousand points gain nothing
    # from a second), while the ray casting around it keeps every core.
    threads = o3d.utility.get_max_threads()
    o3d.utility.set_max_threads(1)
    try:
        result = reg.registration_icp(
            source_cloud,
            target_cloud,
            gate_m,
            np.eye(4),
            reg.TransformationEstimationPointToPlane(reg.TukeyLoss(k=kernel_m)),
            reg.ICPConvergenceCriteria(max_iteration=20, relative_fitness=1e-6, relative_rmse=1e-6),
        )
    finally:
        o3d.utility.set_max_threads(threads)
    if planar:
        local = _constrained(_planar(result.transformation), target - centre, target_normals)
    else:
        local = np.asarray(result.transformation)
    if not _plausible(local, source - centre, gate_m):
        return None
    shift = np.eye(4)
    shift[:3, 3] = centre
    return shift @ local @ np.linalg.inv(shift)


MAX_SOURCE_POINTS = 1500
MAX_TARGET_POINTS = 3000


def _spread(count: int, at_most: int) -> np.ndarray:
    """Indices of at most `at_most` of `count` items, evenly spread."""
    return np.arange(count) if count <= at_most else np.linspace(0, count - 1, at_most).astype(np.int64)


# A planar motion (x, y, yaw) the surfaces constrain less than this (the share of their
# points whose normals oppose it, yaw counted at a lever of LEVER_M) is left out.
MIN_CONSTRAINT = 0.03
LEVER_M = 0.3


def _constrained(local: np.ndarray, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """The planar correction `local` (about the points' centroid) without its part along the
    motions the surfaces do not pin down: a cupboard seen only from the front cannot tell a
    slide sideways, and ICP's answer along it is noise (degeneracy-aware remapping)."""
    kept = _motions(points, normals, MIN_CONSTRAINT, pinned=True)
    yaw = np.arctan2(local[1, 0], local[0, 0])
    motion = np.array([local[0, 3], local[1, 3], yaw * LEVER_M])
    x, y, lever_yaw = kept @ (kept.T @ motion)
    return _planar_transform(x, y, lever_yaw / LEVER_M)


def free_motions(points: np.ndarray, normals: np.ndarray, min_constraint: float) -> np.ndarray:
    """(3, k): the planar motions (x, y, yaw) about the points' centroid that the surfaces
    at `points` (with `normals`) pin down less than `min_constraint`, one a column (yaw in
    radians)."""
    free = _motions(points - points.mean(axis=0), normals, min_constraint, pinned=False)
    return free * np.array([[1.0], [1.0], [1.0 / LEVER_M]])


def _motions(points: np.ndarray, normals: np.ndarray, min_constraint: float, *, pinned: bool) -> np.ndarray:
    """Orthonormal (x, y, yaw x LEVER_M) motions about the origin of `points` that their
    surfaces pin down (`pinned`) or leave free: the eigenvectors of the point-to-plane
    information (the share of the points whose normals oppose the motion) from
    `min_constraint` up, or under it."""
    jacobian = np.column_stack([normals[:, 0], normals[:, 1], np.cross(points, normals)[:, 2] / LEVER_M])
    information = jacobian.T @ jacobian / max(len(points), 1)
    values, vectors = np.linalg.eigh(information)
    return vectors[:, (values >= min_constraint) == pinned]


def yaw_of(transform: np.ndarray) -> float:
    """The turn about z of a (4, 4) or (3, 3) transform's rotation, in (-pi, pi]."""
    return float(np.arctan2(transform[1, 0], transform[0, 0]))


def _planar_transform(x: float, y: float, yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    m = np.eye(4)
    m[:2, :2] = [[c, -s], [s, c]]
    m[:2, 3] = (x, y)
    return m


def _plausible(correction: np.ndarray, points: np.ndarray, gate_m: float) -> bool:
    """Whether a correction moves no point further than the gate: beyond it the points did
    not pin the motion down (too few, or the wrong ones) and ICP wandered off."""
    moved = points @ correction[:3, :3].T + correction[:3, 3]
    return bool(np.isfinite(correction).all() and np.linalg.norm(moved - points, axis=1).max() <= gate_m)


def _planar(a_from_b: np.ndarray) -> np.ndarray:
    """The x, y, yaw part of a rigid transform (a rotation about the vertical and a shift in the floor's plane)."""
    m = np.asarray(a_from_b, dtype=np.float64)
    return _planar_transform(m[0, 3], m[1, 3], np.arctan2(m[1, 0] - m[0, 1], m[0, 0] + m[1, 1]))


def fit_quality(
    source: np.ndarray, target: np.ndarray, target_normals: np.ndarray, target_from_source: np.ndarray, kernel_m: float
) -> PoseFit:
    """How many source points, moved, lie within `kernel_m` of the target's planes, and how close."""
    from scipy.spatial import cKDTree

    # Shares and an RMS: an even spread of the points gives them as well as all of them.
    count = len(source)
    source = source[_spread(len(source), 2 * MAX_SOURCE_POINTS)]
    kept = _spread(len(target), 2 * MAX_TARGET_POINTS)
    target, target_normals = target[kept], target_normals[kept]
    moved = source @ target_from_source[:3, :3].T + target_from_source[:3, 3]
    _, nearest = cKDTree(target).query(moved)
    distances = np.abs(np.einsum("ij,ij->i", moved - target[nearest], target_normals[nearest]))
    inliers = distances < kernel_m
    rmse = float(np.sqrt(np.mean(distances[inliers] ** 2))) if inliers.any() else float("inf")
    return PoseFit(points=count, inlier_fraction=float(inliers.mean()), rmse_m=rmse)
