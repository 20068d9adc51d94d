"""The articulated model: the one type every homemodel pipeline ends in.

A model is a tree of links joined by joints, with one root. Link frames follow URDF:
`parent_from_joint` places the joint frame in the parent link at joint position zero, the
child link frame coincides with the joint frame, and the joint moves the child about (or
along) `axis`, expressed in the joint frame. A rigid small object is a model with one link.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import numpy as np

from homemodel.core.errors import ModelError
from homemodel.core.transforms import (
    as_transform,
    axis_angle_transform,
    translation_transform,
)
from articulation.joint_types import JOINT_TYPES, MOVABLE_JOINT_TYPES, ROTATING_JOINT_TYPES, JointType

if TYPE_CHECKING:  # trimesh (with scipy, networkx, shapely) is imported by what makes meshes
    import trimesh


@dataclass(kw_only=True)
class Material:
    """A surface look: a base colour and, optionally, a texture image (PNG or JPEG)."""

    name: str
    rgba: tuple[float, float, float, float] = (0.8, 0.8, 0.8, 1.0)
    texture: Path | None = None


@dataclass(kw_only=True)
class Visual:
    """A triangle mesh in its own frame, placed in the link by `link_from_visual`.

    `uv` holds one texture coordinate per vertex (OpenGL convention, v up) when the
    material has a texture.
    """

    name: str
    mesh: trimesh.Trimesh
    material: Material
    link_from_visual: np.ndarray = field(default_factory=lambda: np.eye(4))
    uv: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.link_from_visual = as_transform(self.link_from_visual)
        if len(self.mesh.faces) == 0:
            raise ModelError(f"visual {self.name!r}: mesh has no triangles")
        if self.uv is not None:
            self.uv = np.asarray(self.uv, dtype=np.float64)
            if self.uv.shape != (len(self.mesh.vertices), 2):
                raise ValueError(f"{self.uv.shape=} but expected ({len(self.mesh.vertices)}, 2)")


@dataclass(kw_only=True)
class Box:
    size_m: tuple[float, float, float]


@dataclass(kw_only=True)
class Cylinder:
    """A cylinder along its frame's z axis, centred on the origin (URDF convention)."""

    radius_m: float
    length_m: float


@dataclass(kw_only=True)
class Sphere:
    radius_m: float


@dataclass(kw_only=True)
class MeshGeometry:
    """A collision mesh; exporters write its convex hull."""

    mesh: trimesh.Trimesh


Geometry = Box | Cylinder | Sphere | MeshGeometry


@dataclass(kw_only=True)
class Collision:
    name: str
    geometry: Geometry
    link_from_collision: np.ndarray = field(default_factory=lambda: np.eye(4))

    def __post_init__(self) -> None:
        self.link_from_collision = as_transform(self.link_from_collision)


@dataclass(kw_only=True)
class Inertial:
    """Mass, centre of mass in the link frame, and the inertia tensor about the centre of mass."""

    mass_kg: float
    com_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia_kgm2: np.ndarray = field(default_factory=lambda: np.eye(3) * 1e-6)

    def __post_init__(self) -> None:
        self.com_m = np.asarray(self.com_m, dtype=np.float64).reshape(3)
        self.inertia_kgm2 = np.asarray(self.inertia_kgm2, dtype=np.float64)
        if self.inertia_kgm2.shape != (3, 3):
            raise ValueError(f"{self.inertia_kgm2.shape=} but expected (3, 3)")


@dataclass(kw_only=True)
class Link:
    name: str
    visuals: list[Visual] = field(default_factory=list)
    collisions: list[Collision] = field(default_factory=list)
    inertial: Inertial | None = None


@dataclass(kw_only=True)
class JointLimits:
    lower: float = 0.0
    upper: float = 0.0
    effort: float = 10.0
    velocity: float = 1.0


@dataclass(kw_only=True)
class JointDynamics:
    """Viscous damping (N·m·s/rad or N·s/m) and Coulomb friction (N·m or N), as URDF's `<dynamics>`."""

    damping: float = 0.0
    friction: float = 0.0


@dataclass(kw_only=True)
class JointState:
    """A named discrete position of a joint, e.g. an oven knob's "3" at 1.2 rad."""

    name: str
    position: float


@dataclass(kw_only=True)
class Joint:
    name: str
    type: JointType
    parent: str
    child: str
    parent_from_joint: np.ndarray = field(default_factory=lambda: np.eye(4))
    axis: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    limits: JointLimits | None = None
    dynamics: JointDynamics | None = None
    states: list[JointState] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.parent_from_joint = as_transform(self.parent_from_joint)
        self.axis = np.asarray(self.axis, dtype=np.float64).reshape(3)
        if self.type not in JOINT_TYPES:
            raise ModelError(f"joint {self.name!r}: unknown type {self.type!r}")
        norm = float(np.linalg.norm(self.axis))
        if self.is_movable and not (np.isfinite(norm) and norm > 1e-9):
            raise ModelError(f"joint {self.name!r}: axis {self.axis.tolist()} has no direction")

    @property
    def is_movable(self) -> bool:
        return self.type in MOVABLE_JOINT_TYPES

    def joint_from_child(self, position: float) -> np.ndarray:
        """The child's motion at `position` (radians or metres) in the joint frame."""
        if self.type in ROTATING_JOINT_TYPES:
            return axis_angle_transform(self.axis, position)
        if self.type == "prismatic":
            return translation_transform(self.axis / np.linalg.norm(self.axis) * position)
        return np.eye(4)


GraspKind = Literal["handle", "knob", "body", "rim", "push", "button"]


@dataclass(kw_only=True)
class GraspPoint:
    """Where a hand grasps: a frame in a link (x along the approach, z along the bar)."""

    name: str
    link: str
    link_from_grasp: np.ndarray
    kind: GraspKind = "handle"

    def __post_init__(self) -> None:
        self.link_from_grasp = as_transform(self.link_from_grasp)


@dataclass(kw_only=True)
class Model:
    """An articulated model with semantic annotations the map takes over on registration."""

    name: str
    links: list[Link]
    joints: list[Joint] = field(default_factory=list)
    grasp_points: list[GraspPoint] = field(default_factory=list)
    category: str = "object"
    affordances: list[str] = field(default_factory=list)
    properties: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.check_tree()

    def link(self, name: str) -> Link:
        for link in self.links:
            if link.name == name:
                return link
        raise ModelError(f"model {self.name!r}: no link named {name!r}")

    def joint(self, name: str) -> Joint:
        for joint in self.joints:
            if joint.name == name:
                return joint
        raise ModelError(f"model {self.name!r}: no joint named {name!r}")

    @property
    def movable_joints(self) -> list[Joint]:
        return [j for j in self.joints if j.is_movable]

    @property
    def root_link(self) -> str:
        children = {j.child for j in self.joints}
        return next(link.name for link in self.links if link.name not in children)

    def check_tree(self) -> None:
        """One root, unique names, every joint between known links, no cycles."""
        if not self.links:
            raise ModelError(f"model {self.name!r}: has no links")
        names = [link.name for link in self.links]
        for kind, seen in (("link", names), ("joint", [j.name for j in self.joints])):
            dupes = sorted({n for n in seen if seen.count(n) > 1})
            if dupes:
                raise ModelError(f"model {self.name!r}: duplicate {kind} names {dupes}")
        known = set(names)
        children: set[str] = set()
        for j in self.joints:
            for end in (j.parent, j.child):
                if end not in known:
                    raise ModelError(f"model {self.name!r}: joint {j.name!r} refers to unknown link {end!r}")
            if j.child in children:
                raise ModelError(f"model {self.name!r}: link {j.child!r} is the child of two joints")
            children.add(j.child)
        roots = [n for n in names if n not in children]
        if len(roots) != 1:
            raise ModelError(f"model {self.name!r}: expected one root link, found {roots or 'none (a cycle)'}")
        for g in self.grasp_points:
            if g.link not in known:
                raise ModelError(f"model {self.name!r}: grasp point {g.name!r} is on unknown link {g.link!r}")
        reached = set(self.world_from_links())
        if reached != known:
            raise ModelError(f"model {self.name!r}: links {sorted(known - reached)} are not reachable from the root")

    def world_from_links(self, joint_positions: dict[str, float] | None = None) -> dict[str, np.ndarray]:
        """`world_from_link` of every link, the model's root frame being the world.

        Joints missing from `joint_positions` sit at zero.
        """
        positions = joint_positions or {}
        unknown = set(positions) - {j.name for j in self.joints}
        if unknown:
            raise ModelError(f"model {self.name!r}: no joints named {sorted(unknown)}")
        by_parent: dict[str, list[Joint]] = {}
        for j in self.joints:
            by_parent.setdefault(j.parent, []).append(j)
        root = self.root_link
        result = {root: np.eye(4)}
        stack = [root]
        while stack:
            parent = stack.pop()
            for j in by_parent.get(parent, []):
                if j.child in result:
                    continue
                world_from_joint = result[parent] @ j.parent_from_joint
                result[j.child] = world_from_joint @ j.joint_from_child(positions.get(j.name, 0.0))
                stack.append(j.child)
        return result

    def world_from_grasp_points(self, joint_positions: dict[str, float] | None = None) -> dict[str, np.ndarray]:
        links = self.world_from_links(joint_positions)
        return {g.name: links[g.link] @ g.link_from_grasp for g in self.grasp_points}

    def joint_driving(self, link_name: str) -> Joint | None:
        """The nearest movable joint on the path from `link_name` to the root, if any."""
        parent_joint = {j.child: j for j in self.joints}
        name = link_name
        while name in parent_joint:
            joint = parent_joint[name]
            if joint.is_movable:
                return joint
            name = joint.parent
        return None

    def world_mesh(self, joint_positions: dict[str, float] | None = None) -> trimesh.Trimesh:
        """All visuals as one mesh in the model frame (for bounds, pictures and checks)."""
        import trimesh

        links = self.world_from_links(joint_positions)
        parts = []
        for link in self.links:
            for v in link.visuals:
                mesh = v.mesh.copy()
                mesh.apply_transform(links[link.name] @ v.link_from_visual)
                parts.append(mesh)
        if not parts:
            raise ModelError(f"model {self.name!r}: has no visual meshes")
        return trimesh.util.concatenate(parts)
