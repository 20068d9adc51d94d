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
    fit: PoseFit | None = None
    rotation = view.map_from_camera[:3, :3]
    for gate_m in gates_m:
        rendering = state.renderer.render(
            state.map_from_parts(), view.camera, view.map_from_camera, only=state.object_parts(object_id)
        )
        mine = np.isin(rendering.part_index, parts) & (rendering.depth_m < background_m)
        close = np.abs(np.nan_to_num(view.depth_m, nan=-1.0) - rendering.depth_m) < gate_m
        source_mask = mine & view.valid & close
        if source_mask.sum() < min_points:
            return fit
        source = view.points_map(view.depth_m, source_mask)
        target = view.points_map(rendering.depth_m, mine)
        target_normals = rendering.normals_camera[mine] @ rotation.T
        target_from_source = icp_correction(source, target, target_normals, gate_m=gate_m, kernel_m=kernel_m, planar=planar)
        # The source is the object where it is, the target where the map has it.
        state.map_from_objects[object_id] = np.linalg.inv(target_from_source) @ state.map_from_objects[object_id]
        fit = fit_quality(source, target, target_normals, target_from_source, kernel_m)
    return fit


def icp_correction(
    source: np.ndarray, target: np.ndarray, target_normals: np.ndarray, *, gate_m: float, kernel_m: float, planar: bool
) -> np.ndarray:
    """`target_from_source`: Open3D's point-to-plane ICP with a Tukey kernel of width
    `kernel_m`, correspondences up to `gate_m` apart, from the identity."""
    import open3d as o3d

    reg = o3d.pipelines.registration
    source_cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(source))
    target_cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(target))
    target_cloud.normals = o3d.utility.Vector3dVector(target_normals)
    result = reg.registration_icp(
        source_cloud,
        target_cloud,
        gate_m,
        np.eye(4),
        reg.TransformationEstimationPointToPlane(reg.TukeyLoss(k=kernel_m)),
        reg.ICPConvergenceCriteria(max_iteration=30, relative_fitness=1e-7, relative_rmse=1e-7),
    )
    return _planar(result.transformation) if planar else np.asarray(result.transformation)


def _planar(a_from_b: np.ndarray) -> np.ndarray:
    """The x, y, yaw part of a rigid transform (a rotation about the vertical and a shift in the floor's plane)."""
    m = np.asarray(a_from_b, dtype=np.float64)
    yaw = np.arctan2(m[1, 0] - m[0, 1], m[0, 0] + m[1, 1])
    c, s = np.cos(yaw), np.sin(yaw)
    planar = np.eye(4)
    planar[:2, :2] = [[c, -s], [s, c]]
    planar[:2, 3] = m[:2, 3]
    return planar


def fit_quality(
    source: np.ndarray, target: np.ndarray, target_normals: np.ndarray, target_from_source: np.ndarray, kernel_m: float
) -> PoseFit:
    """How many source points, moved, lie within `kernel_m` of the target's planes, and how close."""
    from scipy.spatial import cKDTree

    moved = source @ target_from_source[:3, :3].T + target_from_source[:3, 3]
    _, nearest = cKDTree(target).query(moved)
    distances = np.abs(np.einsum("ij,ij->i", moved - target[nearest], target_normals[nearest]))
    inliers = distances < kernel_m
    rmse = float(np.sqrt(np.mean(distances[inliers] ** 2))) if inliers.any() else float("inf")
    return PoseFit(points=len(moved), inlier_fraction=float(inliers.mean()), rmse_m=rmse)
