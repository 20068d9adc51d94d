"""Write a model as `model.urdf` with OBJ/MTL meshes beside it, relative paths only.

Semantics URDF has no element for (category, affordances, grasp points, discrete joint
states) go into a `<homemodel>` element under `<robot>`; urdfdom, yourdfpy and pybullet
ignore unknown elements, as they do Gazebo's `<gazebo>`.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
from lxml import etree

from articulation.convex_parts import as_convex_hull
from articulation.model import (
    Box,
    Collision,
    Cylinder,
    Joint,
    Link,
    Material,
    MeshGeometry,
    Model,
    Sphere,
    Visual,
)
from articulation.naming import file_stem, unique
from homemodel.core.atomic import write_text_atomic
from homemodel.exchange.numbers import canonical_xyz_rpy, fixed, fixed_list, significant
from homemodel.exchange.obj import mtl_text, obj_text

MESH_DIR = "meshes"


def _origin(parent: etree._Element, a_from_b) -> None:
    xyz, rpy = canonical_xyz_rpy(a_from_b)
    etree.SubElement(parent, "origin", xyz=fixed_list(xyz), rpy=fixed_list(rpy))


class _MeshWriter:
    """Writes each mesh and texture once under `meshes/`, with unique file names."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.mesh_dir = folder / MESH_DIR
        self.taken: set[str] = set()
        self.textures: dict[Path, str] = {}

    def texture(self, material: Material) -> str | None:
        if material.texture is None:
            return None
        source = Path(material.texture)
        if source not in self.textures:
            name = unique(file_stem(f"{material.name}_texture"), self.taken) + source.suffix.lower()
            self.mesh_dir.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source, self.mesh_dir / name)
            self.textures[source] = name
        return self.textures[source]

    def visual(self, link: Link, visual: Visual) -> str:
        stem = unique(file_stem(f"{link.name}_{visual.name}"), self.taken)
        material = file_stem(visual.material.name)
        texture = self.texture(visual.material)
        uv = visual.uv if texture is not None else None
        write_text_atomic(self.mesh_dir / f"{stem}.mtl", mtl_text(material, visual.material.rgba, texture))
        write_text_atomic(
            self.mesh_dir / f"{stem}.obj", obj_text(visual.mesh, mtl_file=f"{stem}.mtl", material=material, uv=uv)
        )
        return f"{MESH_DIR}/{stem}.obj"

    def collision(self, link: Link, collision: Collision, geometry: MeshGeometry) -> str:
        stem = unique(file_stem(f"{link.name}_{collision.name}_collision"), self.taken)
        hull = as_convex_hull(geometry.mesh)
        write_text_atomic(self.mesh_dir / f"{stem}.obj", obj_text(hull, mtl_file=None, material=None, uv=None))
        return f"{MESH_DIR}/{stem}.obj"


def _geometry(parent: etree._Element, geometry, mesh_path: str | None) -> None:
    g = etree.SubElement(parent, "geometry")
    if isinstance(geometry, Box):
        etree.SubElement(g, "box", size=fixed_list(geometry.size_m))
    elif isinstance(geometry, Cylinder):
        etree.SubElement(g, "cylinder", radius=fixed(geometry.radius_m), length=fixed(geometry.length_m))
    elif isinstance(geometry, Sphere):
        etree.SubElement(g, "sphere", radius=fixed(geometry.radius_m))
    else:
        etree.SubElement(g, "mesh", filename=mesh_path)


def _link_element(robot: etree._Element, link: Link, meshes: _MeshWriter) -> None:
    el = etree.SubElement(robot, "link", name=link.name)
    if link.inertial is not None:
        inertial = etree.SubElement(el, "inertial")
        etree.SubElement(inertial, "origin", xyz=fixed_list(link.inertial.com_m), rpy="0 0 0")
        etree.SubElement(inertial, "mass", value=significant(link.inertial.mass_kg))
        i = link.inertial.inertia_kgm2
        i = np.where(np.abs(i) < 1e-9 * np.abs(i).max(), 0.0, i)  # round-off from mesh integrals
        etree.SubElement(
            inertial,
            "inertia",
            ixx=significant(i[0, 0]),
            ixy=significant(i[0, 1]),
            ixz=significant(i[0, 2]),
            iyy=significant(i[1, 1]),
            iyz=significant(i[1, 2]),
            izz=significant(i[2, 2]),
        )
    for visual in link.visuals:
        v = etree.SubElement(el, "visual", name=visual.name)
        _origin(v, visual.link_from_visual)
        _geometry(v, None, meshes.visual(link, visual))
        material = etree.SubElement(v, "material", name=file_stem(visual.material.name))
        etree.SubElement(material, "color", rgba=fixed_list(visual.material.rgba))
    for collision in link.collisions:
        c = etree.SubElement(el, "collision", name=collision.name)
        _origin(c, collision.link_from_collision)
        geometry = collision.geometry
        path = meshes.collision(link, collision, geometry) if isinstance(geometry, MeshGeometry) else None
        _geometry(c, geometry, path)


def _joint_element(robot: etree._Element, joint: Joint) -> None:
    el = etree.SubElement(robot, "joint", name=joint.name, type=joint.type)
    etree.SubElement(el, "parent", link=joint.parent)
    etree.SubElement(el, "child", link=joint.child)
    _origin(el, joint.parent_from_joint)
    if joint.type == "fixed":
        return
    etree.SubElement(el, "axis", xyz=fixed_list(joint.axis))
    limits = joint.limits
    if limits is not None:
        attributes = {"effort": significant(limits.effort), "velocity": significant(limits.velocity)}
        if joint.type != "continuous":
            attributes = {"lower": fixed(limits.lower), "upper": fixed(limits.upper), **attributes}
        etree.SubElement(el, "limit", **attributes)
    if joint.dynamics is not None:
        dynamics = joint.dynamics
        etree.SubElement(el, "dynamics", damping=significant(dynamics.damping), friction=significant(dynamics.friction))


def _extension_element(robot: etree._Element, model: Model) -> None:
    ext = etree.SubElement(robot, "homemodel", category=model.category)
    for affordance in model.affordances:
        etree.SubElement(ext, "affordance", name=affordance)
    for key, value in sorted(model.properties.items()):
        etree.SubElement(ext, "property", name=key, value=value)
    for grasp in model.grasp_points:
        g = etree.SubElement(ext, "grasp_point", name=grasp.name, link=grasp.link, kind=grasp.kind)
        _origin(g, grasp.link_from_grasp)
    for joint in model.joints:
        for state in joint.states:
            etree.SubElement(ext, "joint_state", joint=joint.name, name=state.name, position=fixed(state.position))


def urdf_bytes(model: Model, folder: Path) -> bytes:
    """The URDF document of `model`; writes its meshes under `folder/meshes/`."""
    meshes = _MeshWriter(Path(folder))
    robot = etree.Element("robot", name=model.name)
    _extension_element(robot, model)
    for link in model.links:
        _link_element(robot, link, meshes)
    for joint in model.joints:
        _joint_element(robot, joint)
    return etree.tostring(robot, pretty_print=True, xml_declaration=True, encoding="utf-8")


def write_urdf(model: Model, folder: Path) -> Path:
    path = Path(folder) / "model.urdf"
    write_text_atomic(path, urdf_bytes(model, folder).decode("utf-8"))
    return path
