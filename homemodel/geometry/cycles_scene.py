"""Cycles scenes of meshes for the simulators, rendered headless on the CPU: the one module
outside `modeller/` and `blender_addons/` that imports bpy.

`turntable.blender_render` (simulated turntable captures) and `photogrammetry.synthetic_scene`
(a rendered photo set with ground truth) build their scenes with these functions and keep only
their content (the tag board, the markers, the lights) to themselves.

Poses are `world_from_x` 4x4 arrays in the OpenCV convention for cameras and lights alike:
x right, y down, z forward (where a camera looks, where a light shines). Blender's cameras and
lights look down their -z with y up. bpy and mathutils are imported inside the functions: the
import is heavy, and everything else in homemodel runs without Blender.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from homemodel.core.c_stdio_capture import captured_c_output
from homemodel.core.interrupts import interrupts_deferred

OPENCV_FROM_BLENDER = np.diag([1.0, -1.0, -1.0, 1.0])
VERTEX_COLOURS = "Col"  # the colour attribute add_mesh writes; a `colour` for matte_material


def rendering_code_digest(*scene_modules: str | Path) -> str:
    """A hash of this module's source and of the modules that build a scene with it: key a cache
    of rendered images on it so that a change to the renderer renders them again."""
    digest = hashlib.sha256(Path(__file__).read_bytes())
    for path in scene_modules:
        digest.update(Path(path).read_bytes())
    return digest.hexdigest()[:16]


def import_bpy():  # noqa: ANN201 (the bpy module)
    """bpy, imported with Ctrl-C held until it has started (see `interrupts_deferred`). Every
    Blender scene starts here, so the first import in a process is always this one."""
    with interrupts_deferred():
        import bpy
    return bpy


# What Blender's factory settings with an empty scene hold: the scene and the UI's datablocks.
FACTORY_DATABLOCKS = ("scenes", "screens", "window_managers", "workspaces")
# The scene of the last factory reset (its session_uid) while only datablocks have been added
# to it (objects, meshes, materials, images: what builds do); None once a block that may change
# its own settings (a render's `empty_scene`) has started. A file opened since has other scenes.
_factory_scene: int | None = None


def reset_to_empty_scene() -> None:
    """An empty scene as Blender's factory settings give it. The factory reset takes about
    75 ms: it registers Blender's add-ons again, in Python called from C (Ctrl-C is held
    meanwhile, as for the import, since an interrupt inside it is printed as a traceback and
    swallowed). So it runs only when the scene may differ from the factory's in more than the
    datablocks added to it; otherwise those are removed, in about a millisecond."""
    global _factory_scene
    bpy = import_bpy()
    scenes = bpy.data.scenes
    if _factory_scene is not None and len(scenes) == 1 and scenes[0].session_uid == _factory_scene and not bpy.data.filepath:
        bpy.data.batch_remove([datablock for kind in _datablock_kinds(bpy) for datablock in getattr(bpy.data, kind)])
        return
    with interrupts_deferred():
        bpy.ops.wm.read_factory_settings(use_empty=True)
    _factory_scene = bpy.data.scenes[0].session_uid


def _datablock_kinds(bpy) -> list[str]:  # noqa: ANN001 (the bpy module)
    """bpy.data's collections of datablocks that an empty factory scene has none of."""
    return [
        prop.identifier for prop in bpy.data.bl_rna.properties
        if prop.type == "COLLECTION" and issubclass(type(prop.fixed_type), bpy.types.ID)
        and prop.identifier not in FACTORY_DATABLOCKS
    ]  # fmt: skip


@contextmanager
def empty_scene() -> Iterator[None]:
    """An empty scene for the block, whose renders set the scene's own settings; reset again
    after it, which frees the meshes, images and Cycles' render data."""
    global _factory_scene
    reset_to_empty_scene()
    _factory_scene = None
    try:
        yield
    finally:
        reset_to_empty_scene()


@dataclass(kw_only=True)
class CyclesSettings:
    width_px: int
    height_px: int
    samples: int
    seed: int
    max_bounces: int
    diffuse_bounces: int
    glossy_bounces: int
    # Never a tone curve (Blender's default is AgX): it bends the grey levels of anti-aliased
    # edges, and an sRGB view transform shifted detected tag corners by about half a pixel.
    # "Raw" writes the linear values (the turntable's tags), "Standard" the plain sRGB
    # transfer function (the photo set, like a camera's JPEGs).
    view_transform: Literal["Raw", "Standard"]


def set_up_cycles(settings: CyclesSettings) -> None:
    """Cycles on the CPU with fixed samples, no denoising, 8-bit RGB PNGs."""
    import bpy

    scene = bpy.context.scene
    render = scene.render
    render.engine = "CYCLES"
    render.resolution_x, render.resolution_y = settings.width_px, settings.height_px
    render.resolution_percentage = 100
    render.pixel_aspect_x = render.pixel_aspect_y = 1.0
    render.use_persistent_data = True  # keep the scene between frames; only cameras and lights move
    render.image_settings.file_format = "PNG"
    render.image_settings.color_mode = "RGB"
    render.image_settings.color_depth = "8"
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.samples = settings.samples
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = False
    cycles.seed = settings.seed
    cycles.max_bounces = settings.max_bounces
    cycles.diffuse_bounces = settings.diffuse_bounces
    cycles.glossy_bounces = settings.glossy_bounces
    cycles.transmission_bounces = 0
    cycles.volume_bounces = 0
    cycles.transparent_max_bounces = 0
    scene.view_settings.view_transform = settings.view_transform
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0


def set_world(rgb: tuple[float, float, float], strength: float) -> None:
    """Uniform light from every direction (and the background colour)."""
    import bpy

    world = bpy.data.worlds.new("world")
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (*rgb, 1.0)
    background.inputs["Strength"].default_value = strength
    bpy.context.scene.world = world


def image_from_file(path: Path):  # noqa: ANN201 (bpy type)
    """An 8-bit image file, read as sRGB like any photo or print."""
    import bpy

    return bpy.data.images.load(str(path))


def image_from_array(name: str, linear: np.ndarray):  # noqa: ANN201 (bpy type)
    """A float image of linear values in [0, 1], (H, W) grey or (H, W, 3) RGB, row 0 at the top;
    packed into the scene, used as is (no colour space conversion)."""
    import bpy

    linear = np.asarray(linear, dtype=np.float32)
    rgb = np.repeat(linear[..., None], 3, axis=2) if linear.ndim == 2 else linear
    if rgb.ndim != 3 or rgb.shape[2] != 3:
        raise ValueError(f"{linear.shape=} but expected (H, W) or (H, W, 3)")
    height, width = rgb.shape[:2]
    image = bpy.data.images.new(name, width, height, alpha=False, float_buffer=True)
    image.colorspace_settings.name = "Non-Color"
    rgba = np.ones((height, width, 4), dtype=np.float32)
    rgba[..., :3] = rgb[::-1]  # Blender's images start at the bottom row
    image.pixels.foreach_set(rgba.ravel())
    image.pack()
    return image


def matte_material(
    name: str,
    colour,  # noqa: ANN001 (an RGB tuple, VERTEX_COLOURS or a bpy image)
    *,
    shader: Literal["diffuse", "principled"],
    interpolation: Literal["Linear", "Closest"] = "Linear",
):  # noqa: ANN201 (bpy type)
    """A material of constant, per-vertex or image colour (the mesh's UVs); "diffuse" is pure
    Lambert (cheaper to render), "principled" is a rough surface with a little sheen, like
    paper or painted wood. `interpolation` is the image's: "Closest" keeps printed cell edges
    sharp where they are."""
    import bpy

    material = bpy.data.materials.new(name)
    nodes = material.node_tree.nodes
    if shader == "diffuse":
        nodes.remove(nodes["Principled BSDF"])
        bsdf = nodes.new("ShaderNodeBsdfDiffuse")
        material.node_tree.links.new(bsdf.outputs["BSDF"], nodes["Material Output"].inputs["Surface"])
        colour_input = bsdf.inputs["Color"]
    else:
        bsdf = nodes["Principled BSDF"]
        bsdf.inputs["Roughness"].default_value = 0.8
        bsdf.inputs["Specular IOR Level"].default_value = 0.1
        colour_input = bsdf.inputs["Base Color"]
    if isinstance(colour, tuple):
        colour_input.default_value = (*colour, 1.0)
    elif colour == VERTEX_COLOURS:
        attribute = nodes.new("ShaderNodeAttribute")
        attribute.attribute_name = VERTEX_COLOURS
        material.node_tree.links.new(attribute.outputs["Color"], colour_input)
    else:
        texture = nodes.new("ShaderNodeTexImage")
        texture.image = colour
        texture.interpolation = interpolation
        material.node_tree.links.new(texture.outputs["Color"], colour_input)
    return material


def add_mesh(
    name: str,
    vertices: np.ndarray,
    faces: np.ndarray,
    material,  # noqa: ANN001 (bpy type)
    *,
    uv: np.ndarray | None = None,
    vertex_rgba: np.ndarray | None = None,
    smooth: bool = False,
):  # noqa: ANN201 (bpy type)
    """A mesh object in the scene, in world coordinates: (V, 3) vertices, (F, k) faces of k
    corners, optional (V, 2) UVs and (V, 4) linear colours (VERTEX_COLOURS); flat-shaded unless
    `smooth` (normals interpolated across faces)."""
    import bpy

    vertices = np.asarray(vertices, dtype=np.float32)
    faces = np.asarray(faces, dtype=np.int32)
    if vertices.ndim != 2 or vertices.shape[1] != 3:
        raise ValueError(f"{vertices.shape=} but expected (V, 3)")
    if faces.ndim != 2 or faces.shape[1] < 3:
        raise ValueError(f"{faces.shape=} but expected (F, k) with k >= 3")
    data = bpy.data.meshes.new(name)
    data.vertices.add(len(vertices))
    data.vertices.foreach_set("co", vertices.ravel())
    data.loops.add(faces.size)
    data.loops.foreach_set("vertex_index", faces.ravel())
    data.polygons.add(len(faces))
    data.polygons.foreach_set("loop_start", np.arange(0, faces.size, faces.shape[1], dtype=np.int32))
    data.polygons.foreach_set("loop_total", np.full(len(faces), faces.shape[1], dtype=np.int32))
    if not smooth:
        data.shade_flat()
    if uv is not None:
        layer = data.uv_layers.new(name="UVMap")
        layer.data.foreach_set("uv", np.asarray(uv, dtype=np.float32)[faces.ravel()].ravel())
    if vertex_rgba is not None:
        colours = data.color_attributes.new(VERTEX_COLOURS, "FLOAT_COLOR", "POINT")
        colours.data.foreach_set("color", np.asarray(vertex_rgba, dtype=np.float32).ravel())
    data.update(calc_edges=True)
    data.validate()
    data.materials.append(material)
    obj = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def add_camera(k: np.ndarray, width_px: int, height_px: int):  # noqa: ANN201 (bpy type)
    """The scene's camera, a pinhole with the intrinsics `k` (OpenCV: pixel centres at integers;
    square pixels only). Pose it with `set_pose`."""
    import bpy

    fx, fy, cx, cy = k[0, 0], k[1, 1], k[0, 2], k[1, 2]
    if not np.isclose(fx, fy, rtol=1e-9):
        raise ValueError(f"Blender renders square pixels only: {fx=} != {fy=}")
    data = bpy.data.cameras.new("camera")
    data.sensor_fit = "HORIZONTAL"
    data.sensor_width = 36.0
    data.lens = fx * data.sensor_width / width_px
    # Blender puts pixel centres at half-integers: its principal point is at cx + 0.5. Shifts
    # are in units of the larger image side.
    side = max(width_px, height_px)
    data.shift_x = (width_px / 2 - (cx + 0.5)) / side
    data.shift_y = ((cy + 0.5) - height_px / 2) / side
    data.clip_start, data.clip_end = 0.01, 50.0
    obj = bpy.data.objects.new("camera", data)
    obj.rotation_mode = "QUATERNION"
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.scene.camera = obj
    return obj


def add_area_light(name: str, power_w: float, size_m: float):  # noqa: ANN201 (bpy type)
    """A square light of side `size_m`. Pose it with `set_pose`."""
    import bpy

    data = bpy.data.lights.new(name, "AREA")
    data.energy = power_w
    data.size = size_m
    return _light_object(name, data)


def add_sun(name: str, strength_w_m2: float, angle_deg: float):  # noqa: ANN201 (bpy type)
    """Parallel light of the given irradiance from a disc of `angle_deg` diameter. Pose it with
    `set_pose` (only its direction counts)."""
    import bpy

    data = bpy.data.lights.new(name, "SUN")
    data.energy = strength_w_m2
    data.angle = np.deg2rad(angle_deg)
    return _light_object(name, data)


def _light_object(name: str, data):  # noqa: ANN001, ANN202 (bpy types)
    import bpy

    obj = bpy.data.objects.new(name, data)
    obj.rotation_mode = "QUATERNION"
    bpy.context.scene.collection.objects.link(obj)
    return obj


def set_pose(obj, world_from_obj: np.ndarray, frame: int | None = None) -> None:  # noqa: ANN001 (bpy type)
    """Place a camera or light (OpenCV convention, z forward); with `frame`, as a keyframe of
    that frame of the animation `render_frames` renders."""
    from mathutils import Matrix

    obj.matrix_world = Matrix((np.asarray(world_from_obj, dtype=np.float64) @ OPENCV_FROM_BLENDER).tolist())
    if frame is not None:
        obj.keyframe_insert("location", frame=frame)
        obj.keyframe_insert("rotation_quaternion", frame=frame)


def render_frames(paths: Sequence[Path], progress: Callable[[int], None] | None = None) -> None:
    """Render frame k of the scene's animation into `paths[k]` (PNG); `progress(k + 1)` after
    each. Cycles keeps its scene between frames (persistent data): only what moved is synced."""
    import bpy

    scene = bpy.context.scene
    for frame, path in enumerate(paths):
        scene.frame_set(frame)
        scene.render.filepath = str(path)
        # Blender logs every tile and saved file on fds 1 and 2; the library does not print.
        with captured_c_output():
            bpy.ops.render.render(write_still=True)
        if progress is not None:
            progress(frame + 1)
