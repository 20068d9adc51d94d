"""Blender helpers: an empty scene, primitives at their real size, materials, saving.

Meshes are made with bmesh or `from_pydata`, not `bpy.ops`, so nothing depends on a context
or a selection. Mesh helpers put the primitive at `centre_m` in the mesh's own coordinates;
`add_object` places the object in its parent. Each object records the model link it belongs
to in the custom property `LINK_PROPERTY`.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import numpy as np

from homemodel.core.c_stdio_capture import captured_c_output

if TYPE_CHECKING:
    import bpy

LINK_PROPERTY = "homemodel_link"


def box_mesh(name: str, size_m: Sequence[float], centre_m: Sequence[float] = (0, 0, 0)) -> bpy.types.Mesh:
    """A closed box of `size_m` (x, y, z), its faces' normals outward."""
    import bmesh
    import bpy
    from mathutils import Matrix

    bm = bmesh.new()
    bmesh.ops.create_cube(bm, size=1.0, matrix=Matrix.LocRotScale(centre_m, None, size_m))
    mesh = bpy.data.meshes.new(name)
    bm.to_mesh(mesh)
    bm.free()
    return mesh


def cylinder_mesh(
    name: str,
    radius_m: float,
    length_m: float,
    *,
    axis: Literal["x", "y", "z"] = "z",
    segments: int = 32,
) -> bpy.types.Mesh:
    """A closed cylinder along `axis`, centred on the origin."""
    import bmesh
    import bpy
    from mathutils import Matrix

    to_axis = {"x": Matrix.Rotation(np.pi / 2, 4, "Y"), "y": Matrix.Rotation(-np.pi / 2, 4, "X"), "z": Matrix()}
    bm = bmesh.new()
    bmesh.ops.create_cone(
        bm,
        cap_ends=True,
        segments=segments,
        radius1=radius_m,
        radius2=radius_m,
        depth=length_m,
        matrix=to_axis[axis],
    )
    mesh = bpy.data.meshes.new(name)
    bm.to_mesh(mesh)
    bm.free()
    return mesh


def _revolve(name: str, profile_rz: np.ndarray, segments: int) -> bpy.types.Mesh:
    """A closed solid turning an (r, z) polyline about z: the polyline runs counter-clockwise
    round the section, and the rings through its first and last points are capped by n-gons."""
    import bpy

    angles = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    rings = len(profile_rz)
    r, z = profile_rz[:, 0, None], profile_rz[:, 1, None]
    verts = np.stack([r * np.cos(angles), r * np.sin(angles), np.broadcast_to(z, (rings, segments))], -1)
    index = np.arange(rings * segments).reshape(rings, segments)
    nxt = np.roll(index, -1, axis=1)
    # Quads between neighbouring rings; with a counter-clockwise profile their normals point out.
    quads = np.stack([index[:-1], nxt[:-1], nxt[1:], index[1:]], -1).reshape(-1, 4)
    faces = [tuple(q) for q in quads.tolist()]
    faces.append(tuple(index[0][::-1].tolist()))  # first ring (bottom), facing down
    faces.append(tuple(index[-1].tolist()))  # last ring (inside floor), facing up
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts.reshape(-1, 3).tolist(), [], faces)
    mesh.validate()
    return mesh


def hollow_cylinder_mesh(
    name: str,
    outer_radius_m: float,
    inner_radius_m: float,
    height_m: float,
    bottom_thickness_m: float,
    *,
    segments: int = 64,
) -> bpy.types.Mesh:
    """A cylinder open at the top and closed at the bottom (a cup), standing on z = 0."""
    profile = np.array(
        [
            (outer_radius_m, 0.0),
            (outer_radius_m, height_m),
            (inner_radius_m, height_m),
            (inner_radius_m, bottom_thickness_m),
        ]
    )
    return _revolve(name, profile, segments)


def torus_segment_mesh(
    name: str,
    major_radius_m: float,
    minor_radius_m: float,
    sweep_deg: float,
    *,
    major_segments: int = 24,
    minor_segments: int = 16,
) -> bpy.types.Mesh:
    """A closed torus segment about the origin in the x-z plane, swept over +-`sweep_deg`/2
    from +x, its ends capped."""
    import bpy

    phi = np.radians(np.linspace(-sweep_deg / 2, sweep_deg / 2, major_segments + 1))[:, None]
    psi = np.linspace(0, 2 * np.pi, minor_segments, endpoint=False)[None, :]
    reach = major_radius_m + minor_radius_m * np.cos(psi)
    across = np.broadcast_to(minor_radius_m * np.sin(psi), (phi.size, psi.size))
    verts = np.stack([reach * np.cos(phi), across, reach * np.sin(phi)], -1)
    index = np.arange(verts.shape[0] * verts.shape[1]).reshape(verts.shape[:2])
    nxt = np.roll(index, -1, axis=1)
    quads = np.stack([index[:-1], nxt[:-1], nxt[1:], index[1:]], -1).reshape(-1, 4)
    faces = [tuple(q) for q in quads.tolist()]
    faces.append(tuple(index[0][::-1].tolist()))  # end caps, facing out of the segment
    faces.append(tuple(index[-1].tolist()))
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts.reshape(-1, 3).tolist(), [], faces)
    mesh.validate()
    mesh.shade_smooth()
    return mesh


def remove_faces(mesh: bpy.types.Mesh, normals: Sequence[Sequence[float]]) -> None:
    """Delete, for each of `normals`, the face whose normal points most nearly that way."""
    import bmesh

    bm = bmesh.new()
    bm.from_mesh(mesh)
    doomed = {max(bm.faces, key=lambda f, n=n: f.normal.dot(n)) for n in normals}
    bmesh.ops.delete(bm, geom=list(doomed), context="FACES_ONLY")
    bm.to_mesh(mesh)
    bm.free()


def add_solidify(obj: bpy.types.Object, thickness_m: float) -> None:
    """Give an open shell walls of `thickness_m`, inward, so its outer size stays exact."""
    modifier = obj.modifiers.new("wall thickness", "SOLIDIFY")
    modifier.thickness = thickness_m
    modifier.offset = -1.0  # inward of the outward face normals
    modifier.use_even_offset = True  # keeps the thickness exact at the corners
    modifier.use_rim = True


def subtract(obj: bpy.types.Object, modifier: str, cutter_name: str, mesh: bpy.types.Mesh, obj_from_cutter) -> None:
    """Cut `mesh`, placed at `obj_from_cutter` in `obj`'s frame, out of `obj` (a boolean
    difference, applied on export); the cutter is a hidden wire object parented to `obj`."""
    import bpy
    from mathutils import Matrix

    cutter = bpy.data.objects.new(cutter_name, mesh)
    bpy.context.scene.collection.objects.link(cutter)
    cutter.parent = obj
    cutter.matrix_basis = Matrix(np.asarray(obj_from_cutter, dtype=np.float64).tolist())
    cutter.hide_render = True
    cutter.display_type = "WIRE"
    boolean = obj.modifiers.new(modifier, "BOOLEAN")
    boolean.operation = "DIFFERENCE"
    boolean.object = cutter


def colour_material(name: str, rgb: Sequence[float]) -> bpy.types.Material:
    """The material named `name`, made with base colour `rgb` on first use: one per colour."""
    import bpy

    found = bpy.data.materials.get(name)
    if found is not None:
        return found
    mat = bpy.data.materials.new(name)
    rgba = (*rgb, 1.0)
    mat.diffuse_color = rgba  # the viewport's colour
    mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = rgba  # the renderers'
    return mat


def add_object(
    name: str,
    mesh: bpy.types.Mesh,
    *,
    link: str,
    material: bpy.types.Material,
    parent: bpy.types.Object | None = None,
    parent_from_object: np.ndarray | None = None,
) -> bpy.types.Object:
    """Link a new object for `mesh` into the scene, placed by `parent_from_object`."""
    import bpy
    from mathutils import Matrix

    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    mesh.materials.append(material)
    obj[LINK_PROPERTY] = link
    obj.parent = parent
    if parent_from_object is not None:
        obj.matrix_basis = Matrix(np.asarray(parent_from_object, dtype=np.float64).tolist())
    return obj


def save_blend(path: Path) -> None:
    """Save the scene to `path` atomically (a temporary file in the same folder, then a rename)."""
    import bpy

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # A fresh path in a temporary folder: saving over an existing file would make Blender
    # keep a `.blend1` backup of it.
    with tempfile.TemporaryDirectory(dir=path.parent, prefix=f".{path.stem}.") as tmp_dir:
        tmp = Path(tmp_dir) / path.name
        with captured_c_output():  # Blender reports "Info: Saved ..." on stdout
            bpy.ops.wm.save_as_mainfile(filepath=str(tmp), copy=True)
        os.replace(tmp, path)


def texture_material(name: str, image_path: Path) -> bpy.types.Material:
    """A material whose base colour is the image at `image_path` (packed into the .blend, so
    a saved scene keeps it), sampled with the active UV map."""
    import bpy

    mat = bpy.data.materials.new(name)
    mat.diffuse_color = (1.0, 1.0, 1.0, 1.0)  # the image is the colour; no tint in the viewport
    image = bpy.data.images.load(str(image_path), check_existing=False)
    image.pack()
    nodes = mat.node_tree.nodes
    texture = nodes.new("ShaderNodeTexImage")
    texture.image = image
    texture.location = (-400, 300)
    mat.node_tree.links.new(texture.outputs["Color"], nodes["Principled BSDF"].inputs["Base Color"])
    return mat


def material_texture_path(mat: bpy.types.Material) -> Path | None:
    """The image file feeding the material's base colour, if an Image Texture node does."""
    if mat.node_tree is None:
        return None
    principled = next((n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
    if principled is None or not principled.inputs["Base Color"].is_linked:
        return None
    source = principled.inputs["Base Color"].links[0].from_node
    if source.type != "TEX_IMAGE" or source.image is None:
        return None
    import bpy

    return Path(bpy.path.abspath(source.image.filepath))
