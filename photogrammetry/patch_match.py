"""COLMAP's PatchMatch stereo and fusion, for a pycolmap built with CUDA.

The PyPI wheel has no CUDA (`pycolmap.has_cuda` is False) and the CPU path of
`photogrammetry.stereo` runs instead; this module is used only where CUDA is there.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from homemodel.geometry.open3d_loader import load_open3d


def cuda_available() -> bool:
    import pycolmap

    return bool(getattr(pycolmap, "has_cuda", False))


def patch_match_points(undistorted: Path, max_image_size_px: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fused points, colours (0..1) and unit normals from PatchMatch on an undistorted workspace
    (what `pycolmap.undistort_images` wrote)."""
    o3d = load_open3d()
    import pycolmap

    options = pycolmap.PatchMatchOptions()
    options.max_image_size = max_image_size_px
    options.geom_consistency = True
    pycolmap.patch_match_stereo(undistorted, options=options)
    fused = undistorted / "fused.ply"
    fusion = pycolmap.StereoFusionOptions()
    fusion.max_image_size = max_image_size_px
    pycolmap.stereo_fusion(fused, undistorted, options=fusion, output_type="PLY")
    cloud = o3d.io.read_point_cloud(str(fused))
    return np.asarray(cloud.points), np.asarray(cloud.colors), np.asarray(cloud.normals)
