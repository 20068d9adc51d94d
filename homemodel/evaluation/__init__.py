"""Evaluation metrics for reconstructions against ground truth: VoxelIOU, surface distance, F-score,
camera pose error.

Importable without bpy or open3d (open3d is imported inside the functions that measure
point-to-surface distances). Every function takes two `trimesh.Trimesh` in the same frame
and units; see `docs/evaluation.md` for the conventions.
"""

from homemodel.evaluation.poses import camera_pose_errors
from homemodel.evaluation.rock import rock_surface_distance, rock_voxel_iou
from homemodel.evaluation.surface import f_score, mean_surface_distance_m
from homemodel.evaluation.voxels import VoxelGrid, solid_occupancy, voxel_iou

__all__ = [
    "VoxelGrid",
    "camera_pose_errors",
    "f_score",
    "mean_surface_distance_m",
    "rock_surface_distance",
    "rock_voxel_iou",
    "solid_occupancy",
    "voxel_iou",
]
