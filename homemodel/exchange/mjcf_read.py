"""Read MuJoCo MJCF (ours, `mjcf.py`'s, or one MuJoCo saved) back into a scene.

- Each body of `<worldbody>` is an object: with a `<freejoint>` a free one, else fixed where
  it stands. Its bodies are the links; a body with one hinge or slide joint hangs on a
  revolute (continuous when unlimited) or prismatic joint, a body without a joint on a fixed
  one (named `<parent>_to_<child>`: MJCF has no name for it).
- A joint's `ref` is the position its body is written at (`qpos0`): the scene's joint position.
- Geoms that never collide (contype = conaffinity = 0) are visuals, those of group 3 (our
  collision group) collisions, any other both, as MuJoCo shows and collides them.
- Keyframes named `<joint>=<state>` are the joint's named states.
- What MJCF has no place for (a limit's effort and velocity, grasp points, semantics) keeps the
  model's defaults. `<include>` is refused: it reads other files.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import trimesh
from lxml import etree

from articulation.model import (
    Box,
    Collision,
    Cylinder,
    Inertial,
    Joint,
    JointDynamics,
    JointLimits,
    JointState,
    Link,
    Material,
    MeshGeometry,
    Sphere,
)
from articulation.scene import Scene, Wall
from homemodel.core.errors import InputError, ModelError
from homemodel.core.safe_xml import parse_xml_file
from homemodel.core.transforms import axis_angle_transform, translation_transform
from homemodel.exchange.mjcf import COLLISION_GROUP
from homemodel.exchange.scene_read import (
    ObjectParts,
    mesh_file,
    object_prefix,
    part_name,
    read_visual,
    reanchor,
    texture_file,
    wall_from_box,
)

_NUMBERS = re.compile(r"\s+")
_QPOS_SIZE = {"free": 7, "ball": 4, "hinge": 1, "slide": 1}
DEFAULT_RGBA = (0.5, 0.5, 0.5, 1.0)


def _z_to(direction: np.ndarray) -> np.ndarray:
    """The shortest turn of the z axis onto `direction`, half a turn about x when opposite
    (MuJoCo's `mju_quatZ2Vec`, so geoms given by `fromto` or `zaxis` match MuJoCo's)."""
    v = direction / np.linalg.norm(direction)
    axis = np.cross([0.0, 0.0, 1.0], v)
    if np.linalg.norm(axis) < 1e-12:
        return np.eye(3) if v[2] > 0 else np.diag([1.0, -1.0, -1.0])
    return axis_angle_transform(axis, float(np.arccos(np.clip(v[2], -1.0, 1.0))))[:3, :3]


class _Document:
    """The parts of an MJCF document every body needs: units, default classes, assets."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.root = parse_xml_file(path).getroot()
        if self.root.tag != "mujoco":
            raise InputError(f"{path}: root element is <{self.root.tag}>, expected <mujoco>")
        include = next(self.root.iter("include"), None)
        if include is not None:
            raise self.fail(include, "<include> is not read (it opens other files): merge them into one file")
        # MuJoCo 3's composition elements place bodies and geoms a model reader would miss.
        composed = next(self.root.iter("frame", "replicate", "attach", "composite", "flexcomp"), None)
        if composed is not None:
            raise self.fail(composed, f"<{composed.tag}> is not read (it places bodies and geoms of its own)")
        compiler: dict[str, str] = {}
        for el in self.root.findall("compiler"):
            compiler.update(el.attrib)
        angle = compiler.get("angle", "degree")
        if angle not in ("degree", "radian"):
            raise InputError(f"{path}: <compiler angle={angle!r}> must be degree or radian")
        self.angle_scale = 1.0 if angle == "radian" else np.pi / 180.0
        self.eulerseq = compiler.get("eulerseq", "xyz")
        if not re.fullmatch(r"[xyz]{3}|[XYZ]{3}", self.eulerseq):
            raise InputError(f"{path}: <compiler eulerseq={self.eulerseq!r}> is not read (mixed case or not three axes)")
        self.autolimits = compiler.get("autolimits", "true") == "true"
        self.meshdir = compiler.get("meshdir", compiler.get("assetdir", ""))
        self.texturedir = compiler.get("texturedir", compiler.get("assetdir", ""))
        self.classes: dict[str, dict[str, dict[str, str]]] = {}
        for top in self.root.findall("default"):
            self._defaults(top, top.get("class", "main"), {})
        self.meshes = {(el.get("name") or Path(el.get("file", "")).stem): el for el in self.root.iterfind("asset/mesh")}
        self.materials = {el.get("name"): el for el in self.root.iterfind("asset/material")}
        self.textures = {el.get("name"): el for el in self.root.iterfind("asset/texture")}

    def _defaults(self, element: etree._Element, name: str, inherited: dict[str, dict[str, str]]) -> None:
        own = {tag: dict(values) for tag, values in inherited.items()}
        for child in element:
            if child.tag != "default":
                own.setdefault(child.tag, {}).update(child.attrib)
        self.classes[name] = own
        for child in element.findall("default"):
            self._defaults(child, child.get("class", ""), own)

    def fail(self, element: etree._Element, message: str) -> InputError:
        return InputError(f"{self.path}: line {element.sourceline}: {message}")

    def get(self, element: etree._Element, attribute: str, childclass: str = "main", default: str | None = None) -> str | None:
        """An attribute as MuJoCo resolves it: the element's own, else its default class's."""
        if attribute in element.attrib:
            return element.get(attribute)
        values = self.classes.get(element.get("class", childclass), {}).get(element.tag, {})
        return values.get(attribute, default)

    def floats(self, element: etree._Element, attribute: str, count: int | None, childclass: str = "main",
               default: str | None = None) -> np.ndarray:
        text = self.get(element, attribute, childclass, default)
        if text is None:
            raise self.fail(element, f"<{element.tag}> has no {attribute!r}")
        try:
            values = np.array([float(v) for v in _NUMBERS.split(text.strip())])
        except ValueError:
            raise self.fail(element, f"<{element.tag} {attribute}={text!r}> is not a list of numbers") from None
        if (count is not None and len(values) != count) or not np.all(np.isfinite(values)):
            raise self.fail(element, f"<{element.tag} {attribute}={text!r}> needs {count or 'some'} finite numbers")
        return values

    def frame(self, element: etree._Element, childclass: str = "main") -> np.ndarray:
        """`parent_from_element` of a body, geom, site or inertial (its pos and orientation)."""
        m = np.eye(4)
        if self.get(element, "fromto", childclass) is not None:
            ends = self.floats(element, "fromto", 6, childclass).reshape(2, 3)
            if np.linalg.norm(ends[0] - ends[1]) < 1e-12:
                raise self.fail(element, "fromto has two equal ends")
            m[:3, :3] = _z_to(ends[0] - ends[1])  # MuJoCo's z points from `to` to `from`
            m[:3, 3] = ends.mean(axis=0)
            return m
        m[:3, 3] = self.floats(element, "pos", 3, childclass, "0 0 0")
        for attribute in ("quat", "axisangle", "euler", "xyaxes", "zaxis"):
            if self.get(element, attribute, childclass) is not None:
                m[:3, :3] = self._rotation(element, attribute, childclass)
                break
        return m

    def _rotation(self, element: etree._Element, attribute: str, childclass: str) -> np.ndarray:
        if attribute == "quat":
            q = self.floats(element, "quat", 4, childclass)
            if np.linalg.norm(q) < 1e-12:
                raise self.fail(element, "quat is zero")
            return trimesh.transformations.quaternion_matrix(q / np.linalg.norm(q))[:3, :3]
        if attribute == "axisangle":
            v = self.floats(element, "axisangle", 4, childclass)
            if np.linalg.norm(v[:3]) < 1e-12:
                raise self.fail(element, "axisangle has no axis")
            return axis_angle_transform(v[:3], v[3] * self.angle_scale)[:3, :3]
        if attribute == "euler":
            angles = self.floats(element, "euler", 3, childclass) * self.angle_scale
            # MuJoCo: lower case turns about the moving axes, upper case about the fixed ones.
            rotation = np.eye(3)
            for letter, angle in zip(self.eulerseq.lower(), angles):
                turn = axis_angle_transform(np.eye(3)["xyz".index(letter)], angle)[:3, :3]
                rotation = rotation @ turn if self.eulerseq.islower() else turn @ rotation
            return rotation
        if attribute == "xyaxes":
            v = self.floats(element, "xyaxes", 6, childclass)
            x = v[:3] / np.linalg.norm(v[:3])
            z = np.cross(x, v[3:])
            if not np.all(np.isfinite(x)) or np.linalg.norm(z) < 1e-12:
                raise self.fail(element, "xyaxes are not two independent directions")
            z /= np.linalg.norm(z)
            return np.column_stack([x, np.cross(z, x), z])
        z = self.floats(element, "zaxis", 3, childclass)
        if np.linalg.norm(z) < 1e-12:
            raise self.fail(element, "zaxis has no direction")
        return _z_to(z)

    def mesh(self, geom: etree._Element, name: str) -> tuple[trimesh.Trimesh, np.ndarray | None]:
        asset = self.meshes.get(name)
        if asset is None or asset.get("file") is None:
            raise self.fail(geom, f"mesh {name!r} is not an asset with a file")
        mesh, uv = mesh_file(self.path, str(Path(self.meshdir) / asset.get("file")), f"mesh {name!r}")
        scale = self.floats(asset, "scale", 3, default="1 1 1")
        if not np.allclose(scale, 1.0):
            mesh.apply_scale(scale)
        return mesh, uv

    def material(self, geom: etree._Element, childclass: str, name: str) -> tuple[Material, bool]:
        """The geom's look, and whether it shows a texture image."""
        if self.get(geom, "rgba", childclass) is not None:
            return Material(name=name, rgba=tuple(self.floats(geom, "rgba", 4, childclass))), False
        material_name = self.get(geom, "material", childclass)
        el = self.materials.get(material_name)
        if el is None:
            return Material(name=name, rgba=DEFAULT_RGBA), False
        rgba = tuple(self.floats(el, "rgba", 4, default="1 1 1 1"))
        texture = self.textures.get(el.get("texture"))
        image = None
        if texture is not None and texture.get("file") is not None:
            image = texture_file(self.path, str(Path(self.texturedir) / texture.get("file")), f"texture {texture.get('name')!r}")
        return Material(name=material_name, rgba=rgba, texture=image), image is not None


class _Reader:
    def __init__(self, doc: _Document) -> None:
        self.doc = doc
        self.qpos0: list[float] = []
        self.joint_adr: dict[str, tuple[ObjectParts, str, int]] = {}  # scoped name -> object, joint, qpos index

    def geoms(self, body: etree._Element, childclass: str, link: Link, prefix: str) -> None:
        doc = self.doc
        for index, geom in enumerate(body.findall("geom")):
            scoped = geom.get("name") or f"{link.name}_geom{index}"
            kind = doc.get(geom, "type", childclass, "sphere")
            size = doc.floats(geom, "size", None, childclass, "0 0 0")
            if doc.get(geom, "fromto", childclass) is not None and kind in ("capsule", "cylinder", "box", "ellipsoid"):
                ends = doc.floats(geom, "fromto", 6, childclass).reshape(2, 3)
                half = float(np.linalg.norm(ends[1] - ends[0])) / 2
                size = np.array([size[0], size[0], half]) if kind == "box" else np.array([size[0], half, half])
            link_from_geom = doc.frame(geom, childclass)
            shape, mesh, uv = self.shape(geom, kind, size)
            contype = int(doc.floats(geom, "contype", 1, childclass, "1")[0])
            conaffinity = int(doc.floats(geom, "conaffinity", 1, childclass, "1")[0])
            group = int(doc.floats(geom, "group", 1, childclass, "0")[0])
            is_visual = group != COLLISION_GROUP or (contype == 0 and conaffinity == 0)
            is_collision = contype != 0 or conaffinity != 0
            if is_visual:
                material, textured = doc.material(geom, childclass, part_name(scoped, prefix, link.name))
                link.visuals.append(
                    read_visual(part_name(scoped, prefix, link.name), shape, mesh, uv, material, textured, link_from_geom)
                )
            if is_collision:
                geometry = shape if shape is not None else MeshGeometry(mesh=mesh)
                name = part_name(scoped, prefix, link.name, ("_collision", "_hull"))
                link.collisions.append(Collision(name=name, geometry=geometry, link_from_collision=link_from_geom))

    def shape(self, geom: etree._Element, kind: str, size: np.ndarray):
        """(primitive shape or None, mesh or None, texture coordinates) of a geom."""
        need = {"box": 3, "cylinder": 2, "capsule": 2, "ellipsoid": 3, "sphere": 1}.get(kind, 0)
        if len(size) < need or np.any(size[:need] <= 0):
            raise self.doc.fail(geom, f"<geom type={kind!r}> needs {need} positive sizes, got {size.tolist()}")
        if kind == "box":
            return Box(size_m=tuple(2 * size[:3])), None, None
        if kind == "cylinder":
            return Cylinder(radius_m=float(size[0]), length_m=float(2 * size[1])), None, None
        if kind == "sphere":
            return Sphere(radius_m=float(size[0])), None, None
        if kind == "capsule":
            return None, trimesh.creation.capsule(height=2 * size[1], radius=size[0]), None
        if kind == "ellipsoid":
            mesh = trimesh.creation.icosphere(subdivisions=2)
            mesh.apply_scale(size[:3])
            return None, mesh, None
        if kind == "mesh":
            name = self.doc.get(geom, "mesh")
            mesh, uv = self.doc.mesh(geom, name or "")
            return None, mesh, uv
        raise self.doc.fail(geom, f"<geom type={kind!r}> is not read in a body (box, sphere, cylinder, capsule, ellipsoid, mesh)")

    def inertial(self, body: etree._Element) -> Inertial | None:
        el = body.find("inertial")
        if el is None:
            return None
        doc = self.doc
        frame = doc.frame(el)
        if el.get("fullinertia") is not None:
            xx, yy, zz, xy, xz, yz = doc.floats(el, "fullinertia", 6)
            tensor = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        else:
            tensor = np.diag(doc.floats(el, "diaginertia", 3))
        rotation = frame[:3, :3]
        return Inertial(mass_kg=float(doc.floats(el, "mass", 1)[0]), com_m=frame[:3, 3], inertia_kgm2=rotation @ tensor @ rotation.T)

    def joint(self, body: etree._Element, childclass: str, parts: ObjectParts, prefix: str, parent: str, child: Link) -> np.ndarray:
        """The joint that hangs `child` (the body) on `parent`; returns `body_from_link`, where the
        model's child frame lies (on the joint's `pos`), for `body` to move the link there."""
        doc = self.doc
        joints = [el for el in body if el.tag in ("joint", "freejoint")]
        parent_from_body = doc.frame(body, childclass)
        if not joints:
            parts.joints.append(Joint(name=f"{parent}_to_{child.name}", type="fixed", parent=parent, child=child.name,
                                      parent_from_joint=parent_from_body))
            return np.eye(4)
        if len(joints) > 1:
            raise doc.fail(body, f"body {body.get('name')!r} has {len(joints)} joints; a model's link hangs on one")
        el = joints[0]
        kind = "free" if el.tag == "freejoint" else doc.get(el, "type", childclass, "hinge")
        if kind not in ("hinge", "slide"):
            raise doc.fail(el, f"a {kind} joint inside a model is not read (hinge and slide are)")
        scoped = el.get("name") or f"{child.name}_joint"
        name = scoped.removeprefix(prefix)
        axis = doc.floats(el, "axis", 3, childclass, "0 0 1")
        if np.linalg.norm(axis) < 1e-12:
            raise doc.fail(el, f"joint {scoped!r}: axis has no direction")
        axis = axis / np.linalg.norm(axis)
        scale = doc.angle_scale if kind == "hinge" else 1.0
        ref = float(doc.floats(el, "ref", 1, childclass, "0")[0]) * scale
        range_text = doc.get(el, "range", childclass)
        limited = doc.get(el, "limited", childclass, "auto")
        has_range = limited == "true" or (limited == "auto" and doc.autolimits and range_text is not None)
        limits = None
        if has_range:
            lower, upper = doc.floats(el, "range", 2, childclass) * scale
            limits = JointLimits(lower=float(lower), upper=float(upper))
        damping = doc.get(el, "damping", childclass)
        friction = doc.get(el, "frictionloss", childclass)
        dynamics = None
        if damping is not None or friction is not None:
            dynamics = JointDynamics(damping=float(doc.floats(el, "damping", 1, childclass, "0")[0]),
                                     friction=float(doc.floats(el, "frictionloss", 1, childclass, "0")[0]))
        body_from_link = translation_transform(doc.floats(el, "pos", 3, childclass, "0 0 0"))
        joint_type = "prismatic" if kind == "slide" else ("revolute" if limits is not None else "continuous")
        joint = Joint(name=name, type=joint_type, parent=parent, child=child.name, axis=axis, limits=limits, dynamics=dynamics)
        joint.parent_from_joint = parent_from_body @ body_from_link @ np.linalg.inv(joint.joint_from_child(ref))
        parts.joints.append(joint)
        parts.joint_positions[name] = ref
        self.joint_adr[scoped] = (parts, name, len(self.qpos0))
        self.qpos0.append(ref)
        return body_from_link

    def body(self, body: etree._Element, childclass: str, parts: ObjectParts, prefix: str, parent: str | None) -> None:
        childclass = body.get("childclass", childclass)
        link = Link(name=(body.get("name") or f"body{len(parts.links)}").removeprefix(prefix))
        self.geoms(body, childclass, link, prefix)
        link.inertial = self.inertial(body)
        parts.links.append(link)
        body_from_link = np.eye(4) if parent is None else self.joint(body, childclass, parts, prefix, parent, link)
        for child in body.findall("body"):
            self.body(child, childclass, parts, prefix, link.name)
        # The model's joint frame is its child's frame: the link moves onto the joint's `pos`,
        # once its child joints exist to follow it.
        reanchor(link, parts.joints, body_from_link)

    def top_body(self, body: etree._Element) -> ObjectParts:
        doc = self.doc
        childclass = body.get("childclass", "main")
        names = [el.get("name", "") for el in body.iter("body", "joint", "freejoint")]
        prefix = object_prefix(body.get("name") or "", names)
        parts = ObjectParts(id=prefix[:-2] if prefix else (body.get("name") or f"body_line_{body.sourceline}"))
        parts.world_from_model = doc.frame(body, childclass)
        own = [el for el in body if el.tag in ("joint", "freejoint")]
        kinds = [("free" if el.tag == "freejoint" else doc.get(el, "type", childclass, "hinge")) for el in own]
        if kinds and kinds != ["free"]:
            raise doc.fail(body, f"body {body.get('name')!r}: only a free joint joins an object to the world, not {kinds}")
        parts.free = bool(kinds)
        if parts.free:
            x, y, z = parts.world_from_model[:3, 3]
            w, qx, qy, qz = trimesh.transformations.quaternion_from_matrix(parts.world_from_model)
            self.qpos0.extend([x, y, z, w, qx, qy, qz])
        self.body(body, childclass, parts, prefix, None)
        return parts

    def states(self, objects: list[ObjectParts]) -> None:
        """Each keyframe `<joint>=<state>`: the named state of that joint."""
        for key in self.doc.root.iterfind("keyframe/key"):
            scoped, sep, state = (key.get("name") or "").rpartition("=")
            if not sep or scoped not in self.joint_adr:
                continue
            qpos = self.doc.floats(key, "qpos", None, default=" ".join(map(str, self.qpos0)))
            if len(qpos) != len(self.qpos0):
                raise self.doc.fail(key, f"key {key.get('name')!r} has {len(qpos)} qpos values, the bodies {len(self.qpos0)}")
            parts, joint_name, index = self.joint_adr[scoped]
            joint = next(j for j in parts.joints if j.name == joint_name)
            joint.states.append(JointState(name=state, position=float(qpos[index])))


def _world_geoms(doc: _Document, world: etree._Element) -> tuple[bool, list[Wall]]:
    """The floor (a plane) and our walls (boxes `..._wall_<n>`) among the world's own geoms."""
    floor, walls = False, []
    for geom in world.findall("geom"):
        kind = doc.get(geom, "type", default="sphere")
        if kind == "plane":
            floor = True
            continue
        wall = None
        if kind == "box":
            wall = wall_from_box(geom.get("name") or "", doc.frame(geom), 2 * doc.floats(geom, "size", 3))
        if wall is None:
            raise doc.fail(geom, f"world geom {geom.get('name')!r} is not read: only a floor plane and walls are")
        walls.append(wall)
    return floor, walls


def read_mjcf(path: Path) -> Scene:
    """The scene of an MJCF file: its objects, floor and walls; InputError naming the file
    (and line) for a file that is not one, or uses what a model cannot hold."""
    path = Path(path)
    doc = _Document(path)
    world = doc.root.find("worldbody")
    if world is None:
        raise InputError(f"{path}: has no <worldbody>")
    reader = _Reader(doc)
    objects = [reader.top_body(body) for body in world.findall("body")]
    if not objects:
        raise InputError(f"{path}: has no bodies")
    reader.states(objects)
    floor, walls = _world_geoms(doc, world)
    scene_objects = [parts.scene_object(path) for parts in objects]
    try:
        return Scene(name=doc.root.get("model") or path.stem, objects=scene_objects, floor=floor, walls=walls)
    except ModelError as exc:
        raise InputError(f"{path}: {exc}") from None
