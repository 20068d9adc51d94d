"""Read SDFormat (ours, `sdf.py`'s, or one `gz sdf -p` printed) back into a scene.

- Each `<model>` of the world (or of a bare `<sdf>`) is an object: fixed when a joint holds it
  to `world` or it is `<static>`, else free. Our static `floor` and `..._wall_<n>` models
  are the scene's floor and walls.
- A link's pose is read relative to the model or another link; a joint's pose relative to
  its child; its axis in the joint frame (SDFormat 1.7 and later).
- SDFormat has no initial joint position: the links' poses are the joints' zero. Our writer
  puts the scene's position in `<homemodel:states offset>` and shifts the limits and named
  states by it; the reader shifts them back.
- `<include>` and nested models are refused: they open other files or need frames a model
  cannot hold.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
from lxml import etree

from articulation.joint_types import JOINT_TYPES
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
from articulation.scene import Scene
from homemodel.core.errors import InputError, ModelError
from homemodel.core.safe_xml import parse_xml_file
from homemodel.core.transforms import transform_from_xyz_rpy
from homemodel.exchange.scene_read import (
    ObjectParts,
    mesh_file,
    object_prefix,
    part_name,
    read_visual,
    tree_depth,
    reanchor,
    texture_file,
    wall_from_box,
)
from homemodel.exchange.sdf import HOMEMODEL_NS

_NUMBERS = re.compile(r"\s+")
# Our writer's "no limit" (SDFormat's own default is 1e16 too).
_UNLIMITED = 1e15
_MODEL_FRAME = ("", "__model__")


class _Reader:
    def __init__(self, path: Path) -> None:
        self.path = path

    def fail(self, element: etree._Element, message: str) -> InputError:
        return InputError(f"{self.path}: line {element.sourceline}: {message}")

    def numbers(self, element: etree._Element, count: int) -> np.ndarray:
        text = (element.text or "").strip()
        try:
            values = np.array([float(v) for v in _NUMBERS.split(text)]) if text else np.zeros(0)
        except ValueError:
            raise self.fail(element, f"<{element.tag}>{text[:40]}</{element.tag}> is not a list of numbers") from None
        if len(values) != count or not np.all(np.isfinite(values)):
            raise self.fail(element, f"<{element.tag}> needs {count} finite numbers, got {text[:40]!r}")
        return values

    def number(self, parent: etree._Element, tag: str, default: float) -> float:
        el = parent.find(tag)
        return default if el is None else float(self.numbers(el, 1)[0])

    def pose(self, parent: etree._Element) -> tuple[np.ndarray, str]:
        """(`frame_from_element`, the frame it is relative to) of `parent`'s `<pose>`."""
        el = parent.find("pose")
        if el is None:
            return np.eye(4), ""
        if el.get("rotation_format", "euler_rpy") == "quat_xyzw":
            import trimesh

            v = self.numbers(el, 7)
            if np.linalg.norm(v[3:]) < 1e-12:
                raise self.fail(el, "<pose> quaternion is zero")
            m = trimesh.transformations.quaternion_matrix([v[6], *v[3:6]] / np.linalg.norm(v[3:]))
            m[:3, 3] = v[:3]
        else:
            v = self.numbers(el, 6)
            angles = np.radians(v[3:]) if el.get("degrees") == "true" else v[3:]
            m = transform_from_xyz_rpy(v[:3], angles)
        return m, el.get("relative_to", "")

    def geometry(self, parent: etree._Element, what: str):
        """(primitive shape or None, mesh or None, texture coordinates) of a `<geometry>`."""
        geometry = parent.find("geometry")
        shape = None if geometry is None else next((el for el in geometry if isinstance(el.tag, str)), None)
        if shape is None:
            raise self.fail(parent, f"{what} has no geometry")
        if shape.tag == "box":
            size = self.numbers(_child(self, shape, "size"), 3)
            return Box(size_m=tuple(size)), None, None
        if shape.tag == "cylinder":
            return Cylinder(radius_m=self.number(shape, "radius", 1.0), length_m=self.number(shape, "length", 1.0)), None, None
        if shape.tag == "sphere":
            return Sphere(radius_m=self.number(shape, "radius", 1.0)), None, None
        if shape.tag == "mesh":
            uri = (_child(self, shape, "uri").text or "").strip()
            if shape.find("submesh") is not None:
                raise self.fail(shape, f"{what}: <submesh> is not read")
            mesh, uv = mesh_file(self.path, uri, what)
            scale_el = shape.find("scale")
            if scale_el is not None:
                mesh.apply_scale(self.numbers(scale_el, 3))
            return None, mesh, uv
        raise self.fail(shape, f"{what}: <{shape.tag}> geometry is not read (box, cylinder, sphere, mesh)")

    def material(self, visual: etree._Element, name: str) -> tuple[Material, bool]:
        el = visual.find("material")
        rgba = (1.0, 1.0, 1.0, 1.0)
        if el is None:
            return Material(name=name, rgba=rgba), False
        diffuse = el.find("diffuse")
        if diffuse is not None:
            rgba = tuple(self.numbers(diffuse, 4))
        albedo = el.find("pbr/metal/albedo_map")
        if albedo is None:
            return Material(name=name, rgba=rgba), False
        image = texture_file(self.path, (albedo.text or "").strip(), f"visual {visual.get('name')!r}")
        return Material(name=name, rgba=rgba, texture=image), True

    def link(self, el: etree._Element, prefix: str) -> Link:
        scoped = el.get("name") or ""
        link = Link(name=scoped.removeprefix(prefix))
        inertial = el.find("inertial")
        if inertial is not None:
            frame, _ = self.pose(inertial)
            tensor = np.eye(3)
            inertia = inertial.find("inertia")
            if inertia is not None:
                xx, xy, xz, yy, yz, zz = (self.number(inertia, k, 1.0 if k[1] == k[2] else 0.0)
                                          for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"))
                tensor = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
            rotation = frame[:3, :3]
            link.inertial = Inertial(mass_kg=self.number(inertial, "mass", 1.0), com_m=frame[:3, 3],
                                     inertia_kgm2=rotation @ tensor @ rotation.T)
        for visual in el.findall("visual"):
            name = part_name(visual.get("name") or "visual", prefix, link.name)
            shape, mesh, uv = self.geometry(visual, f"visual {visual.get('name')!r}")
            material, textured = self.material(visual, name)
            link.visuals.append(read_visual(name, shape, mesh, uv, material, textured, self.pose(visual)[0]))
        for col in el.findall("collision"):
            shape, mesh, _ = self.geometry(col, f"collision {col.get('name')!r}")
            name = part_name(col.get("name") or "collision", prefix, link.name, ("_collision", "_hull"))
            geometry = shape if shape is not None else MeshGeometry(mesh=mesh)
            link.collisions.append(Collision(name=name, geometry=geometry, link_from_collision=self.pose(col)[0]))
        return link

    def model_from_links(self, model_el: etree._Element, prefix: str) -> dict[str, np.ndarray]:
        """`model_from_link` of every link, following `relative_to` through other links."""
        poses = {el.get("name"): self.pose(el) for el in model_el.iterchildren("link")}
        done: dict[str, np.ndarray] = {}

        def resolve(name: str, seen: tuple[str, ...]) -> np.ndarray:
            if name in done:
                return done[name]
            frame_from_link, relative_to = poses[name]
            if relative_to in _MODEL_FRAME:
                done[name] = frame_from_link
            elif relative_to in poses and relative_to not in seen:
                done[name] = resolve(relative_to, (*seen, name)) @ frame_from_link
            else:
                raise InputError(f"{self.path}: link {name!r}: pose relative to {relative_to!r} is not read "
                                 "(the model or another link)")
            return done[name]

        return {name.removeprefix(prefix): resolve(name, ()) for name in poses}

    def joint(self, el: etree._Element, parts: ObjectParts, prefix: str, model_from_link: dict[str, np.ndarray]) -> None:
        scoped, kind = el.get("name") or "", el.get("type")
        parent = (_child(self, el, "parent").text or "").strip()
        scoped_child = child = (_child(self, el, "child").text or "").strip()
        if parent == "world":
            if kind != "fixed":
                raise self.fail(el, f"joint {scoped!r}: only a fixed joint holds a model to the world, not {kind!r}")
            parts.free = False
            return
        parent, child = parent.removeprefix(prefix), child.removeprefix(prefix)
        for end in (parent, child):
            if end not in model_from_link:
                raise self.fail(el, f"joint {scoped!r} refers to unknown link {end!r}")
        if kind not in JOINT_TYPES:  # SDFormat spells these as the model does
            raise self.fail(el, f"joint {scoped!r}: type {kind!r} is not read ({', '.join(JOINT_TYPES)})")
        child_from_joint, relative_to = self.pose(el)
        if relative_to not in ("", child):
            raise self.fail(el, f"joint {scoped!r}: pose relative to {relative_to!r} is not read (its child's frame)")
        # The model's joint frame is its child's frame: move the link onto the SDF joint frame.
        child_link = next(link for link in parts.links if link.name == child)
        reanchor(child_link, parts.joints, child_from_joint)
        parent_from_child = np.linalg.inv(model_from_link[parent]) @ model_from_link[child] @ child_from_joint
        name = scoped.removeprefix(prefix)
        states_el = el.find(f"{{{HOMEMODEL_NS}}}states")
        offset = 0.0 if states_el is None else _attribute_number(self, states_el, "offset")
        joint = Joint(name=name, type="fixed", parent=parent, child=child, parent_from_joint=parent_from_child)
        if kind != "fixed":
            axis_el = el.find("axis")
            axis = np.array([0.0, 0.0, 1.0]) if axis_el is None else self.numbers(_child(self, axis_el, "xyz"), 3)
            expressed_in = "" if axis_el is None else _child(self, axis_el, "xyz").get("expressed_in", "")
            if expressed_in == scoped_child:  # the link's own axes, not the joint frame's
                axis = child_from_joint[:3, :3].T @ axis
            elif expressed_in:
                raise self.fail(axis_el, f"joint {scoped!r}: axis expressed in {expressed_in!r} is not read")
            if np.linalg.norm(axis) < 1e-12:
                raise self.fail(el, f"joint {scoped!r}: axis has no direction")
            limit = None if axis_el is None else axis_el.find("limit")
            lower = -np.inf if limit is None else self.number(limit, "lower", -1e16)
            upper = np.inf if limit is None else self.number(limit, "upper", 1e16)
            unlimited = lower <= -_UNLIMITED and upper >= _UNLIMITED
            joint_type = "prismatic" if kind == "prismatic" else ("continuous" if unlimited or kind == "continuous" else "revolute")
            limits = None
            if limit is not None and not unlimited:
                limits = JointLimits(lower=lower + offset, upper=upper + offset,
                                     effort=self.number(limit, "effort", 10.0), velocity=self.number(limit, "velocity", 1.0))
            elif limit is not None and (limit.find("effort") is not None or limit.find("velocity") is not None):
                limits = JointLimits(effort=self.number(limit, "effort", 10.0), velocity=self.number(limit, "velocity", 1.0))
            dynamics_el = None if axis_el is None else axis_el.find("dynamics")
            dynamics = None if dynamics_el is None else JointDynamics(
                damping=self.number(dynamics_el, "damping", 0.0), friction=self.number(dynamics_el, "friction", 0.0))
            joint = Joint(name=name, type=joint_type, parent=parent, child=child, axis=axis / np.linalg.norm(axis),
                          limits=limits, dynamics=dynamics)
            joint.parent_from_joint = parent_from_child @ np.linalg.inv(joint.joint_from_child(offset))
            parts.joint_positions[name] = offset
            if states_el is not None:
                joint.states = [JointState(name=s.get("name") or "", position=_attribute_number(self, s, "position") + offset)
                                for s in states_el.findall(f"{{{HOMEMODEL_NS}}}state")]
        parts.joints.append(joint)

    def model(self, model_el: etree._Element) -> ObjectParts:
        if model_el.find("model") is not None or model_el.find("include") is not None:
            raise self.fail(model_el, f"model {model_el.get('name')!r}: nested models and <include> are not read")
        model_id = model_el.get("name") or f"model_line_{model_el.sourceline}"
        names = [el.get("name", "") for el in model_el.iter("link", "joint")]
        links = list(model_el.iterchildren("link"))
        if not links:
            raise self.fail(model_el, f"model {model_id!r} has no links")
        prefix = object_prefix(links[0].get("name") or "", names)
        static = (model_el.findtext("static") or "").strip() in ("true", "1")
        world_from_model, relative_to = self.pose(model_el)
        if relative_to not in ("", "world"):
            raise self.fail(model_el, f"model {model_id!r}: pose relative to {relative_to!r} is not read (the world)")
        parts = ObjectParts(id=model_id, free=not static, world_from_model=world_from_model)
        parts.links = [self.link(el, prefix) for el in links]
        model_from_link = self.model_from_links(model_el, prefix)
        joints = list(model_el.iterchildren("joint"))
        parent_of = {(j.findtext("child") or "").strip(): (j.findtext("parent") or "").strip() for j in joints}
        for el in sorted(joints, key=lambda j: -tree_depth((j.findtext("child") or "").strip(), parent_of, self.path)):
            self.joint(el, parts, prefix, model_from_link)
        roots = {link.name for link in parts.links} - {j.child for j in parts.joints}
        if len(roots) == 1:  # else the model's check names the problem
            parts.world_from_model = parts.world_from_model @ model_from_link[roots.pop()]
        return parts


def _child(reader: _Reader, parent: etree._Element, tag: str) -> etree._Element:
    el = parent.find(tag)
    if el is None:
        raise reader.fail(parent, f"<{parent.tag}> has no <{tag}>")
    return el


def _attribute_number(reader: _Reader, el: etree._Element, attribute: str) -> float:
    try:
        value = float(el.get(attribute, ""))
    except ValueError:
        raise reader.fail(el, f"<{el.tag} {attribute}={el.get(attribute)!r}> is not a number") from None
    if not np.isfinite(value):
        raise reader.fail(el, f"<{el.tag} {attribute}={el.get(attribute)!r}> is not finite")
    return value


def read_sdf(path: Path) -> Scene:
    """The scene of an SDFormat file: its models, floor and walls; InputError naming the file
    (and line) for a file that is not one, or uses what a model cannot hold."""
    path = Path(path)
    reader = _Reader(path)
    root = parse_xml_file(path).getroot()
    if root.tag != "sdf":
        raise InputError(f"{path}: root element is <{root.tag}>, expected <sdf>")
    version = root.get("version", "")
    try:
        major_minor = tuple(int(v) for v in version.split(".")[:2])
    except ValueError:
        major_minor = (0, 0)
    if major_minor < (1, 7):
        raise InputError(f"{path}: SDFormat version {version!r} is read from 1.7 on; convert it with `gz sdf -p`")
    worlds = root.findall("world")
    if len(worlds) > 1:
        raise InputError(f"{path}: holds {len(worlds)} worlds; expected one")
    container = worlds[0] if worlds else root
    include = next(container.iter("include"), None)
    if include is not None:
        raise reader.fail(include, "<include> is not read (it opens other files): merge them into one file")
    floor, walls, objects = False, [], []
    for model_el in container.findall("model"):
        shapes = model_el.findall("link/*/geometry/*")
        if (model_el.findtext("static") or "").strip() in ("true", "1") and shapes and all(g.tag == "plane" for g in shapes):
            floor = True  # a ground plane, as Gazebo's worlds have
            continue
        parts = reader.model(model_el)
        static_box = _static_box(parts)
        if static_box is not None and parts.id == "floor":
            floor = True
        elif static_box is not None and (wall := wall_from_box(parts.id, *static_box)) is not None:
            walls.append(wall)
        else:
            objects.append(parts.scene_object(path))
    if not objects:
        raise InputError(f"{path}: has no models")
    try:
        return Scene(name=worlds[0].get("name", path.stem) if worlds else path.stem, objects=objects, floor=floor, walls=walls)
    except ModelError as exc:
        raise InputError(f"{path}: {exc}") from None


def _static_box(parts: ObjectParts) -> tuple[np.ndarray, np.ndarray] | None:
    """(world_from_box, size) of a static model that is one box, as our floor and walls are."""
    if parts.free or len(parts.links) != 1 or parts.joints:
        return None
    shapes = [c.geometry for c in parts.links[0].collisions]
    if len(shapes) != 1 or not isinstance(shapes[0], Box):
        return None
    return parts.world_from_model @ parts.links[0].collisions[0].link_from_collision, np.asarray(shapes[0].size_m)

