"""What the MJCF, SDF and USD readers share (`simulator_read` is their one entry).

Our writers prefix every name in a scene with its object's id (`SceneObject.name`); a reader
strips that prefix again. A joint whose axis does not pass through its child's frame (MJCF's
joint `pos`, SDF's joint `<pose>`, USD's `localPos1`) is read by moving the child link's frame
onto the joint (`reanchor`), since the model's joint frame is its child's frame.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh

from articulation.model import Joint, Link, Material, Model, Visual
from articulation.scene import SceneObject, Wall
from homemodel.core.errors import InputError, ModelError
from homemodel.core.input_files import confined_path
from homemodel.core.limits import URDF_JOINTS, URDF_LINKS
from homemodel.exchange.urdf.read import primitive_mesh
from homemodel.exchange.urdf.read import read_mesh_parts

# `walls_from_outlines` names a wall `<room>__wall_<n>`.
_WALL_NAME = re.compile(r"_wall_\d+$")
_UPRIGHT_TOLERANCE = 1e-6


@dataclass(kw_only=True)
class ObjectParts:
    """One object's links and joints as a reader finds them, before they become a model."""

    id: str
    links: list[Link] = field(default_factory=list)
    joints: list[Joint] = field(default_factory=list)
    world_from_model: np.ndarray = field(default_factory=lambda: np.eye(4))
    joint_positions: dict[str, float] = field(default_factory=dict)
    free: bool = False

    def scene_object(self, path: Path) -> SceneObject:
        URDF_LINKS.check(path, len(self.links))
        URDF_JOINTS.check(path, len(self.joints))
        try:
            model = Model(name=self.id, links=self.links, joints=self.joints)
            return SceneObject(
                id=self.id, model=model, world_from_model=self.world_from_model,
                joint_positions=self.joint_positions, free=self.free,
            )
        except ModelError as exc:
            raise InputError(f"{path}: {exc}") from None


def object_prefix(root_name: str, names: list[str]) -> str:
    """The `<id>__` our writers put before every name of an object, when all of `names` carry
    the root's; "" for a file whose names do not (one written by someone else)."""
    head, sep, _ = root_name.partition("__")
    prefix = head + sep
    if sep and all(name.startswith(prefix) for name in names):
        return prefix
    return ""


def part_name(scoped: str, prefix: str, link: str, suffixes: tuple[str, ...] = ()) -> str:
    """A visual's or collision's own name from the writers' `<id>__<link>_<name>[_suffix]`."""
    name = scoped.removeprefix(prefix)
    if name.startswith(f"{link}_") and len(name) > len(link) + 1:
        name = name[len(link) + 1 :]
    for suffix in suffixes:
        if name.endswith(suffix) and len(name) > len(suffix):
            return name[: -len(suffix)]
    return name


def reanchor(link: Link, joints: list[Joint], link_old_from_new: np.ndarray) -> None:
    """Move `link`'s frame by `link_old_from_new`: what hangs in the link (visuals, collisions,
    inertial, child joints of `joints`) keeps its place."""
    if np.allclose(link_old_from_new, np.eye(4)):
        return
    new_from_old = np.linalg.inv(link_old_from_new)
    for visual in link.visuals:
        visual.link_from_visual = new_from_old @ visual.link_from_visual
    for collision in link.collisions:
        collision.link_from_collision = new_from_old @ collision.link_from_collision
    if link.inertial is not None:
        rotation = new_from_old[:3, :3]
        link.inertial.com_m = rotation @ link.inertial.com_m + new_from_old[:3, 3]
        link.inertial.inertia_kgm2 = rotation @ link.inertial.inertia_kgm2 @ rotation.T
    for joint in joints:
        if joint.parent == link.name:
            joint.parent_from_joint = new_from_old @ joint.parent_from_joint


def mesh_file(path: Path, name: str, what: str) -> tuple[trimesh.Trimesh, np.ndarray | None]:
    """The mesh file `name` (relative to the scene file's folder and inside it) as one mesh,
    and its per-vertex texture coordinates when the file has one part that carries them."""
    try:
        mesh_path = confined_path(path.parent, name, folder_role="scene's folder")
        parts = read_mesh_parts(mesh_path)
    except InputError as exc:
        raise InputError(f"{path}: {what}: {exc}") from None
    uv = getattr(parts[0][1].visual, "uv", None) if len(parts) == 1 else None
    meshes = [trimesh.Trimesh(vertices=m.vertices, faces=m.faces, process=False) for _, m in parts]
    mesh = meshes[0] if len(meshes) == 1 else trimesh.util.concatenate(meshes)
    if uv is not None and len(uv) != len(mesh.vertices):
        uv = None
    return mesh, None if uv is None else np.asarray(uv, dtype=np.float64)


def texture_file(path: Path, name: str, what: str) -> Path:
    try:
        image = confined_path(path.parent, name, folder_role="scene's folder")
    except InputError as exc:
        raise InputError(f"{path}: {what}: {exc}") from None
    if not image.is_file():
        raise InputError(f"{path}: {what}: texture {name!r} does not exist")
    return image


def wall_from_box(name: str, world_from_box: np.ndarray, size_m: np.ndarray) -> Wall | None:
    """The wall `Wall.world_from_wall` and `size_m` describe, if the box is one of ours: named
    `..._wall_<n>`, upright, standing on the floor."""
    rotation = world_from_box[:3, :3]
    height = float(size_m[2])
    upright = abs(rotation[2, 2] - 1.0) < _UPRIGHT_TOLERANCE
    if not (_WALL_NAME.search(name) and upright and abs(world_from_box[2, 3] - height / 2) < 1e-6):
        return None
    along = rotation[:2, 0] / np.linalg.norm(rotation[:2, 0])
    centre = world_from_box[:2, 3]
    half = along * float(size_m[0]) / 2
    return Wall(
        name=name, start_xy=tuple(map(float, centre - half)), end_xy=tuple(map(float, centre + half)),
        height_m=height, thickness_m=float(size_m[1]),
    )


def joint_motion_position(joint_type: str, axis: np.ndarray, motion: np.ndarray) -> float:
    """The joint position (rad or m) of `motion`, a rotation about (or translation along) the
    unit `axis`."""
    if joint_type == "prismatic":
        return float(motion[:3, 3] @ axis)
    rotation = motion[:3, :3]
    sine = 0.5 * np.array([rotation[2, 1] - rotation[1, 2], rotation[0, 2] - rotation[2, 0], rotation[1, 0] - rotation[0, 1]])
    return float(np.arctan2(sine @ axis, (np.trace(rotation) - 1.0) / 2))


def read_visual(name: str, shape, mesh: trimesh.Trimesh | None, uv: np.ndarray | None, material: Material,
                textured: bool, link_from_visual: np.ndarray) -> Visual:
    """A visual read from a file: a primitive `shape`'s mesh where no `mesh` is given, its
    texture kept only with coordinates for it; an empty mesh is the file's fault (InputError)."""
    kept_uv = uv if textured else None
    if kept_uv is None:
        material.texture = None
    try:
        return Visual(name=name, mesh=mesh if mesh is not None else primitive_mesh(shape), material=material,
                      link_from_visual=link_from_visual, uv=kept_uv)
    except (ModelError, ValueError) as exc:
        raise InputError(str(exc)) from None


def tree_depth(link: str, parent_of: dict[str, str], source: Path) -> int:
    """How many joints lie between `link` and its tree's root (`parent_of`: child to parent).
    A reader places the deepest joints first, so a link moved onto its joint (`reanchor`) takes
    its child joints along."""
    depth = 0
    while link in parent_of:
        link, depth = parent_of[link], depth + 1
        if depth > len(parent_of):
            raise InputError(f"{source}: the joints form a cycle")
    return depth
