"""Texture baking against ground truth: the rendered set's true mesh, baked from its photos at
their true cameras, shows the true texture where the photos see it; the undistorted views the
later stages read are the photos' pixels, losslessly."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import cv2
import numpy as np
import pytest
import trimesh
from rendered_photo_set import rendered_photo_set

from homemodel.geometry.camera import Camera
from photogrammetry.sfm import View
from photogrammetry.synthetic_scene import truth_object_mesh
from photogrammetry.texturing import TextureBakingOptions, bake_texture


@pytest.fixture(scope="module")
def scene():
    return rendered_photo_set()


def _true_views(scene) -> list[View]:
    height, width = cv2.imread(str(scene.image_paths[0])).shape[:2]
    camera = Camera(width=width, height=height, fx=scene.fx_px, fy=scene.fx_px, cx=(width - 1) / 2, cy=(height - 1) / 2)
    return [View(name=p.name, image_path=p, camera=camera, camera_from_world=scene.camera_from_world[p.name])
            for p in scene.image_paths]  # fmt: skip


def _texture_at(mesh: trimesh.Trimesh, uv: np.ndarray, image: np.ndarray, points: np.ndarray, faces: np.ndarray):
    bary = trimesh.triangles.points_to_barycentric(mesh.triangles[faces], points)
    coords = np.einsum("nk,nkd->nd", bary, uv[mesh.faces[faces]])
    h, w = image.shape
    rows = np.clip(((1 - coords[:, 1]) * h).astype(int), 0, h - 1)
    return image[rows, np.clip((coords[:, 0] * w).astype(int), 0, w - 1)].astype(float)


def test_baked_texture_of_the_true_mesh_shows_the_true_pattern(scene) -> None:
    """The true vase (subdivided to 30,720 faces, so the atlas holds many charts) baked from the
    30 photos at their true cameras: 80 % or more of the atlas seen, and the baked grey levels
    on the side wall correlate with the true texture at r > 0.7 (0.75 measured: the photos'
    sun, shadows and blur differ from the flat albedo; the reconstructed model's test asks 0.5)."""
    truth, truth_uv = truth_object_mesh()
    mesh = trimesh.Trimesh(truth.vertices, truth.faces, process=False).subdivide().subdivide()
    baked = bake_texture(mesh, _true_views(scene), TextureBakingOptions(size_px=1024), workers=2)
    assert baked.covered_share > 0.8
    points, faces = trimesh.sample.sample_surface(baked.mesh, 8000, seed=0)
    side = (points[:, 2] > 0.01) & (points[:, 2] < 0.13)  # the caps' true UVs are not comparable
    points, faces = points[side], faces[side]
    grey = cv2.cvtColor(baked.texture, cv2.COLOR_RGB2GRAY)
    baked_values = _texture_at(baked.mesh, baked.uv, grey, points, faces)
    truth_image = cv2.cvtColor(cv2.imread(str(scene.folder / "textures" / "object.png")), cv2.COLOR_BGR2GRAY)
    closest, _, truth_faces = trimesh.proximity.closest_point(truth, points)
    away_from_seam = np.abs(np.arctan2(closest[:, 1], closest[:, 0] - truth.centroid[0])) < 3.0
    truth_values = _texture_at(truth, truth_uv, truth_image, closest, truth_faces)
    correlation = np.corrcoef(baked_values[away_from_seam], truth_values[away_from_seam])[0, 1]
    assert correlation > 0.7, correlation


def test_undistorted_views_hold_the_remapped_pixels_losslessly(scene, tmp_path: Path) -> None:
    """Five photos undistorted (a real pycolmap camera with radial distortion): each view file
    reads back exactly as OpenCV's remap of the photo through COLMAP's own lookup."""
    import pycolmap

    from photogrammetry.undistortion import _lookup, pinhole_camera, undistort_photos

    height, width = cv2.imread(str(scene.image_paths[0])).shape[:2]
    camera = pycolmap.Camera(model="SIMPLE_RADIAL", width=width, height=height,
                             params=[scene.fx_px, width / 2, height / 2, -0.04])  # fmt: skip
    names = [p.name for p in scene.image_paths[:5]]
    images = {i: SimpleNamespace(name=n, camera_id=1, camera=camera) for i, n in enumerate(names)}
    written = undistort_photos(SimpleNamespace(cameras={1: camera}, images=images), scene.folder / "images",
                               tmp_path, workers=2)  # fmt: skip
    map_x, map_y = _lookup(camera, pinhole_camera(camera))
    for name in names:
        path, view_camera = written[name]
        expected = cv2.remap(cv2.imread(str(scene.folder / "images" / name)), map_x, map_y, cv2.INTER_LINEAR,
                             borderMode=cv2.BORDER_CONSTANT)  # fmt: skip
        assert (view_camera.width, view_camera.height) == expected.shape[1::-1]
        assert np.array_equal(cv2.imread(str(path)), expected)
