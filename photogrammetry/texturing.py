"""A UV atlas (`chart_atlas`) and a colour texture baked from the photos by projection.

Every texel is placed on the mesh (its triangle and barycentric coordinates), projected into
every view, and kept from the views that see it unoccluded (a ray-cast depth buffer per view),
weighted by how squarely the view faces the surface (cos^4 of the view angle), so grazing
and occluded views do not smear the texture.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
import trimesh

from homemodel.core.checks import require_at_least, require_between
from homemodel.core.errors import ModelError
from homemodel.core.progress import Progress
from homemodel.geometry.camera import Camera
from homemodel.geometry.raycast import RayCaster
from homemodel.geometry.uv_atlas import atlas_texels
from homemodel.geometry.chart_atlas import chart_atlas
from photogrammetry.photos import read_rgb
from photogrammetry.sfm import View


@dataclass(kw_only=True)
class TextureBakingOptions:
    size_px: int = 2048
    depth_buffer_px: int = 480  # longer side of the per-view visibility depth buffers
    max_image_px: int = 1600  # colour is sampled from the photos shrunk to this longer side
    min_cos: float = 0.15  # views more grazing than this never contribute
    padding_px: int = 4

    def check(self) -> None:
        require_at_least("size_px", self.size_px, 64)
        require_at_least("depth_buffer_px", self.depth_buffer_px, 16)
        require_at_least("max_image_px", self.max_image_px, 16)
        require_between("min_cos", self.min_cos, 0.0, 1.0)
        require_at_least("padding_px", self.padding_px, 0)


@dataclass(kw_only=True)
class TexturedMesh:
    mesh: trimesh.Trimesh  # vertices split along the atlas seams
    uv: np.ndarray  # (V, 2), OpenGL convention (v up)
    texture: np.ndarray  # (size, size, 3) uint8 RGB
    covered_share: float  # share of the atlas texels that some view saw


def _depth_buffer(caster: RayCaster, view: View, max_side_px: int) -> tuple[np.ndarray, Camera]:
    """Ray-cast depth (along the optical axis) of the mesh in a shrunk view, and that view's camera."""
    camera = view.camera.scaled(min(1.0, max_side_px / max(view.camera.width, view.camera.height)))
    depth = caster.depth(camera, view.camera_from_world)
    depth[np.isnan(depth)] = np.inf  # a pixel that misses the mesh hides nothing
    return depth, camera


def bake_texture(
    mesh: trimesh.Trimesh,
    views: list[View],
    options: TextureBakingOptions | None = None,
    progress: Progress | None = None,
    *,
    workers: int = 1,
) -> TexturedMesh:
    """UV-unwrap `mesh` and colour its texture from the `views` (poses in the mesh's frame),
    `workers` views at a time; progress stage "texturing"."""
    options = options or TextureBakingOptions()
    atlas = chart_atlas(mesh, size_px=options.size_px, padding_px=options.padding_px)
    texels = atlas_texels(atlas, options.size_px)
    points = texels.points
    normals = texels.interpolate(atlas.mesh.vertex_normals)
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    caster = RayCaster(mesh)
    # Every view tests every texel: in float32, about the texels' mean (no precision lost), with
    # the texel-wide terms made once, so that a view costs three products with its pose and
    # centre; only the texels that face it are then projected. Facing: n . (c - p) > min_cos
    # |c - p|, where |c - p|^2 = |p|^2 - 2 p . c + |c|^2.
    origin = points.mean(axis=0)
    points32, normals32 = (points - origin).astype(np.float32), normals.astype(np.float32)
    normal_dot_point = np.einsum("ij,ij->i", normals32, points32)
    point_square = np.einsum("ij,ij->i", points32, points32)

    def view_colours(view: View) -> tuple[np.ndarray, np.ndarray]:
        """The texels `view` sees unoccluded, and their weighted colours and weights (N, 4)."""
        depth, depth_camera = _depth_buffer(caster, view, options.depth_buffer_px)
        rotation = view.camera_from_world[:3, :3].astype(np.float32)
        translation = (view.camera_from_world[:3, :3] @ origin + view.camera_from_world[:3, 3]).astype(np.float32)
        centre = (view.centre_world - origin).astype(np.float32)
        z = points32 @ rotation[2] + translation[2]
        facing = normals32 @ centre - normal_dot_point
        distance = np.sqrt(np.maximum(point_square - 2 * (points32 @ centre) + centre @ centre, 1e-30))
        usable = np.nonzero((z > 0) & (facing > options.min_cos * distance))[0]
        camera_points = points32[usable] @ rotation.T + translation
        # The views are pinhole (undistorted): a pixel is f x / z + c in any of their sizes.
        x, y = camera_points[:, 0] / camera_points[:, 2], camera_points[:, 1] / camera_points[:, 2]
        col = np.rint(depth_camera.fx * x + depth_camera.cx).astype(np.int32)
        row = np.rint(depth_camera.fy * y + depth_camera.cy).astype(np.int32)
        inside = np.nonzero((col >= 0) & (col < depth.shape[1]) & (row >= 0) & (row < depth.shape[0]))[0]
        # Visible: nothing in front of the texel along this pixel's ray (a tolerance for the
        # depth buffer's coarser sampling of the surface).
        seen = inside[camera_points[inside, 2] <= depth[row[inside], col[inside]] * 1.01 + 1e-9]
        visible = usable[seen]
        if not len(visible):
            return visible, np.zeros((0, 4), np.float32)
        image = read_rgb(view.image_path, max_side_px=options.max_image_px)
        camera = view.camera.scaled(image.shape[1] / view.camera.width)
        xy = np.column_stack([camera.fx * x[seen] + camera.cx, camera.fy * y[seen] + camera.cy])
        weighted = np.empty((len(visible), 4), np.float32)
        weighted[:, 3] = (facing[visible] / distance[visible]) ** 4
        weighted[:, :3] = _sample_bilinear(image, xy) * weighted[:, 3:]
        return visible, weighted

    sums = np.zeros((len(points), 4), np.float32)  # weighted colour, weight
    # Views on every core (numpy, the ray caster and OpenCV release the GIL); sums in this thread.
    with ThreadPoolExecutor(max_workers=workers) as pool:
        for index, (visible, weighted) in enumerate(pool.map(view_colours, views)):
            sums[visible] += weighted
            if progress:
                progress("texturing", index + 1, len(views))
    colour_sum, weight_sum = sums[:, :3].astype(np.float64), sums[:, 3].astype(np.float64)
    seen = weight_sum > 0
    if not seen.any():
        raise ModelError("no view sees the mesh: cannot bake a texture")
    colours = np.zeros((len(points), 3))
    colours[seen] = colour_sum[seen] / weight_sum[seen, None]
    colours[~seen] = colours[seen].mean(axis=0)  # texels no photo saw (the bottom): the mean colour
    texture = texels.paint(np.clip(colours, 0, 255).astype(np.uint8), gutter_px=options.padding_px)
    return TexturedMesh(mesh=atlas.mesh, uv=atlas.uv, texture=texture, covered_share=float(seen.mean()))


def _sample_bilinear(image: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Colours at sub-pixel positions (cv2.remap, its maps folded into rows under its size limit)."""
    import cv2

    width = 4096
    count = len(xy)
    padded = np.zeros((-(-count // width) * width, 2), np.float32)
    padded[:count] = xy
    maps = padded.reshape(-1, width, 2)
    sampled = cv2.remap(image, maps[..., 0], maps[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
    return sampled.reshape(-1, image.shape[2])[:count].astype(np.float32)
