"""Turn the objects a builder made in Blender into an `articulation.Model`.

The scene holds the visual geometry: every mesh object carries the link it belongs to in
the custom property `LINK_PROPERTY`, and the object named like a link sits at that link's
frame. What a mesh cannot say (collision shapes, joints, grasp points, semantics, mass) the
builder hands over as an `Assembly`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from articulation.inertia import inertial_from_meshes
from articulation.model import (
    Collision,
    GraspPoint,
    Inertial,
    Joint,
    Link,
    Material,
    Model,
    Visual,
)
from homemodel.core.errors import ModelError
from modeller.blender_scene import LINK_PROPERTY, material_texture_path

if TYPE_CHECKING:
    import bpy
    import trimesh
    from mathutils import Matrix

# Parts with fixed masses never take more than this share from the rest of the model (its
# carcass, machinery and fittings), whatever their materials say.
MIN_REST_SHARE = 0.3


@dataclass(kw_only=True)
class Assembly:
    """A builder's description of the model beside its Blender objects.

    `collisions` lists every link (root first) with its collision shapes in the link frame.
    Give `mass_kg` (the whole model's) or `density_kg_m3` (the total follows from the
    volume). `link_masses_kg` fixes the mass of parts whose mass is known from what they are
    (a door as a panel of its material); the other links share the rest of the total by volume.
    """

    name: str
    category: str
    collisions: dict[str, list[Collision]]
    joints: list[Joint] = field(default_factory=list)
    grasp_points: list[GraspPoint] = field(default_factory=list)
    affordances: list[str] = field(default_factory=list)
    properties: dict[str, str] = field(default_factory=dict)
    density_kg_m3: float | None = None
    mass_kg: float | None = None
    link_masses_kg: dict[str, float] = field(default_factory=dict)


def model_from_scene(assembly: Assembly) -> Model:
    """Read every linked mesh object (modifiers applied, triangulated) into the model's links."""
    import bpy

    depsgraph = bpy.context.evaluated_depsgraph_get()
    materials: dict[str, Material] = {}
    visuals: dict[str, list[Visual]] = {name: [] for name in assembly.collisions}
    # Whole objects, for mass properties: a visual per material is an open piece of one.
    solids: dict[str, list[trimesh.Trimesh]] = {name: [] for name in assembly.collisions}
    for obj in bpy.data.objects:
        link = obj.get(LINK_PROPERTY)
        if link is None or obj.type != "MESH":
            continue
        if link not in visuals:
            raise ModelError(f"object {obj.name!r} belongs to link {link!r}, which the model does not have")
        link_obj = bpy.data.objects.get(link)
        if link_obj is None:
            raise ModelError(f"link {link!r} has no object of its name to give its frame")
        evaluated = obj.evaluated_get(depsgraph)
        link_from_object = np.linalg.inv(_matrix(link_obj.evaluated_get(depsgraph).matrix_world)) @ _matrix(
            evaluated.matrix_world
        )
        solid, pieces = _triangles(evaluated, link_from_object)
        solids[link].append(solid)
        for slot, mesh, uv in pieces:
            material = _material(obj, slot, materials)
            name = obj.name if slot == 0 else f"{obj.name}.{material.name}"
            visuals[link].append(Visual(name=name, mesh=mesh, material=material, uv=uv))

    links = [Link(name=name, visuals=visuals[name], collisions=shapes) for name, shapes in assembly.collisions.items()]
    for link in links:
        if not link.visuals:
            raise ModelError(f"link {link.name!r} has no mesh objects in the scene")
    _set_inertials(
        links, solids, density_kg_m3=assembly.density_kg_m3, mass_kg=assembly.mass_kg, fixed_kg=assembly.link_masses_kg
    )
    return Model(
        name=assembly.name,
        links=links,
        joints=assembly.joints,
        grasp_points=assembly.grasp_points,
        category=assembly.category,
        affordances=assembly.affordances,
        properties=assembly.properties,
    )


def _matrix(blender_matrix: Matrix) -> np.ndarray:
    return np.array(blender_matrix, dtype=np.float64)


def _triangles(
    evaluated: bpy.types.Object, link_from_object: np.ndarray
) -> tuple[trimesh.Trimesh, list[tuple[int, trimesh.Trimesh, np.ndarray | None]]]:
    """The evaluated object's mesh in the link frame as triangles: whole, and split into
    (material slot, mesh, uv) pieces, one per material slot its faces use.

    A piece whose material has an image texture gets one UV per vertex (`Visual.uv`):
    Blender keeps UVs per face corner, so a vertex where faces meet with different UVs
    (a seam, an edge of the photographed face) is split into one vertex per UV.
    """
    import trimesh

    mesh = evaluated.to_mesh()
    try:
        mesh.calc_loop_triangles()
        vertices = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
        mesh.vertices.foreach_get("co", vertices)
        faces = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int32)
        mesh.loop_triangles.foreach_get("vertices", faces)
        loops = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int32)
        mesh.loop_triangles.foreach_get("loops", loops)
        slots = np.empty(len(mesh.loop_triangles), dtype=np.int32)
        mesh.loop_triangles.foreach_get("material_index", slots)
        textured = {i for i, m in enumerate(mesh.materials) if m is not None and material_texture_path(m) is not None}
        loop_uv = None
        if textured and mesh.uv_layers.active is not None:
            loop_uv = np.empty(len(mesh.loops) * 2, dtype=np.float32)
            mesh.uv_layers.active.data.foreach_get("uv", loop_uv)
            loop_uv = loop_uv.reshape(-1, 2).astype(np.float64)
    finally:
        evaluated.to_mesh_clear()
    vertices = vertices.reshape(-1, 3).astype(np.float64) @ link_from_object[:3, :3].T + link_from_object[:3, 3]
    faces, loops = faces.reshape(-1, 3), loops.reshape(-1, 3)
    whole = trimesh.Trimesh(vertices, faces, process=False)
    used = np.unique(slots)
    if len(used) == 1 and used[0] not in textured:
        return whole, [(int(used[0]), whole, None)]
    pieces = []
    for slot in used.tolist():
        chosen = slots == slot
        if slot in textured and loop_uv is not None:
            # One vertex per distinct (vertex, u, v) among the piece's face corners.
            corners = np.column_stack([faces[chosen].reshape(-1), loop_uv[loops[chosen].reshape(-1)]])
            keys, inverse = np.unique(corners, axis=0, return_inverse=True)
            piece = trimesh.Trimesh(vertices[keys[:, 0].astype(np.int64)], inverse.reshape(-1, 3), process=False)
            pieces.append((slot, piece, keys[:, 1:]))
        else:
            kept, inverse = np.unique(faces[chosen], return_inverse=True)
            pieces.append((slot, trimesh.Trimesh(vertices[kept], inverse.reshape(-1, 3), process=False), None))
    return whole, pieces


def _material(obj: bpy.types.Object, slot: int, materials: dict[str, Material]) -> Material:
    """The Blender material in the object's `slot` as one shared `Material` per Blender material."""
    blender_material = obj.material_slots[slot].material if slot < len(obj.material_slots) else None
    if blender_material is None:
        raise ModelError(f"object {obj.name!r} has no material in slot {slot}")
    if blender_material.name not in materials:
        rgba = tuple(float(c) for c in blender_material.diffuse_color)
        texture = material_texture_path(blender_material)
        materials[blender_material.name] = Material(name=blender_material.name, rgba=rgba, texture=texture)
    return materials[blender_material.name]


def _set_inertials(
    links: list[Link],
    solids: dict[str, list[trimesh.Trimesh]],
    *,
    density_kg_m3: float | None,
    mass_kg: float | None,
    fixed_kg: dict[str, float],
) -> None:
    """Inertials from each link's whole objects' meshes: the links in `fixed_kg` at their
    mass, the others sharing the rest of the total at one density.

    The total is `mass_kg`, else `density_kg_m3` times the whole volume. Fixed masses that
    would leave the other links less than `MIN_REST_SHARE` of the total are scaled down.
    """
    if (density_kg_m3 is None) == (mass_kg is None):
        raise ValueError("give exactly one of density_kg_m3 and mass_kg")
    unknown = set(fixed_kg) - {link.name for link in links}
    if unknown:
        raise ModelError(f"masses given for links {sorted(unknown)}, which the model does not have")
    # At unit density an inertial's mass is the link's volume, and mass and inertia scale
    # linearly with density, so one pass gives every link's shape.
    unit = {link.name: inertial_from_meshes(solids[link.name], density_kg_m3=1.0) for link in links}
    total = mass_kg if mass_kg is not None else density_kg_m3 * sum(i.mass_kg for i in unit.values())
    rest_volume = sum(i.mass_kg for name, i in unit.items() if name not in fixed_kg)
    fixed_total = sum(fixed_kg.values())
    scale = min(1.0, (1 - MIN_REST_SHARE) * total / fixed_total) if fixed_total > 0 else 1.0
    rest_density = (total - scale * fixed_total) / rest_volume if rest_volume > 0 else 0.0
    for link in links:
        inertial = unit[link.name]
        density = scale * fixed_kg[link.name] / inertial.mass_kg if link.name in fixed_kg else rest_density
        link.inertial = Inertial(
            mass_kg=inertial.mass_kg * density, com_m=inertial.com_m, inertia_kgm2=inertial.inertia_kgm2 * density
        )
