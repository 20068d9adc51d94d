"""Photos of textured matte meshes rendered with the toolkit's ray caster, without Blender: what
`synthetic_scene` uses when its `renderer` is "rays".

Each pixel centre's ray finds its triangle (open3d, `homemodel.geometry.raycast`), the
barycentric weights give the texture coordinates, the texture (sRGB, looked up bilinearly or at
the closest texel) gives the albedo, and Lambert's law the light: a uniform sky (ambient) plus a
sun whose shadow a second ray finds. Pixels where the triangle's part or the sunlight changes
from a neighbour, and pixels of closest-texel parts (printed cells), are sampled again on a
finer grid and averaged: anti-aliased edges where they matter (marker corners, silhouettes)
for a few percent of the pixels. No light bounces between surfaces. A camera's blur (a Gaussian
in linear light) and shot noise may be added: on the synthetic photo set, sharp noise-free
renders put the cameras 1 % too close in the marker frame (5.7 and 7.1 mm off, in two renders),
with 0.5 px of blur and 1 % shot noise 0.06 % (2.6 mm; Cycles' render 3.5 mm).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import trimesh

from homemodel.core.srgb import srgb_decode, srgb_encode
from homemodel.geometry.camera import Camera
from homemodel.geometry.raycast import RayCaster, changing_pixels, subpixel_offsets

# Far enough along the normal that a shadow ray does not hit its own triangle in float32.
_SHADOW_RAY_OFFSET_M = 1e-4


@dataclass(kw_only=True)
class TexturedPart:
    """A mesh with per-vertex texture coordinates (u right, v up from the image's bottom row,
    Blender's convention) and its 8-bit sRGB RGB texture."""

    vertices: np.ndarray  # (V, 3) world frame, metres
    faces: np.ndarray  # (F, 3) or (F, 4) planar quads
    uv: np.ndarray  # (V, 2)
    texture_srgb: np.ndarray  # (H, W, 3) uint8 RGB
    closest_texel: bool = False  # printed cells: no interpolation between texels


@dataclass(kw_only=True)
class Lighting:
    sky_radiance: float  # linear, from every direction (the background as well)
    sun_irradiance_w_m2: float
    to_sun: np.ndarray  # (3,) unit vector, world frame


def srgb_to_linear(srgb: np.ndarray) -> np.ndarray:
    c = np.asarray(srgb, np.float32) / 255.0
    return srgb_decode(c).astype(np.float32)


def linear_to_srgb8(linear: np.ndarray) -> np.ndarray:
    """Blender's "Standard" view transform: the sRGB transfer function, rounded to 8 bits."""
    c = np.clip(linear, 0.0, 1.0)
    return (srgb_encode(c) * 255 + 0.5).astype(np.uint8)


def _triangles(faces: np.ndarray) -> np.ndarray:
    faces = np.asarray(faces, np.int64)
    if faces.ndim != 2 or faces.shape[1] not in (3, 4):
        raise ValueError(f"{faces.shape=} but expected (F, 3) or (F, 4)")
    if faces.shape[1] == 3:
        return faces
    return np.vstack([faces[:, [0, 1, 2]], faces[:, [0, 2, 3]]])


def _texture_lookup(texture: np.ndarray, uv: np.ndarray, closest: bool) -> np.ndarray:
    """(N, 3) linear texture values at (N, 2) texture coordinates (texel centres at half steps)."""
    h, w = texture.shape[:2]
    flat = texture.reshape(-1, 3)
    x = uv[:, 0] * w - 0.5
    y = (1.0 - uv[:, 1]) * h - 0.5
    if closest:
        col = np.clip(np.rint(x).astype(np.int64), 0, w - 1)
        row = np.clip(np.rint(y).astype(np.int64), 0, h - 1)
        return flat[row * w + col]
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    x0, y0 = x0.astype(np.int64), y0.astype(np.int64)
    left, right = np.clip(x0, 0, w - 1), np.clip(x0 + 1, 0, w - 1)
    top, bottom = np.clip(y0, 0, h - 1) * w, np.clip(y0 + 1, 0, h - 1) * w
    upper = flat[top + left] + (flat[top + right] - flat[top + left]) * fx
    lower = flat[bottom + left] + (flat[bottom + right] - flat[bottom + left]) * fx
    return upper + (lower - upper) * fy


class RayRenderer:
    """A scene of textured parts under one lighting, ready to be photographed from many poses."""

    def __init__(
        self, parts: Sequence[TexturedPart], lighting: Lighting, *, edge_samples: int = 3, blur_px: float = 0.0,
        shot_noise: float = 0.0,
    ) -> None:
        """`edge_samples` per side of the finer grid at edges; `blur_px` the Gaussian sigma of the
        camera's blur; `shot_noise` the noise's sigma at full brightness (it grows with the square
        root of the light)."""
        if not parts:
            raise ValueError("a scene needs at least one part")
        if edge_samples < 1 or blur_px < 0 or shot_noise < 0:
            raise ValueError(f"{edge_samples=}, {blur_px=}, {shot_noise=} but expected >= 1, >= 0, >= 0")
        self._blur_px, self._shot_noise = blur_px, shot_noise
        vertices, faces, corner_uv, part_of_face = [], [], [], []
        offset = 0
        for index, part in enumerate(parts):
            triangles = _triangles(part.faces)
            vertices.append(np.asarray(part.vertices, np.float64))
            faces.append(triangles + offset)
            corner_uv.append(np.asarray(part.uv, np.float32)[triangles])
            part_of_face.append(np.full(len(triangles), index))
            offset += len(part.vertices)
        mesh = trimesh.Trimesh(np.vstack(vertices), np.vstack(faces), process=False)
        self._caster = RayCaster(mesh)
        self._normals = mesh.face_normals.astype(np.float32)
        self._corner_uv = np.concatenate(corner_uv)  # (F, 3, 2)
        self._part_of_face = np.concatenate(part_of_face)
        self._textures = [srgb_to_linear(p.texture_srgb) for p in parts]
        self._closest = [p.closest_texel for p in parts]
        self._lighting = lighting
        self._to_sun = np.asarray(lighting.to_sun, np.float32) / np.linalg.norm(lighting.to_sun)
        self._subpixel = subpixel_offsets(edge_samples)

    def render(self, camera: Camera, camera_from_world: np.ndarray, rng: np.random.Generator | None = None) -> np.ndarray:
        """(height, width, 3) uint8 RGB photo from `camera` (no distortion) at `camera_from_world`;
        `rng` draws the shot noise (a fixed seed when None)."""
        world_from_camera = np.linalg.inv(camera_from_world)
        to_world = world_from_camera[:3, :3].T
        origin = world_from_camera[:3, 3]
        linear, label = self._shade(origin, camera.pixel_rays() @ to_world)
        label = label.reshape(camera.height, camera.width)
        again = np.isin(label // 2, np.flatnonzero(self._closest)) | changing_pixels(label)
        rows, cols = np.nonzero(again)
        pixels = (np.column_stack([cols, rows])[:, None, :] + self._subpixel[None]).reshape(-1, 2)
        finer, _ = self._shade(origin, camera.rays(pixels) @ to_world)
        linear[rows * camera.width + cols] = finer.reshape(len(rows), len(self._subpixel), 3).mean(axis=1)
        linear = linear.reshape(camera.height, camera.width, 3)
        if self._blur_px > 0:
            import cv2

            linear = cv2.GaussianBlur(linear, (0, 0), self._blur_px)
        if self._shot_noise > 0:
            rng = rng or np.random.default_rng(0)
            linear = linear + self._shot_noise * np.sqrt(np.maximum(linear, 0)) * rng.standard_normal(linear.shape, np.float32)
        return linear_to_srgb8(linear)

    def _shade(self, origin: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Linear RGB of each ray, and a label (2 x part + sunlit; -1 for the sky) for finding edges."""
        hits = self._caster.first_hits(origin, directions)
        hit = np.flatnonzero(hits.hit)
        triangle = hits.triangle[hit]
        weights = hits.barycentric[hit]
        corners = self._corner_uv[triangle]
        uv = corners[:, 0] + (corners[:, 1] - corners[:, 0]) * weights[:, :1] + (corners[:, 2] - corners[:, 0]) * weights[:, 1:]
        part = self._part_of_face[triangle]
        albedo = np.empty((len(hit), 3), np.float32)
        for index, texture in enumerate(self._textures):
            on = np.flatnonzero(part == index)
            albedo[on] = _texture_lookup(texture, uv[on], self._closest[index])
        rays = np.asarray(directions[hit], np.float32)
        normals = self._normals[triangle]
        normals[np.einsum("nd,nd->n", normals, rays) > 0] *= -1  # the side the camera sees
        cos_sun = normals @ self._to_sun
        facing = np.flatnonzero(cos_sun > 0)
        points = origin + hits.t[hit[facing], None] * rays[facing] + _SHADOW_RAY_OFFSET_M * normals[facing]
        sunlit = facing[~np.isfinite(self._caster.hit_distances(points, np.broadcast_to(self._to_sun, points.shape)))]
        light = np.full(len(hit), self._lighting.sky_radiance, np.float32)
        light[sunlit] += self._lighting.sun_irradiance_w_m2 / np.pi * cos_sun[sunlit]
        linear = np.full((len(directions), 3), self._lighting.sky_radiance, np.float32)
        linear[hit] = albedo * light[:, None]
        label = np.full(len(directions), -1, np.int64)
        label[hit] = 2 * part
        label[hit[sunlit]] += 1
        return linear, label
