"""A model's thumbnail for the database's table: ray-cast on the CPU (no GL, no Blender), each
triangle in its material's colour, lit from the viewer's side. About 20 ms for a cupboard."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from articulation.model import Model
from homemodel.core.atomic import write_bytes_atomic
from homemodel.core.transforms import world_from_camera_looking_at
from homemodel.geometry.camera import Camera
from homemodel.geometry.raycast import RayCaster

THUMBNAIL_PX = 160
BACKGROUND = (245, 245, 245)
AMBIENT = 0.35


def _coloured_mesh(model: Model) -> tuple[trimesh.Trimesh, np.ndarray]:
    """Every visual in the model frame, at rest, and an RGB per triangle."""
    world_from_links = model.world_from_links()
    parts, colours = [], []
    for link in model.links:
        for visual in link.visuals:
            mesh = visual.mesh.copy()
            mesh.apply_transform(world_from_links[link.name] @ visual.link_from_visual)
            parts.append(mesh)
            colours.append(np.tile(np.asarray(visual.material.rgba[:3]), (len(mesh.faces), 1)))
    return trimesh.util.concatenate(parts), np.vstack(colours)


def render_thumbnail(model: Model, size_px: int = THUMBNAIL_PX) -> np.ndarray:
    """(size, size, 3) uint8 RGB: the model seen from the front-right, above (its front is +x)."""
    mesh, colours = _coloured_mesh(model)
    centre = mesh.bounding_box.centroid
    radius = float(np.linalg.norm(mesh.extents)) / 2 or 1.0
    fov_half = np.radians(20.0)
    eye = centre + radius / np.sin(fov_half) * np.array([0.75, -0.45, 0.5]) / np.linalg.norm([0.75, -0.45, 0.5])
    focal = size_px / 2 / np.tan(fov_half)
    camera = Camera(width=size_px, height=size_px, fx=focal, fy=focal, cx=(size_px - 1) / 2, cy=(size_px - 1) / 2)
    world_from_camera = world_from_camera_looking_at(eye, centre)
    directions, hits = RayCaster(mesh).camera_hits(camera, np.linalg.inv(world_from_camera))
    image = np.tile(np.asarray(BACKGROUND, dtype=np.float64), (size_px * size_px, 1))
    hit = hits.hit
    view = directions[hit] / np.linalg.norm(directions[hit], axis=1, keepdims=True)
    # Two-sided: scans and imported assets come with either winding.
    shade = AMBIENT + (1 - AMBIENT) * np.abs(np.sum(hits.normals[hit] * view, axis=1))
    image[hit] = 255 * colours[hits.triangle[hit]] * shade[:, None]
    return np.clip(image, 0, 255).astype(np.uint8).reshape(size_px, size_px, 3)


def write_thumbnail(model: Model, path: Path) -> Path:
    import cv2

    # The channels flipped by numpy: cv2.cvtColor wakes OpenCV's thread pool, 13 ms on a busy machine.
    ok, png = cv2.imencode(".png", np.ascontiguousarray(render_thumbnail(model)[:, :, ::-1]))
    if not ok:
        raise RuntimeError("cannot encode the thumbnail as PNG")
    write_bytes_atomic(Path(path), png.tobytes())
    return Path(path)
