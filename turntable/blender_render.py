"""Colour frames of a simulated turntable capture, rendered by Blender's Cycles on the CPU.

The scene is built in the table frame and stays still; the camera and its lights move
around it (the same images as a fixed tripod and a turning table). Frames are one
animation render so Cycles keeps its scene between frames (`use_persistent_data`).

Colour management is "Raw" (linear, no view transform): an sRGB view transform bends the
grey levels of anti-aliased tag edges and shifted detected corners by about half a pixel.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from homemodel.core.c_stdio_capture import captured_c_output
from turntable.board import TAG_CELLS, Board, tag_bits
from homemodel.geometry.camera import Camera

# A Blender camera looks down its -z with y up; an OpenCV camera looks down +z with y down.
_OPENCV_FROM_BLENDER_CAMERA = np.diag([1.0, -1.0, -1.0, 1.0])
_QUIET_CELLS = 1  # white cells around each tag's black square
# Albedos of printed paper and toner. Lights are set so white stays well below 8-bit
# saturation: clipped whites pull the tag edges' half-intensity crossing into the black.
_PAPER_WHITE, _INK_BLACK = 0.8, 0.04


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
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bscene = bpy.context.scene
    _setup_render(bscene, scene)
    bscene.collection.objects.link(
        _mesh_object("object", scene.object_mesh, _vertex_colour_material(), scene.object_rgba)
    )
    bscene.collection.objects.link(_mesh_object("table", scene.table_mesh, _plain_material("table", 0.75)))
    bscene.collection.objects.link(_mesh_object("floor", scene.floor_mesh, _plain_material("floor", 0.3)))
    bscene.collection.objects.link(_tag_object(scene.board))
    camera = _camera_object(scene.camera)
    bscene.collection.objects.link(camera)
    bscene.camera = camera
    lights = [_light_object(f"light_{i}", power) for i, power in enumerate(scene.light_power_w)]
    for light in lights:
        bscene.collection.objects.link(light)
    for frame, table_from_camera in enumerate(scene.table_from_cameras):
        _key_pose(camera, table_from_camera @ _OPENCV_FROM_BLENDER_CAMERA, frame)
        for light, table_from_light in zip(lights, scene.table_from_lights[frame]):
            _key_pose(light, table_from_light @ _OPENCV_FROM_BLENDER_CAMERA, frame)
    bscene.frame_start, bscene.frame_end = 0, len(scene.table_from_cameras) - 1
    bscene.render.filepath = str(Path(color_dir) / "######")

    written = [0]

    def _on_write(*_args: object) -> None:
        written[0] += 1
        if progress is not None:
            progress(written[0])

    bpy.app.handlers.render_write.append(_on_write)
    try:
        # Blender logs every tile and saved file on fds 1 and 2; the library does not print.
        with captured_c_output():
            bpy.ops.render.render(animation=True)
    finally:
        bpy.app.handlers.render_write.remove(_on_write)
        bpy.ops.wm.read_factory_settings(use_empty=True)


def _setup_render(bscene, scene: RenderScene) -> None:  # noqa: ANN001 (bpy types)
    import bpy

    render = bscene.render
    render.engine = "CYCLES"
    render.resolution_x, render.resolution_y = scene.camera.width, scene.camera.height
    render.resolution_percentage = 100
    render.pixel_aspect_x = render.pixel_aspect_y = 1.0
    render.use_persistent_data = True
    render.image_settings.file_format = "PNG"
    render.image_settings.color_mode = "RGB"
    render.image_settings.color_depth = "8"
    cycles = bscene.cycles
    cycles.device = "CPU"
    cycles.samples = scene.samples
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = False
    cycles.seed = scene.seed
    cycles.max_bounces = 2
    cycles.diffuse_bounces = 1
    cycles.glossy_bounces = 1
    cycles.transmission_bounces = 0
    cycles.volume_bounces = 0
    cycles.transparent_max_bounces = 0
    bscene.view_settings.view_transform = "Raw"
    bscene.view_settings.look = "None"
    bscene.view_settings.exposure = 0.0
    bscene.view_settings.gamma = 1.0
    world = bpy.data.worlds.new("world")
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    background.inputs["Strength"].default_value = scene.ambient_strength
    bscene.world = world


def _mesh_object(name: str, mesh: trimesh.Trimesh, material, rgba: np.ndarray | None = None):  # noqa: ANN001, ANN202
    import bpy

    data = bpy.data.meshes.new(name)
    vertices = np.asarray(mesh.vertices, dtype=np.float32)
    faces = np.asarray(mesh.faces, dtype=np.int32)
    data.vertices.add(len(vertices))
    data.vertices.foreach_set("co", vertices.ravel())
    data.loops.add(faces.size)
    data.loops.foreach_set("vertex_index", faces.ravel())
    data.polygons.add(len(faces))
    data.polygons.foreach_set("loop_start", np.arange(0, faces.size, 3, dtype=np.int32))
    data.polygons.foreach_set("loop_total", np.full(len(faces), 3, dtype=np.int32))
    if rgba is not None:
        colours = data.color_attributes.new("Col", "FLOAT_COLOR", "POINT")
        colours.data.foreach_set("color", np.asarray(rgba, dtype=np.float32).ravel())
    data.update()
    data.validate()
    data.materials.append(material)
    return bpy.data.objects.new(name, data)


def _principled(name: str):  # noqa: ANN202
    import bpy

    material = bpy.data.materials.new(name)
    bsdf = material.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Roughness"].default_value = 0.8
    bsdf.inputs["Specular IOR Level"].default_value = 0.1
    return material, bsdf


def _plain_material(name: str, grey: float):  # noqa: ANN202
    material, bsdf = _principled(name)
    bsdf.inputs["Base Color"].default_value = (grey, grey, grey, 1.0)
    return material


def _vertex_colour_material():  # noqa: ANN202
    material, bsdf = _principled("object")
    attribute = material.node_tree.nodes.new("ShaderNodeAttribute")
    attribute.attribute_name = "Col"
    material.node_tree.links.new(attribute.outputs["Color"], bsdf.inputs["Base Color"])
    return material


def _tag_object(board: Board):  # noqa: ANN202
    """All tags as quads at z = 0, textured from one atlas with nearest-texel lookup, so each
    cell edge lies exactly where board.yaml puts it."""
    import bpy

    block = TAG_CELLS + 2 * _QUIET_CELLS
    columns = int(np.ceil(np.sqrt(len(board.tags))))
    rows = int(np.ceil(len(board.tags) / columns))
    atlas = np.full((rows * block, columns * block), _PAPER_WHITE, dtype=np.float32)
    vertices, faces, uvs = [], [], []
    half = board.tag_size_m / 2 * block / TAG_CELLS
    for index, tag in enumerate(board.tags):
        row, col = divmod(index, columns)
        r0, c0 = row * block + _QUIET_CELLS, col * block + _QUIET_CELLS
        atlas[r0 : r0 + TAG_CELLS, c0 : c0 + TAG_CELLS] = np.where(tag_bits(tag.id), _PAPER_WHITE, _INK_BLACK)
        cx, cy = tag.center_m
        base = len(vertices)
        vertices += [
            (cx - half, cy - half, 0.0),
            (cx + half, cy - half, 0.0),
            (cx + half, cy + half, 0.0),
            (cx - half, cy + half, 0.0),
        ]
        faces.append((base, base + 1, base + 2, base + 3))
        # Atlas row 0 is the top of a tag; Blender images start at the bottom row.
        u0, u1 = col * block / atlas.shape[1], (col + 1) * block / atlas.shape[1]
        v_top = 1.0 - row * block / atlas.shape[0]
        v_bottom = 1.0 - (row + 1) * block / atlas.shape[0]
        uvs += [(u0, v_bottom), (u1, v_bottom), (u1, v_top), (u0, v_top)]
    data = bpy.data.meshes.new("tags")
    data.from_pydata(vertices, [], faces)
    uv_layer = data.uv_layers.new(name="UVMap")
    uv_layer.data.foreach_set("uv", np.asarray(uvs, dtype=np.float32).ravel())
    image = bpy.data.images.new("tag_atlas", atlas.shape[1], atlas.shape[0], alpha=False, float_buffer=True)
    image.colorspace_settings.name = "Non-Color"
    rgba = np.repeat(atlas[::-1, :, None], 4, axis=2)
    rgba[..., 3] = 1.0
    image.pixels.foreach_set(rgba.ravel())
    image.pack()
    material, bsdf = _principled("tags")
    texture = material.node_tree.nodes.new("ShaderNodeTexImage")
    texture.image = image
    texture.interpolation = "Closest"
    material.node_tree.links.new(texture.outputs["Color"], bsdf.inputs["Base Color"])
    data.materials.append(material)
    return bpy.data.objects.new("tags", data)


def _camera_object(camera: Camera):  # noqa: ANN202
    """A Blender camera with the intrinsics of `camera` (square pixels)."""
    import bpy

    if not np.isclose(camera.fx, camera.fy, rtol=1e-9):
        raise ValueError(f"Blender renders square pixels only: {camera.fx=} != {camera.fy=}")
    data = bpy.data.cameras.new("camera")
    data.sensor_fit = "HORIZONTAL"
    data.sensor_width = 36.0
    data.lens = camera.fx * data.sensor_width / camera.width
    # OpenCV puts pixel centres at integers, Blender at half-integers: its principal point
    # is at cx + 0.5. Shifts are in units of the larger image side.
    side = max(camera.width, camera.height)
    data.shift_x = (camera.width / 2 - (camera.cx + 0.5)) / side
    data.shift_y = ((camera.cy + 0.5) - camera.height / 2) / side
    data.clip_start, data.clip_end = 0.01, 50.0
    obj = bpy.data.objects.new("camera", data)
    obj.rotation_mode = "QUATERNION"
    return obj


def _light_object(name: str, power_w: float):  # noqa: ANN202
    import bpy

    data = bpy.data.lights.new(name, "AREA")
    data.energy = power_w
    data.size = 0.3
    obj = bpy.data.objects.new(name, data)
    obj.rotation_mode = "QUATERNION"
    return obj


def _key_pose(obj, table_from_obj: np.ndarray, frame: int) -> None:  # noqa: ANN001
    from mathutils import Matrix

    obj.matrix_world = Matrix(table_from_obj.tolist())
    obj.keyframe_insert("location", frame=frame)
    obj.keyframe_insert("rotation_quaternion", frame=frame)
