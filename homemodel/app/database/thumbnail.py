"""A model's thumbnail for the database's table: drawn on the CPU (no GL, no Blender) by a
small z-buffer, each triangle in its material's colour, lit from the viewer's side.

Not by the ray caster (`homemodel.geometry.raycast`, which gives the same picture): it is
open3d's, and importing open3d costs a worker about 1.1 s of CPU (half of it the plotly and
dash its visualisation module imports), which spec and import entries need for nothing else.
"""

from __future__ import annotations

import functools
import numpy as np

from articulation.model import Model
from homemodel.core.transforms import world_from_camera_looking_at
from homemodel.geometry.camera import Camera

THUMBNAIL_PX = 160
BACKGROUND = (245, 245, 245)
AMBIENT = 0.35
FOV_HALF_RAD = np.radians(20.0)


def _coloured_triangles(model: Model) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every visual's vertices in the model frame, at rest, its triangles (indices into them)
    and an RGB per triangle. In numpy: trimesh's copies, transforms and concatenation were a
    third of a cup's thumbnail."""
    world_from_links = model.world_from_links()
    vertices, faces, colours, count = [], [], [], 0
    for link in model.links:
        for visual in link.visuals:
            world_from_visual = world_from_links[link.name] @ visual.link_from_visual
            points = np.asarray(visual.mesh.vertices, dtype=np.float64)
            vertices.append(points @ world_from_visual[:3, :3].T + world_from_visual[:3, 3])
            faces.append(np.asarray(visual.mesh.faces, dtype=np.int64) + count)
            colours.append(np.tile(np.asarray(visual.material.rgba[:3], dtype=np.float64), (len(faces[-1]), 1)))
            count += len(points)
    return np.vstack(vertices), np.vstack(faces), np.vstack(colours)


def _unit_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(F, 3) each triangle's unit normal; zero for a degenerate one (as trimesh gives)."""
    corners = vertices[faces]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    lengths = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.divide(normals, lengths, out=np.zeros_like(normals), where=lengths > 0)


def _max3(a: np.ndarray) -> np.ndarray:
    """(N,) the largest of each row of (N, 3): pairwise, 3-4x faster than numpy's reduction
    over an axis of length 3, which the z-buffer ran a dozen times a thumbnail."""
    return np.maximum(np.maximum(a[:, 0], a[:, 1]), a[:, 2])


def _min3(a: np.ndarray) -> np.ndarray:
    return np.minimum(np.minimum(a[:, 0], a[:, 1]), a[:, 2])


def nearest_triangles(vertices: np.ndarray, faces: np.ndarray, camera: Camera, camera_from_mesh: np.ndarray) -> np.ndarray:
    """(height * width,) the index of the triangle (a row of `faces`) nearest the camera at each
    pixel centre, row by row, -1 where none is: a z-buffer over the triangles wholly in front
    of the camera, with 1/z (linear in the image) as the depth."""
    points = np.asarray(vertices, dtype=np.float64) @ camera_from_mesh[:3, :3].T + camera_from_mesh[:3, 3]
    faces = np.asarray(faces)
    in_front = _min3(points[faces, 2]) > 1e-9
    faces, indices = faces[in_front], np.flatnonzero(in_front)
    corners = camera.project(np.where(points[:, 2:] > 1e-9, points, [0.0, 0.0, 1.0]))[faces]  # (F, 3, 2) pixels
    x0, y0 = corners[:, :, 0], corners[:, :, 1]
    x1, y1 = x0[:, [1, 2, 0]], y0[:, [1, 2, 0]]
    area = np.einsum("fc,fc->f", x0, y1) - np.einsum("fc,fc->f", x1, y0)  # twice the signed area
    flat = np.abs(area) < 1e-12
    area[flat] = 1.0
    # A corner's barycentric weight is linear in the pixel (x, y): the signed area the pixel
    # makes with the opposite edge, over the triangle's. So is 1/z, interpolated by the weights.
    ex, ey = x1, y1  # corner i's opposite edge runs from corner i + 1 ...
    fx, fy = x0[:, [2, 0, 1]], y0[:, [2, 0, 1]]  # ... to corner i + 2
    weights = np.stack([ey - fy, fx - ex, ex * fy - fx * ey], axis=2) / area[:, None, None]  # (F, 3 corners, 3 coefficients)
    inverse_z = 1.0 / points[faces, 2]
    depth = np.einsum("fc,fck->fk", inverse_z, weights)  # 1/z = depth . (x, y, 1)
    low_y = np.clip(np.ceil(_min3(y0)), 0, camera.height - 1).astype(np.int64)
    high_y = np.clip(np.floor(_max3(y0)), -1, camera.height - 1).astype(np.int64)
    rows = np.where(flat, 0, np.maximum(high_y - low_y + 1, 0))
    # Each triangle's pixel rows; on a row, where every weight a x + b y + c is >= 0.
    f = np.repeat(np.arange(len(faces)), rows)
    y = (low_y[f] + np.arange(len(f)) - np.repeat(np.cumsum(rows) - rows, rows)).astype(np.float64)
    # Gathered from contiguous (F, 3) arrays: fancy indexing into (F, 3, 3) took half the time.
    a, b, c = (np.ascontiguousarray(weights[:, :, k]) for k in range(3))
    slope, rest = a.take(f, axis=0), b.take(f, axis=0) * y[:, None] + c.take(f, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = -rest / slope
    left = _max3(np.where(slope > 0, bound - 1e-9, -np.inf))
    right = _min3(np.where(slope < 0, bound + 1e-9, np.inf))
    outside = (slope == 0) & (rest < -1e-9)  # an edge along the row, the row outside it
    never = outside[:, 0] | outside[:, 1] | outside[:, 2]
    first = np.clip(np.ceil(left), 0, camera.width - 1)
    last = np.clip(np.floor(right), -1, camera.width - 1)
    widths = np.where(never, 0, np.maximum(last - first + 1, 0)).astype(np.int64)
    pixel_row = np.repeat(np.arange(len(f)), widths)
    x = first.take(pixel_row) + np.arange(len(pixel_row)) - np.repeat(np.cumsum(widths) - widths, widths)
    y, triangle = y.take(pixel_row), f.take(pixel_row)
    d0, d1, d2 = (np.ascontiguousarray(depth[:, k]).take(triangle) for k in range(3))
    inverse_depth = d0 * x + d1 * y + d2
    pixel = (y * camera.width + x).astype(np.int64)
    z_buffer = np.full(camera.width * camera.height, -np.inf)
    np.maximum.at(z_buffer, pixel, inverse_depth)  # the largest 1/z: the nearest
    nearest = np.full(camera.width * camera.height, -1, dtype=np.int64)
    wins = inverse_depth == z_buffer[pixel]
    nearest[pixel[wins]] = indices[triangle[wins]]
    return nearest


@functools.lru_cache(maxsize=4)
def _thumbnail_camera(size_px: int) -> tuple[Camera, np.ndarray]:
    """The thumbnails' camera (the same for every model: it is placed to fit each) and its
    unit pixel rays in its own frame."""
    focal = size_px / 2 / np.tan(FOV_HALF_RAD)
    camera = Camera(width=size_px, height=size_px, fx=focal, fy=focal, cx=(size_px - 1) / 2, cy=(size_px - 1) / 2)
    rays = camera.pixel_rays()
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    rays.flags.writeable = False
    return camera, rays


def render_thumbnail(model: Model, size_px: int = THUMBNAIL_PX) -> np.ndarray:
    """(size, size, 3) uint8 RGB: the model seen from the front-right, above (its front is +x)."""
    vertices, faces, colours = _coloured_triangles(model)
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    centre = (low + high) / 2
    radius = float(np.linalg.norm(high - low)) / 2 or 1.0
    eye = centre + radius / np.sin(FOV_HALF_RAD) * np.array([0.75, -0.45, 0.5]) / np.linalg.norm([0.75, -0.45, 0.5])
    camera, rays = _thumbnail_camera(size_px)
    world_from_camera = world_from_camera_looking_at(eye, centre)
    triangle = nearest_triangles(vertices, faces, camera, np.linalg.inv(world_from_camera))
    image = np.empty((size_px * size_px, 3), dtype=np.uint8)
    image[:] = BACKGROUND
    hit = np.flatnonzero(triangle >= 0)
    drawn = triangle[hit]
    # |normal . view| in the camera's frame (a rotation keeps it): two-sided, since scans and
    # imported assets come with either winding.
    normals = (_unit_normals(vertices, faces) @ world_from_camera[:3, :3]).take(drawn, axis=0)
    shade = AMBIENT + (1 - AMBIENT) * np.abs(np.einsum("ij,ij->i", normals, rays[hit]))
    image[hit] = np.clip(255 * colours[drawn] * shade[:, None], 0, 255).astype(np.uint8)
    return image.reshape(size_px, size_px, 3)


def thumbnail_png(model: Model) -> bytes:
    """The thumbnail as PNG bytes (the entry's build stores them with its other records)."""
    import cv2

    # The channels flipped by numpy: cv2.cvtColor wakes OpenCV's thread pool, 13 ms on a busy machine.
    ok, png = cv2.imencode(".png", np.ascontiguousarray(render_thumbnail(model)[:, :, ::-1]))
    if not ok:
        raise RuntimeError("cannot encode the thumbnail as PNG")
    return png.tobytes()
