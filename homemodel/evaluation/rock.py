"""The evaluation conventions of Rock et al., "Completing 3D Object Shape from One Depth Image" (CVPR 2015).

Both meshes are normalised together: one similarity transform puts the union of their
bounding boxes at the centre of the cube [-2, 2]^3, its longest side spanning the cube less
one voxel on each side (so the surface voxels of the largest extent stay on the grid).
VoxelIOU is then measured on a 200^3 solid grid over that cube, and the surface distance
is the RMS of the nearest-surface distances both ways divided by the cube's side (4).
"""

from __future__ import annotations

import numpy as np
import trimesh

from homemodel.evaluation.meshes import checked_mesh
from homemodel.evaluation.surface import two_way_distances
from homemodel.evaluation.voxels import VoxelGrid, iou_of_occupancies, solid_occupancy

CUBE_HALF_SIDE = 2.0
GRID_RESOLUTION = 200


def normalised_together(pred: trimesh.Trimesh, gt: trimesh.Trimesh) -> tuple[trimesh.Trimesh, trimesh.Trimesh]:
    """Both meshes under the one similarity transform that fits their joint bounds into the cube."""
    pred, gt = checked_mesh(pred, "pred"), checked_mesh(gt, "gt")
    low = np.minimum(pred.bounds[0], gt.bounds[0])
    high = np.maximum(pred.bounds[1], gt.bounds[1])
    voxel = 2 * CUBE_HALF_SIDE / GRID_RESOLUTION
    scale = 2 * (CUBE_HALF_SIDE - voxel) / float(np.max(high - low))
    centre = 0.5 * (low + high)
    return (
        trimesh.Trimesh((pred.vertices - centre) * scale, pred.faces, process=False),
        trimesh.Trimesh((gt.vertices - centre) * scale, gt.faces, process=False),
    )


def rock_grid() -> VoxelGrid:
    voxel = 2 * CUBE_HALF_SIDE / GRID_RESOLUTION
    return VoxelGrid(origin_m=np.full(3, -CUBE_HALF_SIDE), voxel_size_m=voxel, shape=(GRID_RESOLUTION,) * 3)


def rock_voxel_iou(pred: trimesh.Trimesh, gt: trimesh.Trimesh) -> float:
    """VoxelIOU with Rock et al.'s conventions: normalised together into [-2, 2]^3, 200^3 solid grid."""
    pred_n, gt_n = normalised_together(pred, gt)
    grid = rock_grid()
    return iou_of_occupancies(solid_occupancy(pred_n, grid), solid_occupancy(gt_n, grid))


def rock_surface_distance(
    pred: trimesh.Trimesh, gt: trimesh.Trimesh, *, n_samples: int = 100_000, seed: int = 0
) -> float:
    """RMS of the nearest-surface distances both ways (pred's samples to gt, gt's to pred) in the
    normalised frame, divided by the cube's side: a fraction of the cube, not a length."""
    pred_n, gt_n = normalised_together(pred, gt)
    pred_to_gt, gt_to_pred = two_way_distances(pred_n, gt_n, n_samples=n_samples, seed=seed)
    rms = float(np.sqrt(np.mean(np.concatenate([pred_to_gt, gt_to_pred]) ** 2)))
    return rms / (2 * CUBE_HALF_SIDE)
