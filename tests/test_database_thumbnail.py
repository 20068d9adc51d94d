"""The database's thumbnails are drawn by a z-buffer that sees what the project's ray caster
sees, and an import entry's worker builds without importing open3d (1.1 s of CPU a worker)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

from articulation.model import Link, Material, Model, Visual
from homemodel.app.database.thumbnail import THUMBNAIL_PX, nearest_triangles, render_thumbnail
from homemodel.core.transforms import world_from_camera_looking_at
from homemodel.geometry.camera import Camera
from homemodel.geometry.raycast import RayCaster


def _mug() -> trimesh.Trimesh:
    outer = trimesh.creation.cylinder(radius=0.04, height=0.1, sections=48)
    inner = trimesh.creation.cylinder(radius=0.035, height=0.1, sections=48)
    inner.apply_translation([0.0, 0.0, 0.006])
    return outer.difference(inner)


def _cabinet_with_a_mug() -> trimesh.Trimesh:
    body = trimesh.creation.box((0.6, 0.5, 0.8))
    body.apply_translation([0.0, 0.0, 0.4])
    mug = _mug()
    mug.apply_translation([0.1, 0.0, 0.8])
    return trimesh.util.concatenate([body, mug])


def _open_sheets() -> trimesh.Trimesh:
    """Two crossing, open, one-sided quads: either winding, one in front of the other."""
    quad = trimesh.Trimesh([[0, 0, 0], [0.3, 0, 0], [0.3, 0, 0.3], [0, 0, 0.3]], [[0, 1, 2], [0, 2, 3]])
    other = quad.copy()
    other.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 0, 1], [0.15, 0, 0]))
    other.invert()
    return trimesh.util.concatenate([quad, other])


@pytest.mark.parametrize("make", [_mug, _cabinet_with_a_mug, _open_sheets, lambda: trimesh.creation.icosphere(subdivisions=4)])
@pytest.mark.parametrize("size_px", [THUMBNAIL_PX, 97])
def test_the_z_buffer_finds_the_triangles_the_ray_caster_hits(make, size_px: int) -> None:
    mesh = make()
    centre = mesh.bounding_box.centroid
    eye = centre + 2.5 * np.linalg.norm(mesh.extents) * np.array([0.75, -0.45, 0.5])
    focal = size_px / 2 / np.tan(np.radians(20.0))
    camera = Camera(width=size_px, height=size_px, fx=focal, fy=focal, cx=(size_px - 1) / 2, cy=(size_px - 1) / 2)
    camera_from_mesh = np.linalg.inv(world_from_camera_looking_at(eye, centre))
    _, hits = RayCaster(mesh).camera_hits(camera, camera_from_mesh)
    drawn = nearest_triangles(mesh.vertices, mesh.faces, camera, camera_from_mesh)
    assert 0.05 < np.mean(drawn >= 0) < 0.95
    # Pixel centres exactly on a shared edge may go to either triangle: a few per thousand at most.
    assert np.mean((drawn >= 0) == hits.hit) >= 0.999
    assert np.mean(drawn == hits.triangle) >= 0.995


def test_a_thumbnail_shows_the_model_in_its_colours() -> None:
    blue = Material(name="blue", rgba=(0.1, 0.2, 0.9, 1.0))
    model = Model(name="mug", links=[Link(name="body", visuals=[Visual(name="mug", mesh=_mug(), material=blue)])])
    image = render_thumbnail(model).reshape(-1, 3).astype(float)
    drawn = np.any(image != 245, axis=1)
    assert 0.1 < drawn.mean() < 0.9
    # Lit blue: blue the strongest channel everywhere the mug is drawn, in proportion to its colour.
    assert np.all(image[drawn, 2] > image[drawn, 0]) and np.all(image[drawn, 2] > image[drawn, 1])


def test_an_import_entry_is_built_without_open3d(tmp_path: Path) -> None:
    """A worker as a build warms it up for an import entry, then builds a glb cup: valid, with
    its thumbnail, and open3d never imported."""
    _mug().export(tmp_path / "cup.glb")
    (tmp_path / "manifest.yaml").write_text("entries:\n  - {id: cup, source: urdf, path: cup.glb, repair: true, category: cup}\n")
    script = f"""
import sys
from pathlib import Path
from homemodel.app.database.warm_up import warm_up
from homemodel.app.database.build import repair_for
from homemodel.app.database.manifest import load_manifest
from homemodel.app.database.build_request import BuildRequest
from homemodel.app.database.tasks import build_batch
warm_up(("urdf",))
jobs, repair = load_manifest(Path({str(tmp_path / "manifest.yaml")!r}))
[row] = build_batch([BuildRequest(job=jobs[0], key="k", db_dir=Path({str(tmp_path / "db")!r}), repair=repair_for(jobs[0], repair, False))])
print(row.status, row.error, "open3d" in sys.modules, "bpy" in sys.modules)
"""
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=False, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["valid", "None", "False", "False"], done.stdout + done.stderr[-2000:]
    assert (tmp_path / "db" / "models" / "cup" / "thumbnail.png").stat().st_size > 1000
