"""Write a scene as an SDFormat 1.9 world (`scene.sdf`) for Gazebo.

- Each object is a `<model>` at its pose; furniture is held by a fixed joint to `world`
  (a `<static>` model would freeze its doors too); a free object has no such joint.
- SDFormat has no initial joint position: a joint's zero is its links' initial poses. The
  links are therefore written at the scene's joint positions, and each joint's limits (and
  the positions `<homemodel:states>` names) are shifted by that position, so the door still
  stops where the real one does.
- Damping and friction come from `joint_physics`, as in the MJCF.
- Meshes are OBJ files under `meshes/<object id>/` (`scene_meshes`), by relative URI; a
  photo texture is a PNG beside them, the visual's PBR albedo map.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from lxml import etree

from articulation.convex_parts import as_convex_hull
from articulation.export_dynamics import export_dynamics
from articulation.joint_loads import STANDARD_GRAVITY_M_S2
from articulation.model import Box, Cylinder, Link, Material, MeshGeometry, Sphere
from articulation.scene import Scene, SceneObject
from homemodel.core.atomic import write_text_atomic
from homemodel.core.transforms import translation_transform
from homemodel.exchange.numbers import canonical_xyz_rpy, fixed, fixed_list, significant
from homemodel.exchange.scene_meshes import SceneMeshes
from homemodel.exchange.urdf.scene import FLOOR_MATERIAL, WALL_MATERIAL, floor_box

SCENE_FILE = "scene.sdf"
SDF_VERSION = "1.9"
HOMEMODEL_NS = "https://homemodel.dev/sdf/1"


def _text(parent: etree._Element, tag: str, text: str, **attributes: str) -> etree._Element:
    el = etree.SubElement(parent, tag, **attributes)
    el.text = text
    return el


def _pose(parent: etree._Element, a_from_b: np.ndarray, **attributes: str) -> None:
    xyz, rpy = canonical_xyz_rpy(a_from_b)
    _text(parent, "pose", fixed_list([*xyz, *rpy]), **attributes)


def _material(parent: etree._Element, material: Material, texture_uri: str | None = None) -> None:
    el = etree.SubElement(parent, "material")
    # A photo shows its own colours: white, keeping the material's opacity.
    colour = fixed_list((1.0, 1.0, 1.0, material.rgba[3]) if texture_uri else material.rgba)
    _text(el, "ambient", colour)
    _text(el, "diffuse", colour)
    if texture_uri:
        _text(etree.SubElement(etree.SubElement(el, "pbr"), "metal"), "albedo_map", texture_uri)


def _geometry(parent: etree._Element, shape, uri: str | None) -> None:
    g = etree.SubElement(parent, "geometry")
    if isinstance(shape, Box):
        _text(etree.SubElement(g, "box"), "size", fixed_list(shape.size_m))
    elif isinstance(shape, Cylinder):
        c = etree.SubElement(g, "cylinder")
        _text(c, "radius", fixed(shape.radius_m))
        _text(c, "length", fixed(shape.length_m))
    elif isinstance(shape, Sphere):
        _text(etree.SubElement(g, "sphere"), "radius", fixed(shape.radius_m))
    else:
        _text(etree.SubElement(g, "mesh"), "uri", uri)


def _link(model_el: etree._Element, obj: SceneObject, link: Link, model_from_link: np.ndarray, meshes: SceneMeshes) -> None:
    el = etree.SubElement(model_el, "link", name=obj.name(link.name))
    _pose(el, model_from_link, relative_to="__model__")
    if link.inertial is not None:
        inertial = etree.SubElement(el, "inertial")
        _pose(inertial, translation_transform(link.inertial.com_m))
        _text(inertial, "mass", significant(link.inertial.mass_kg))
        inertia = etree.SubElement(inertial, "inertia")
        i = link.inertial.inertia_kgm2
        for key, value in (("ixx", i[0, 0]), ("ixy", i[0, 1]), ("ixz", i[0, 2]), ("iyy", i[1, 1]), ("iyz", i[1, 2]), ("izz", i[2, 2])):
            _text(inertia, key, significant(value))
    for visual in link.visuals:
        textured = visual.material.texture is not None and visual.uv is not None
        name, uri = meshes.write(obj, f"{link.name}_{visual.name}", visual.mesh, visual.uv if textured else None)
        v = etree.SubElement(el, "visual", name=name)
        _pose(v, visual.link_from_visual)
        _geometry(v, None, uri)
        _material(v, visual.material, meshes.texture(obj, visual.material.texture)[1] if textured else None)
    for collision in link.collisions:
        shape = collision.geometry
        if isinstance(shape, MeshGeometry):
            name, uri = meshes.write(obj, f"{link.name}_{collision.name}_hull", as_convex_hull(shape.mesh))
        else:
            name, uri = meshes.name(obj, f"{link.name}_{collision.name}_collision"), None
        c = etree.SubElement(el, "collision", name=name)
        _pose(c, collision.link_from_collision)
        _geometry(c, shape, uri)


def _joints(model_el: etree._Element, obj: SceneObject) -> None:
    if not obj.free:
        joint = etree.SubElement(model_el, "joint", name=obj.name("placed"), type="fixed")
        _text(joint, "parent", "world")
        _text(joint, "child", obj.name(obj.model.root_link))
    for j in obj.model.joints:
        kind = {"continuous": "revolute"}.get(j.type, j.type)
        el = etree.SubElement(model_el, "joint", name=obj.name(j.name), type=kind)
        _text(el, "parent", obj.name(j.parent))
        _text(el, "child", obj.name(j.child))
        if not j.is_movable:
            continue
        # The joint frame is the child's frame (its default pose): the axis is the same there.
        q = obj.position(j.name)
        axis = etree.SubElement(el, "axis")
        _text(axis, "xyz", fixed_list(j.axis / np.linalg.norm(j.axis), 9))
        limit = etree.SubElement(axis, "limit")
        if j.type == "continuous" or j.limits is None:
            _text(limit, "lower", "-1e16")
            _text(limit, "upper", "1e16")
        else:
            _text(limit, "lower", fixed(j.limits.lower - q, 9))
            _text(limit, "upper", fixed(j.limits.upper - q, 9))
        if j.limits is not None:
            _text(limit, "effort", significant(j.limits.effort))
            _text(limit, "velocity", significant(j.limits.velocity))
        dynamics = export_dynamics(obj.model, j, gravity_model=obj.gravity_model)
        dyn = etree.SubElement(axis, "dynamics")
        _text(dyn, "damping", significant(dynamics.damping))
        _text(dyn, "friction", significant(dynamics.friction))
        if q or j.states:
            states = etree.SubElement(el, f"{{{HOMEMODEL_NS}}}states", offset=fixed(q, 9))
            for s in j.states:
                etree.SubElement(states, f"{{{HOMEMODEL_NS}}}state", name=s.name, position=fixed(s.position - q, 9))


def _object(world: etree._Element, obj: SceneObject, meshes: SceneMeshes) -> None:
    model_el = etree.SubElement(world, "model", name=obj.id)
    _pose(model_el, obj.world_from_model)
    frames = obj.model.world_from_links(obj.joint_positions)
    for link in obj.model.links:
        _link(model_el, obj, link, frames[link.name], meshes)
    _joints(model_el, obj)


def _static_box(world: etree._Element, name: str, world_from_box: np.ndarray, size, material: Material) -> None:
    model_el = etree.SubElement(world, "model", name=name)
    _text(model_el, "static", "true")
    _pose(model_el, world_from_box)
    link = etree.SubElement(model_el, "link", name=name)
    for tag in ("collision", "visual"):
        part = etree.SubElement(link, tag, name=f"{name}_{tag}")
        _geometry(part, Box(size_m=size), None)
        if tag == "visual":
            _material(part, material)


def sdf_bytes(scene: Scene, folder: Path) -> bytes:
    """The SDF document of `scene`; writes its meshes under `folder/meshes/`."""
    sdf = etree.Element("sdf", version=SDF_VERSION, nsmap={"homemodel": HOMEMODEL_NS})
    world = etree.SubElement(sdf, "world", name=scene.name)
    _text(world, "gravity", f"0 0 {-STANDARD_GRAVITY_M_S2}")
    physics = etree.SubElement(world, "physics", name="default", type="dart")
    _text(physics, "max_step_size", "0.001")
    _text(physics, "real_time_factor", "1")
    light = etree.SubElement(world, "light", name="sun", type="directional")
    _text(light, "cast_shadows", "true")
    _pose(light, translation_transform((0.0, 0.0, 10.0)))
    _text(light, "diffuse", "0.8 0.8 0.8 1")
    _text(light, "direction", "-0.3 -0.2 -1")
    if scene.floor:
        world_from_floor, size = floor_box(scene)
        _static_box(world, "floor", world_from_floor, size, FLOOR_MATERIAL)
    for wall in scene.walls:
        _static_box(world, wall.name, wall.world_from_wall(), wall.size_m, WALL_MATERIAL)
    meshes = SceneMeshes(folder)
    for obj in scene.objects:
        _object(world, obj, meshes)
    return etree.tostring(sdf, pretty_print=True, xml_declaration=True, encoding="utf-8")


def write_sdf(scene: Scene, folder: Path) -> Path:
    path = Path(folder) / SCENE_FILE
    write_text_atomic(path, sdf_bytes(scene, folder).decode("utf-8"))
    return path
