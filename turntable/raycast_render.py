"""Colour frames of a simulated turntable capture by ray casting (open3d's Embree, through
`homemodel.geometry.raycast`): the scene `blender_render` gives Cycles, drawn without Blender
for a fraction of its CPU time.

A ray's hit gives its albedo (the object's vertex colours interpolated, the tag atlas looked
up nearest-texel as Cycles does, the table and floor greys) and its shading: Lambert from each
light, taken as a point at its centre with a shadow ray (hard shadows), plus the white world's
ambient light, unoccluded. The radiometry is Cycles': a light of power P has radiance
P / (pi A), so a surface of albedo a at distance d sends a P cos(light) cos(surface) /
(pi^2 d^2) (Cycles gave 0.95 of this under a 0.3 m light 1 m above a plane: the light's area).
No indirect bounce, no specular, no noise. Values are written linear ("Raw", as the Cycles path).

One ray goes through each pixel centre; where a pixel's 4-neighbours see another surface, tag
cell colour, shadow or depth, the pixel is drawn again as the mean of SUPERSAMPLING x
SUPERSAMPLING rays on a regular grid inside it: a box filter, symmetric about the pixel centre,
so anti-aliased tag edges keep their place (detected corners lie as close to the truth as
Cycles' at 16 samples, closer than at 2-4: docs/turntable.md, tests/test_turntable_accuracy.py).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from homemodel.geometry.raycast import Hits, RayCaster, changing_pixels, subpixel_offsets
from turntable.blender_render import FLOOR_GREY, INK_BLACK, PAPER_WHITE, TABLE_GREY, RenderScene, tag_quads

SUPERSAMPLING = 3  # rays per pixel along each axis, where a pixel holds an edge
_RAYS_PER_CHUNK = 1 << 20  # bounds the memory of one cast
_OFFSET_M = 1e-4  # secondary rays start this far off the surface (the tags lie 5e-5 m above the table)


@dataclass(kw_only=True)
class _Surfaces:
    """The scene as one triangle mesh, with what each triangle's albedo comes from."""

    mesh: trimesh.Trimesh
    object_faces: np.ndarray  # (F_object, 3), a plain array: trimesh's tracked one is slow to index
    first_table: int  # faces [0, first_table) are the object's
    first_floor: int
    first_tag: int
    object_rgb: np.ndarray  # (V_object, 3) linear
    object_normals: np.ndarray  # (V_object, 3) unit vertex normals (Cycles' smooth shading)
    tag_uvs: np.ndarray  # (T * 2, 3, 2) each tag triangle's corner UVs
    atlas: np.ndarray

    @classmethod
    def of(cls, scene: RenderScene) -> _Surfaces:
        quads = tag_quads(scene.board)
        triangles = np.concatenate([quads.faces[:, [0, 1, 2]], quads.faces[:, [0, 2, 3]]], axis=1).reshape(-1, 3)
        tags = trimesh.Trimesh(quads.vertices, triangles, process=False)
        parts = [scene.object_mesh, scene.table_mesh, scene.floor_mesh, tags]
        firsts = np.cumsum([0] + [len(p.faces) for p in parts])
        return cls(
            mesh=trimesh.util.concatenate(parts),
            object_faces=np.asarray(scene.object_mesh.faces, dtype=np.int64).copy(),
            first_table=int(firsts[1]),
            first_floor=int(firsts[2]),
            first_tag=int(firsts[3]),
            object_rgb=np.asarray(scene.object_rgba, dtype=np.float64)[:, :3],
            object_normals=np.asarray(scene.object_mesh.vertex_normals, dtype=np.float64),
            tag_uvs=quads.uvs[triangles],
            atlas=quads.atlas,
        )

    def albedo_and_normal(self, hits: Hits) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(N, 3) linear albedo, (N, 3) shading normal and (N,) surface of each hit (rays that
        hit): 0 object, 1 table, 2 floor, 3 a tag's paper, 4 its ink."""
        face = hits.triangle
        weights = np.column_stack([1.0 - hits.barycentric.sum(axis=1), hits.barycentric]).astype(np.float64)
        albedo = np.empty((len(face), 3))
        normal = hits.normals.astype(np.float64)
        on_object = face < self.first_table
        corners = self.object_faces[face[on_object]]
        w = weights[on_object]
        albedo[on_object] = np.einsum("ijk,ij->ik", self.object_rgb[corners], w)
        smooth = np.einsum("ijk,ij->ik", self.object_normals[corners], w)
        normal[on_object] = smooth / np.maximum(np.sqrt(np.einsum("ij,ij->i", smooth, smooth)), 1e-12)[:, None]
        surface = np.searchsorted([self.first_table, self.first_floor, self.first_tag], face, side="right")
        albedo[surface == 1] = TABLE_GREY
        albedo[surface == 2] = FLOOR_GREY
        on_tag = face >= self.first_tag
        uv = np.einsum("ijk,ij->ik", self.tag_uvs[face[on_tag] - self.first_tag], weights[on_tag])
        rows, columns = self.atlas.shape
        row = np.clip(((1.0 - uv[:, 1]) * rows).astype(np.int64), 0, rows - 1)
        column = np.clip((uv[:, 0] * columns).astype(np.int64), 0, columns - 1)
        texel = self.atlas[row, column]
        albedo[on_tag] = texel[:, None]
        surface[on_tag] += texel < (PAPER_WHITE + INK_BLACK) / 2
        return albedo, normal, surface


def render_colour_frames_raycast(
    scene: RenderScene, color_dir: Path, progress: Callable[[int], None] | None = None
) -> None:
    """Write `color_dir/000000.png ...`, 8-bit RGB, one per camera pose (as `render_colour_frames`)."""
    import cv2

    surfaces = _Surfaces.of(scene)
    caster = RayCaster(surfaces.mesh)
    camera = scene.camera
    sub_x, sub_y = subpixel_offsets(SUPERSAMPLING).T
    v, u = np.mgrid[0 : camera.height, 0 : camera.width]
    centres = camera.rays(np.column_stack([u.ravel(), v.ravel()]).astype(np.float64))
    for frame, table_from_camera in enumerate(scene.table_from_cameras):
        lights = list(zip(scene.table_from_lights[frame], scene.light_power_w))
        shade = lambda rays: _shade(scene, surfaces, caster, lights, table_from_camera, rays)  # noqa: E731
        radiance, key, depth = shade(centres)
        image = radiance.reshape(camera.height, camera.width, 3)
        # Only pixels whose neighbourhood changes surface, tag cell, shadow or depth need more rays.
        shape = (camera.height, camera.width)
        edge = np.flatnonzero(changing_pixels(key.reshape(shape), depth.reshape(shape)))
        for first in range(0, len(edge), _RAYS_PER_CHUNK // len(sub_x)):
            pixels = edge[first : first + _RAYS_PER_CHUNK // len(sub_x)]
            samples = np.stack([u.ravel()[pixels, None] + sub_x, v.ravel()[pixels, None] + sub_y], axis=-1)
            sampled, _, _ = shade(camera.rays(samples.reshape(-1, 2)))
            image.reshape(-1, 3)[pixels] = sampled.reshape(len(pixels), len(sub_x), 3).mean(axis=1)
        rgb = np.round(np.clip(image, 0.0, 1.0) * 255).astype(np.uint8)
        cv2.imwrite(str(Path(color_dir) / f"{frame:06d}.png"), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
        if progress is not None:
            progress(frame + 1)


def _shade(
    scene: RenderScene,
    surfaces: _Surfaces,
    caster: RayCaster,
    lights: list[tuple[np.ndarray, float]],
    table_from_camera: np.ndarray,
    rays_camera: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Along each camera ray (z = 1 in the camera frame): (N, 3) linear radiance, (N,) int key
    of what it sees (surface, tag cell colour, lit or not; -1: nothing) and (N,) depth."""
    origin = table_from_camera[:3, 3]
    directions = rays_camera @ table_from_camera[:3, :3].T
    hits = caster.first_hits(origin, directions)
    radiance = np.full((len(directions), 3), scene.ambient_strength)  # the white world behind
    key = np.full(len(directions), -1, dtype=np.int64)
    hit = hits.hit
    hits = Hits(
        t=hits.t[hit], triangle=hits.triangle[hit], barycentric=hits.barycentric[hit], normals=hits.normals[hit]
    )
    albedo, normal, surface = surfaces.albedo_and_normal(hits)
    # Surfaces are two-sided: turn the normals to the side the camera sees.
    seen = directions[hit]
    facing = np.einsum("ij,ij->i", hits.normals, seen) > 0
    normal[facing] *= -1.0
    start = seen * hits.t[:, None]
    start += origin
    start += _OFFSET_M * normal
    light = np.full(len(start), scene.ambient_strength)
    lit_by = np.zeros(len(start), dtype=np.int64)
    for index, (table_from_light, power_w) in enumerate(lights):
        irradiance = _light(caster, table_from_light, power_w, start, normal)
        light += irradiance
        lit_by |= (irradiance > 0).astype(np.int64) << index
    radiance[hit] = albedo * light[:, None]
    key[hit] = surface + 8 * lit_by
    depth = np.full(len(directions), np.nan)
    depth[hit] = hits.t
    return radiance, key, depth


def _light(
    caster: RayCaster, table_from_light: np.ndarray, power_w: float, start: np.ndarray, normal: np.ndarray
) -> np.ndarray:
    """Irradiance / pi at each point from a light shining along its z, taken as a point at its centre."""
    to_light = table_from_light[:3, 3] - start
    distance = np.sqrt(np.einsum("ij,ij->i", to_light, to_light))
    to_light /= distance[:, None]
    cos_surface = np.einsum("ij,ij->i", to_light, normal)
    cos_light = -to_light @ table_from_light[:3, 2]
    lit = (cos_surface > 0) & (cos_light > 0)
    if lit.any():
        blocked = caster.hit_distances(start[lit], to_light[lit]) < distance[lit]
        lit[np.flatnonzero(lit)[blocked]] = False
    return np.where(lit, power_w * cos_surface * cos_light / (np.pi**2 * distance**2), 0.0)
