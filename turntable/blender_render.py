"""Colour frames of a simulated turntable capture, rendered by Blender's Cycles on the CPU
(through `homemodel.geometry.cycles_scene`).

The scene is built in the table frame and stays still; the camera and its lights move
around it (the same images as a fixed tripod and a turning table), keyed per frame.

Colour management is "Raw" (linear, no view transform): an sRGB view transform bends the
grey levels of anti-aliased tag edges and shifted detected corners by about half a pixel.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from homemodel.geometry import cycles_scene
from turntable.board import TAG_CELLS, Board, tag_bits
from homemodel.geometry.camera import Camera

_QUIET_CELLS = 1  # white cells around each tag's black square
# Albedos of printed paper and toner. Clipped whites pull the tag edges' half-intensity
# crossing into the black, yet the studio key light clips paper white at 255 where it stands
# close (measured: 75 % of the paper pixels of a 320x240 frame at the tests' 0.3 m camera);
# detected corners stay within 0.1-0.2 px of the truth there (tests/test_turntable_accuracy.py).
PAPER_WHITE, INK_BLACK = 0.8, 0.04
TABLE_GREY, FLOOR_GREY = 0.75, 0.3
LIGHT_SIZE_M = 0.3  # side of each square area light


@dataclass(kw_only=True)
class RenderScene:
    """What to render, all in the table frame."""

    object_mesh: trimesh.Trimesh
    object_rgba: np.ndarray  # (V, 4) linear colours in [0, 1]
    table_mesh: trimesh.Trimesh
    floor_mesh: trimesh.Trimesh
    board: Board
    camera: Camera
    table_from_cameras: Sequence[np.ndarray]  # OpenCV camera frames, one per output frame
    table_from_lights: Sequence[Sequence[np.ndarray]]  # per frame, each light's frame, z towards what it lights
    light_power_w: Sequence[float]
    ambient_strength: float
    samples: int
    seed: int


def render_colour_frames(scene: RenderScene, color_dir: Path, progress: Callable[[int], None] | None = None) -> None:
    """Write `color_dir/000000.png ...`, 8-bit RGB, one per camera pose."""
    camera = scene.camera
    with cycles_scene.empty_scene():
        cycles_scene.set_up_cycles(
            cycles_scene.CyclesSettings(
                width_px=camera.width,
                height_px=camera.height,
                samples=scene.samples,
                seed=scene.seed,
                max_bounces=2,
                diffuse_bounces=1,
                glossy_bounces=1,
                view_transform="Raw",
            )
        )
        cycles_scene.set_world((1.0, 1.0, 1.0), scene.ambient_strength)
        object_material = cycles_scene.matte_material("object", cycles_scene.VERTEX_COLOURS, shader="principled")
        cycles_scene.add_mesh(
            "object",
            scene.object_mesh.vertices,
            scene.object_mesh.faces,
            object_material,
            vertex_rgba=scene.object_rgba,
            smooth=True,
        )
        for name, mesh, grey in (("table", scene.table_mesh, TABLE_GREY), ("floor", scene.floor_mesh, FLOOR_GREY)):
            material = cycles_scene.matte_material(name, (grey, grey, grey), shader="principled")
            cycles_scene.add_mesh(name, mesh.vertices, mesh.faces, material, smooth=True)
        _add_tags(scene.board)
        blender_camera = cycles_scene.add_camera(camera.matrix, camera.width, camera.height)
        lights = [
            cycles_scene.add_area_light(f"light_{i}", power_w, LIGHT_SIZE_M)
            for i, power_w in enumerate(scene.light_power_w)
        ]
        for frame, table_from_camera in enumerate(scene.table_from_cameras):
            cycles_scene.set_pose(blender_camera, table_from_camera, frame)
            for light, table_from_light in zip(lights, scene.table_from_lights[frame]):
                cycles_scene.set_pose(light, table_from_light, frame)
        paths = [Path(color_dir) / f"{frame:06d}.png" for frame in range(len(scene.table_from_cameras))]
        cycles_scene.render_frames(paths, progress)


@dataclass(kw_only=True)
class TagQuads:
    """The board's tags as one quad each at z = 0 (table frame), textured from one atlas."""

    vertices: np.ndarray  # (4T, 3)
    faces: np.ndarray  # (T, 4) corners counter-clockwise seen from above
    uvs: np.ndarray  # (4T, 2), v = 1 at the atlas's top row
    atlas: np.ndarray  # (rows, columns) float32 albedo, row 0 at the top


def tag_quads(board: Board) -> TagQuads:
    """Each tag with its quiet zone as a quad whose atlas block puts every cell edge exactly
    where board.yaml puts it (looked up nearest-texel)."""
    block = TAG_CELLS + 2 * _QUIET_CELLS
    columns = int(np.ceil(np.sqrt(len(board.tags))))
    rows = int(np.ceil(len(board.tags) / columns))
    atlas = np.full((rows * block, columns * block), PAPER_WHITE, dtype=np.float32)
    vertices, uvs = [], []
    half = board.tag_size_m / 2 * block / TAG_CELLS
    for index, tag in enumerate(board.tags):
        row, col = divmod(index, columns)
        r0, c0 = row * block + _QUIET_CELLS, col * block + _QUIET_CELLS
        atlas[r0 : r0 + TAG_CELLS, c0 : c0 + TAG_CELLS] = np.where(tag_bits(tag.id), PAPER_WHITE, INK_BLACK)
        cx, cy = tag.center_m
        vertices += [
            (cx - half, cy - half, 0.0),
            (cx + half, cy - half, 0.0),
            (cx + half, cy + half, 0.0),
            (cx - half, cy + half, 0.0),
        ]
        # Atlas row 0 is the top of a tag, at v = 1.
        u0, u1 = col * block / atlas.shape[1], (col + 1) * block / atlas.shape[1]
        v_top = 1.0 - row * block / atlas.shape[0]
        v_bottom = 1.0 - (row + 1) * block / atlas.shape[0]
        uvs += [(u0, v_bottom), (u1, v_bottom), (u1, v_top), (u0, v_top)]
    faces = np.arange(len(vertices)).reshape(-1, 4)
    return TagQuads(vertices=np.array(vertices), faces=faces, uvs=np.array(uvs), atlas=atlas)


def _add_tags(board: Board) -> None:
    quads = tag_quads(board)
    image = cycles_scene.image_from_array("tag_atlas", quads.atlas)
    material = cycles_scene.matte_material("tags", image, shader="principled", interpolation="Closest")
    cycles_scene.add_mesh("tags", quads.vertices, quads.faces, material, uv=quads.uvs)
