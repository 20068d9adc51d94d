"""Read a URDF (ours, or PartNet-Mobility's `mobility.urdf` with many OBJ parts per link)
into the model type.

Meshes are resolved relative to the URDF's folder and must stay inside it; the XML is
parsed safely (no DOCTYPE, no entities, a size bound).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import trimesh
from lxml import etree

from articulation.joint_types import JOINT_TYPES
from articulation.model import (
    Box,
    Collision,
    Cylinder,
    GraspPoint,
    Inertial,
    Joint,
    JointDynamics,
    JointLimits,
    JointState,
    Link,
    Material,
    MeshGeometry,
    Model,
    Sphere,
    Visual,
)
from homemodel.core.errors import InputError, ModelError
from homemodel.core.input_files import read_bounded
from homemodel.core.limits import MESH_TRIANGLES
from homemodel.core.transforms import transform_from_xyz_rpy
from homemodel.exchange import urdf as urdf_doc
from homemodel.exchange.obj import read_plain_obj
from homemodel.exchange.urdf.mesh_paths import resolve_mesh
from homemodel.geometry.collada import collada_unit_m
from homemodel.geometry.mesh_io import MAX_MESH_BYTES, declared_faces

_NUMBER_LIST = re.compile(r"\s+")


class _Context:
    def __init__(self, urdf_path: Path, package_paths: Sequence[Path] = ()) -> None:
        self.path = urdf_path
        self.folder = urdf_path.parent.resolve()
        self.package_paths = tuple(package_paths)
        self.global_materials: dict[str, tuple[float, float, float, float]] = {}
        # Each mesh is named by its visual's loader, its texture lookup and its collisions:
        # resolved once (a kitchen map's 77 meshes made ~940 `Path.resolve` calls).
        self._mesh_paths: dict[str, Path] = {}

    def fail(self, element: etree._Element, message: str) -> InputError:
        return InputError(f"{self.path}: line {element.sourceline}: {message}")

    def floats(self, element: etree._Element, attribute: str, count: int, default: str | None = None) -> np.ndarray:
        text = element.get(attribute, default)
        if text is None:
            raise self.fail(element, f"<{element.tag}> has no {attribute!r}")
        try:
            values = [float(v) for v in _NUMBER_LIST.split(text.strip())]
        except ValueError:
            raise self.fail(element, f"<{element.tag} {attribute}={text!r}> is not a list of numbers") from None
        if len(values) != count or not np.all(np.isfinite(values)):
            raise self.fail(element, f"<{element.tag} {attribute}={text!r}> needs {count} finite numbers")
        return np.array(values)

    def origin(self, parent: etree._Element) -> np.ndarray:
        el = parent.find("origin")
        if el is None:
            return np.eye(4)
        return transform_from_xyz_rpy(self.floats(el, "xyz", 3, "0 0 0"), self.floats(el, "rpy", 3, "0 0 0"))

    def mesh_path(self, element: etree._Element) -> Path:
        filename = element.get("filename", "")
        if filename in self._mesh_paths:
            return self._mesh_paths[filename]
        try:
            path = resolve_mesh(filename, self.folder, self.package_paths)
        except InputError as exc:
            raise self.fail(element, f"mesh {filename!r}: {exc}") from None
        if not path.is_file():
            raise self.fail(element, f"mesh {filename!r} does not exist")
        self._mesh_paths[filename] = path
        return path


def read_mesh_parts(path: Path) -> list[tuple[str, trimesh.Trimesh]]:
    """The triangle meshes of one mesh file (an OBJ may hold several materials, a DAE or glTF
    several nodes), placed by their nodes, in metres for a DAE with a `<unit>`; raises
    InputError "PATH: problem" for a file that is unsafe, too big, empty or NaN."""
    data = read_bounded(path, MAX_MESH_BYTES)
    MESH_TRIANGLES.check(path, declared_faces(data, path.suffix.lower()))
    unit_m = 1.0
    if path.suffix.lower() == ".dae":
        try:
            unit_m = collada_unit_m(data, path)  # parsed safely first: pycollada would resolve entities
        except InputError as exc:
            raise InputError(f"{path}: {str(exc).removeprefix(f'{path}: ')}") from None
    parts = _plain_obj_parts(data, path)
    if parts is None:
        try:
            loaded = trimesh.load(path, process=False, maintain_order=True)
        except Exception as exc:  # trimesh raises many types for corrupt files
            raise InputError(f"{path}: cannot be read: {type(exc).__name__}: {exc}") from None
        parts = [(name, mesh) for name, mesh in scene_parts(loaded, path.stem) if len(mesh.faces) > 0]
    if not parts:
        raise InputError(f"{path}: has no triangles")
    MESH_TRIANGLES.check(path, sum(len(mesh.faces) for _, mesh in parts))
    if not all(np.all(np.isfinite(mesh.vertices)) for _, mesh in parts):
        raise InputError(f"{path}: has non-finite (NaN or infinite) vertex coordinates")
    if unit_m != 1.0:
        for _, mesh in parts:
            mesh.apply_scale(unit_m)
    return parts


def _plain_obj_parts(data: bytes, path: Path) -> list[tuple[str, trimesh.Trimesh]] | None:
    """A plain OBJ (a collision hull, or a visual of one untextured material, as homemodel writes
    them) read by the strict OBJ reader, which gives what trimesh's parser does several times
    faster, its material made by trimesh's own MTL parser; None for any other file."""
    obj = read_plain_obj(data, path)
    if obj is None:
        return None
    mesh = obj.trimesh(keep_unreferenced=True)
    if b"mtllib" in data:
        material = _only_material(data, path, obj.materials)
        if material is None:
            return None
        mesh.visual = trimesh.visual.TextureVisuals(material=material)
    return [(path.stem, mesh)]


def _only_material(data: bytes, path: Path, used: tuple[str, ...]) -> trimesh.visual.material.SimpleMaterial | None:
    """The material trimesh's OBJ loader gives the faces of an OBJ that names one MTL file beside
    it and uses one of its materials before its first face, when that MTL has no texture (whose
    image trimesh would load); None otherwise."""
    from trimesh.exchange.obj import parse_mtl

    start = data.find(b"mtllib")
    end = data.find(b"\n", start)
    library = data[start + 6:end if end >= 0 else len(data)].decode("utf-8", "replace").strip()
    face = data.find(b"\nf ")
    if (len(used) != 1 or data.count(b"mtllib") != 1 or (start and data[start - 1:start] != b"\n")
            or not library or any(c in library for c in "/\\") or not 0 <= data.find(b"\nusemtl ") < face):
        return None
    mtl = path.parent / library
    if not mtl.is_file():
        return None
    text = read_bounded(mtl, MAX_MESH_BYTES)  # within the bound the OBJ beside it was read
    try:
        materials = parse_mtl(text) if b"map_" not in text.lower() else {}
    except Exception:  # trimesh's loader swallows it too, and then gives no material: it decides
        return None
    return trimesh.visual.material.SimpleMaterial(**materials[used[0]]) if used[0] in materials else None


def _load_mesh_parts(ctx: _Context, element: etree._Element) -> list[tuple[str, trimesh.Trimesh]]:
    """The parts of one mesh file, scaled as the URDF says."""
    path = ctx.mesh_path(element)
    try:
        parts = read_mesh_parts(path)
    except InputError as exc:
        raise ctx.fail(element, f"mesh {path.name} {str(exc).removeprefix(f'{path}: ')}") from None
    scale = ctx.floats(element, "scale", 3, "1 1 1")
    if not np.allclose(scale, 1.0):
        for _, mesh in parts:
            mesh.apply_scale(scale)
    return parts


def scene_parts(loaded: trimesh.Trimesh | trimesh.Scene, stem: str) -> list[tuple[str, trimesh.Trimesh]]:
    """(name, mesh) of every triangle mesh a file holds, each placed by its scene node's
    transform (a DAE's or glTF's nodes move their meshes; an OBJ's are the identity)."""
    if not isinstance(loaded, trimesh.Scene):
        return [(stem, loaded)] if isinstance(loaded, trimesh.Trimesh) else []
    parts: list[tuple[str, trimesh.Trimesh]] = []
    used: set[str] = set()
    for node in loaded.graph.nodes_geometry:
        transform, geometry_name = loaded.graph[node]
        mesh = loaded.geometry.get(geometry_name)
        if not isinstance(mesh, trimesh.Trimesh):
            continue
        if not np.allclose(transform, np.eye(4)):
            mesh = mesh.copy()
            mesh.apply_transform(transform)
        name = geometry_name if geometry_name not in used else str(node)
        used.add(name)
        parts.append((name, mesh))
    return parts


def _mtl_textures(obj_path: Path, model_folder: Path) -> dict[str, Path]:
    """Material name -> texture image, from the OBJ's MTL files (trimesh keeps images, not
    paths). Images may lie anywhere in the model folder (PartNet-Mobility's MTLs name
    `../images/texture_N.jpg`), or beside the OBJ when it lies in another package.
    `obj_path` is resolved (`_Context.mesh_path`), and so is its folder."""
    root = model_folder if obj_path.is_relative_to(model_folder) else obj_path.parent
    textures: dict[str, Path] = {}
    for line in obj_path.read_text(errors="replace").splitlines():
        if not line.startswith("mtllib "):
            continue
        mtl = (obj_path.parent / line.split(None, 1)[1].strip()).resolve()
        if not mtl.is_relative_to(obj_path.parent) or not mtl.is_file():
            continue
        current = None
        for mline in mtl.read_text(errors="replace").splitlines():
            words = mline.split(None, 1)
            if len(words) == 2 and words[0] == "newmtl":
                current = words[1].strip()
            elif len(words) == 2 and words[0] == "map_Kd" and current is not None:
                image = (mtl.parent / words[1].strip().split()[-1]).resolve()
                if image.is_file() and image.is_relative_to(root):
                    textures[current] = image
    return textures


def _material_of(ctx: _Context, visual_el: etree._Element, mesh: trimesh.Trimesh | None, textures: dict[str, Path]):
    el = visual_el.find("material")
    name, rgba, texture = "default", (0.8, 0.8, 0.8, 1.0), None
    if mesh is not None and isinstance(mesh.visual, trimesh.visual.TextureVisuals):
        mat = mesh.visual.material
        name = getattr(mat, "name", None) or name
        texture = textures.get(name)
        diffuse = getattr(mat, "diffuse", None)
        if diffuse is not None:
            rgba = tuple(float(c) / 255.0 for c in np.asarray(diffuse, dtype=float)[:4])
    if el is not None:
        name = el.get("name") or name
        colour = el.find("color")
        if colour is not None:
            rgba = tuple(ctx.floats(colour, "rgba", 4))
        elif name in ctx.global_materials:
            rgba = ctx.global_materials[name]
    return Material(name=name, rgba=rgba, texture=texture)


def _visuals(ctx: _Context, link_el: etree._Element, link_name: str) -> list[Visual]:
    visuals: list[Visual] = []
    for index, el in enumerate(link_el.findall("visual")):
        origin = ctx.origin(el)
        base = el.get("name") or f"visual{index}"
        for part_name, mesh, textures in _geometry_meshes(ctx, el):
            name = base if part_name is None else f"{base}_{part_name}"
            material = _material_of(ctx, el, mesh, textures)
            uv = None
            if material.texture is not None and getattr(mesh.visual, "uv", None) is not None:
                uv = np.asarray(mesh.visual.uv, dtype=np.float64)
            if uv is None:
                material.texture = None
            plain = trimesh.Trimesh(vertices=mesh.vertices, faces=mesh.faces, process=False)
            visuals.append(Visual(name=name, mesh=plain, material=material, link_from_visual=origin, uv=uv))
    return visuals


def _geometry_meshes(ctx: _Context, parent: etree._Element):
    """(part name or None, mesh, textures) for a <visual>'s geometry."""
    geometry = parent.find("geometry")
    if geometry is None or len(geometry) == 0:
        raise ctx.fail(parent, f"<{parent.tag}> has no geometry")
    shape = geometry[0]
    primitive = _primitive(ctx, shape)
    if primitive is not None:
        return [(None, primitive_mesh(primitive), {})]
    if shape.tag != "mesh":
        raise ctx.fail(shape, f"unknown geometry <{shape.tag}>")
    parts = _load_mesh_parts(ctx, shape)
    textures = _mtl_textures(ctx.mesh_path(shape), ctx.folder) if ctx.mesh_path(shape).suffix.lower() == ".obj" else {}
    single = len(parts) == 1
    return [(None if single else name, mesh, textures) for name, mesh in parts]


def _primitive(ctx: _Context, shape: etree._Element) -> Box | Cylinder | Sphere | None:
    if shape.tag == "box":
        return Box(size_m=tuple(ctx.floats(shape, "size", 3)))
    if shape.tag == "cylinder":
        return Cylinder(radius_m=ctx.floats(shape, "radius", 1)[0], length_m=ctx.floats(shape, "length", 1)[0])
    if shape.tag == "sphere":
        return Sphere(radius_m=ctx.floats(shape, "radius", 1)[0])
    return None


def primitive_mesh(primitive: Box | Cylinder | Sphere) -> trimesh.Trimesh:
    if isinstance(primitive, Box):
        return trimesh.creation.box(primitive.size_m)
    if isinstance(primitive, Cylinder):
        return trimesh.creation.cylinder(radius=primitive.radius_m, height=primitive.length_m, sections=32)
    return trimesh.creation.icosphere(subdivisions=2, radius=primitive.radius_m)


def _collisions(ctx: _Context, link_el: etree._Element) -> list[Collision]:
    collisions: list[Collision] = []
    for index, el in enumerate(link_el.findall("collision")):
        origin = ctx.origin(el)
        name = el.get("name") or f"collision{index}"
        geometry = el.find("geometry")
        if geometry is None or len(geometry) == 0:
            raise ctx.fail(el, "<collision> has no geometry")
        primitive = _primitive(ctx, geometry[0])
        if primitive is not None:
            collisions.append(Collision(name=name, geometry=primitive, link_from_collision=origin))
            continue
        for part_name, mesh in _load_mesh_parts(ctx, geometry[0]):
            part = name if part_name == ctx.mesh_path(geometry[0]).stem else f"{name}_{part_name}"
            plain = trimesh.Trimesh(vertices=mesh.vertices, faces=mesh.faces, process=False)
            collisions.append(Collision(name=part, geometry=MeshGeometry(mesh=plain), link_from_collision=origin))
    return collisions


def _inertial(ctx: _Context, link_el: etree._Element) -> Inertial | None:
    el = link_el.find("inertial")
    if el is None:
        return None
    mass_el, inertia_el = el.find("mass"), el.find("inertia")
    if mass_el is None or inertia_el is None:
        raise ctx.fail(el, "<inertial> needs <mass> and <inertia>")
    origin = ctx.origin(el)
    names = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    xx, xy, xz, yy, yz, zz = (ctx.floats(inertia_el, n, 1, "0")[0] for n in names)
    inertia = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    rotation = origin[:3, :3]
    # The model keeps the tensor in link axes; URDF may give it in a rotated inertial frame.
    return Inertial(
        mass_kg=ctx.floats(mass_el, "value", 1)[0], com_m=origin[:3, 3], inertia_kgm2=rotation @ inertia @ rotation.T
    )


def _joints(ctx: _Context, robot: etree._Element, states: dict[str, list[JointState]]) -> list[Joint]:
    joints: list[Joint] = []
    for el in urdf_doc.joints(robot):
        name, kind = el.get("name"), el.get("type")
        if not name:
            raise ctx.fail(el, "<joint> has no name")
        if kind not in JOINT_TYPES:
            raise ctx.fail(el, f"joint {name!r} has unsupported type {kind!r}")
        parent, child = el.find("parent"), el.find("child")
        if parent is None or child is None or not parent.get("link") or not child.get("link"):
            raise ctx.fail(el, f"joint {name!r} needs <parent link> and <child link>")
        axis_el = el.find("axis")
        axis = ctx.floats(axis_el, "xyz", 3, "1 0 0") if axis_el is not None else np.array([1.0, 0.0, 0.0])
        limit_el = el.find("limit")
        limits = None
        if limit_el is not None:
            limits = JointLimits(
                lower=ctx.floats(limit_el, "lower", 1, "0")[0],
                upper=ctx.floats(limit_el, "upper", 1, "0")[0],
                effort=ctx.floats(limit_el, "effort", 1, "0")[0],
                velocity=ctx.floats(limit_el, "velocity", 1, "0")[0],
            )
        dynamics_el = el.find("dynamics")
        dynamics = None
        if dynamics_el is not None:
            dynamics = JointDynamics(
                damping=ctx.floats(dynamics_el, "damping", 1, "0")[0],
                friction=ctx.floats(dynamics_el, "friction", 1, "0")[0],
            )
        joints.append(
            Joint(
                name=name,
                type=kind,
                parent=parent.get("link"),
                child=child.get("link"),
                parent_from_joint=ctx.origin(el),
                axis=axis,
                limits=limits,
                dynamics=dynamics,
                states=states.get(name, []),
            )
        )
    return joints


# Mesh files `homemodel.model_folder.asset_import` makes one-link models of.
MESH_FILE_SUFFIXES = (".glb", ".gltf", ".obj", ".stl", ".ply", ".dae")
# A model folder holds homemodel's model.urdf, or PartNet-Mobility's mobility.urdf.
URDF_NAMES: tuple[str, ...] = ("model.urdf", "mobility.urdf")


def find_urdf(path: Path) -> Path:
    """The URDF of a model folder, or `path` itself when it is a .urdf file."""
    path = Path(path)
    if path.is_dir():
        for name in URDF_NAMES:
            if (path / name).is_file():
                return path / name
        raise InputError(f"{path}: a model folder must contain {' or '.join(URDF_NAMES)}")
    if not path.exists():
        raise InputError(f"{path}: no such file or folder")
    if path.suffix.lower() == ".xacro":
        raise InputError(f"{path}: a xacro macro file, not a URDF: expand it first (`xacro {path.name} > robot.urdf`)")
    if path.suffix.lower() in MESH_FILE_SUFFIXES:
        raise InputError(
            f"{path}: a mesh file, not a model: import it first (a manifest entry `source: urdf` with "
            "`repair: true`, `homemodel db build`), then use the model folder or db:ID"
        )
    if path.suffix.lower() != ".urdf":
        raise InputError(f"{path}: expected a model folder or a .urdf file")
    return path


def load_urdf(path: Path, *, package_paths: Sequence[Path] = ()) -> Model:
    """Read `path` into a Model; raises InputError naming the file and line on bad input.
    `package://NAME/...` meshes are found in the package holding the URDF, else in
    `package_paths` (see `homemodel.exchange.urdf.mesh_paths.find_package`)."""
    path = Path(path)
    ctx = _Context(path, package_paths)
    robot = urdf_doc.read_urdf_robot(path)
    for el in robot.findall("material"):
        colour = el.find("color")
        if el.get("name") and colour is not None:
            ctx.global_materials[el.get("name")] = tuple(ctx.floats(colour, "rgba", 4))
    ext = robot.find("homemodel")
    states: dict[str, list[JointState]] = {}
    grasp_points: list[GraspPoint] = []
    category, affordances, properties = "object", [], {}
    if ext is not None:
        category = ext.get("category", category)
        affordances = [a.get("name") for a in ext.findall("affordance") if a.get("name")]
        properties = {p.get("name"): p.get("value", "") for p in ext.findall("property") if p.get("name")}
        for g in ext.findall("grasp_point"):
            grasp_points.append(
                GraspPoint(name=g.get("name"), link=g.get("link"), kind=g.get("kind", "handle"), link_from_grasp=ctx.origin(g))
            )
        for s in ext.findall("joint_state"):
            states.setdefault(s.get("joint"), []).append(
                JointState(name=s.get("name"), position=ctx.floats(s, "position", 1)[0])
            )
    links = []
    for el in urdf_doc.links(robot):
        name = el.get("name")
        if not name:
            raise ctx.fail(el, "<link> has no name")
        links.append(Link(name=name, visuals=_visuals(ctx, el, name), collisions=_collisions(ctx, el), inertial=_inertial(ctx, el)))
    try:
        return Model(
            name=robot.get("name") or path.stem,
            links=links,
            joints=_joints(ctx, robot, states),
            grasp_points=grasp_points,
            category=category,
            affordances=affordances,
            properties=properties,
        )
    except ModelError as exc:
        raise InputError(f"{path}: {exc}") from None
