"""A scene for a simulator: models placed in one world frame, each joint at a position.

One exported model is a scene of one fixed object at the origin; a home is a scene of every
object of its map, with a floor and, where a room gives its outline, walls. The MJCF, SDF,
USD, URDF and glTF scene writers all read this one type, so they agree on names, poses and
joint positions.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from articulation.joint_loads import UPRIGHT_GRAVITY_M_S2
from articulation.model import Model
from homemodel.core.errors import ModelError
from homemodel.core.transforms import as_transform

WALL_HEIGHT_M = 2.5
WALL_THICKNESS_M = 0.1
_NAME_UNSAFE = re.compile(r"[^A-Za-z0-9_]+")


@dataclass(kw_only=True)
class SceneObject:
    """A model at `world_from_model`, its joints at `joint_positions` (missing ones at zero).

    A `free` object (a cup, a jar) is a rigid body the simulator lets fall and slide; the
    others (furniture, appliances) are fixed to the world.
    """

    id: str
    model: Model
    world_from_model: np.ndarray = field(default_factory=lambda: np.eye(4))
    joint_positions: dict[str, float] = field(default_factory=dict)
    free: bool = False

    def __post_init__(self) -> None:
        self.world_from_model = as_transform(self.world_from_model)
        known = {j.name for j in self.model.movable_joints}
        unknown = sorted(set(self.joint_positions) - known)
        if unknown:
            raise ModelError(f"object {self.id!r}: model {self.model.name!r} has no movable joints {unknown}")

    def name(self, part: str) -> str:
        """`part` (a link, joint, mesh or material name) made unique in the scene by the object id.

        Letters, digits and underscores only: the one spelling USD prim names, ROS frames,
        MJCF and SDF names all accept.
        """
        return _NAME_UNSAFE.sub("_", f"{self.id}__{part}")

    @property
    def gravity_model(self) -> np.ndarray:
        """Gravity (m/s²) in the model's frame: -z for an upright object."""
        return self.world_from_model[:3, :3].T @ UPRIGHT_GRAVITY_M_S2

    @property
    def safe_id(self) -> str:
        """The object id in the spelling of `name`."""
        return _NAME_UNSAFE.sub("_", self.id)

    def position(self, joint_name: str) -> float:
        return float(self.joint_positions.get(joint_name, 0.0))


@dataclass(kw_only=True)
class Wall:
    """A straight wall on the floor from `start_xy` to `end_xy` (map frame, metres)."""

    name: str
    start_xy: tuple[float, float]
    end_xy: tuple[float, float]
    height_m: float = WALL_HEIGHT_M
    thickness_m: float = WALL_THICKNESS_M

    @property
    def length_m(self) -> float:
        return float(np.hypot(self.end_xy[0] - self.start_xy[0], self.end_xy[1] - self.start_xy[1]))

    def world_from_wall(self) -> np.ndarray:
        """The centre of the wall's box, its x axis along the wall."""
        (x0, y0), (x1, y1) = self.start_xy, self.end_xy
        yaw = float(np.arctan2(y1 - y0, x1 - x0))
        c, s = np.cos(yaw), np.sin(yaw)
        m = np.eye(4)
        m[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
        m[:3, 3] = [(x0 + x1) / 2, (y0 + y1) / 2, self.height_m / 2]
        return m

    @property
    def size_m(self) -> tuple[float, float, float]:
        return (self.length_m, self.thickness_m, self.height_m)


def _edges(outline_xy: list[tuple[float, float]]):
    """(start, end, outward unit normal) of each edge of a closed polygon."""
    corners = np.asarray(outline_xy, dtype=np.float64)
    x, y = corners[:, 0], corners[:, 1]
    counter_clockwise = float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y)) > 0
    for a, b in zip(corners, np.roll(corners, -1, axis=0)):
        length = float(np.linalg.norm(b - a))
        if length < 1e-9:
            continue
        along = (b - a) / length
        yield a, b, (np.array([along[1], -along[0]]) if counter_clockwise else np.array([-along[1], along[0]]))


def walls_from_outlines(outlines: list[tuple[str, list[tuple[float, float]]]]) -> list[Wall]:
    """Walls on the edges of rooms' floor plans, (room id, closed polygon) each.

    A wall stands outside its room, so the room keeps its full floor, and runs on by its
    thickness at both ends so corners close. An edge two rooms share (the same segment, in
    opposite directions) gets one wall, centred on it, named after both rooms.
    """
    edges = [(room, a, b, n) for room, outline in outlines for a, b, n in _edges(outline)]
    key = lambda a, b: (tuple(np.round(a, 6)), tuple(np.round(b, 6)))  # noqa: E731
    owners: dict[tuple, str] = {}
    for room, a, b, _ in edges:
        owners.setdefault(key(a, b), room)
    walls: list[Wall] = []
    counts: dict[str, int] = {}
    for room, a, b, outward in edges:
        other = owners.get(key(b, a))
        if other is not None and other != room and owners[key(a, b)] == room and room > other:
            continue  # the other room writes this shared wall
        shared = other is not None and other != room
        name = f"{min(room, other)}__{max(room, other)}" if shared else room
        along = (b - a) / np.linalg.norm(b - a)
        shift = np.zeros(2) if shared else outward * WALL_THICKNESS_M / 2
        start, end = a + shift - along * WALL_THICKNESS_M, b + shift + along * WALL_THICKNESS_M
        index = counts.get(name, 0)
        counts[name] = index + 1
        walls.append(Wall(name=f"{name}__wall_{index}", start_xy=tuple(start), end_xy=tuple(end)))
    return walls


@dataclass(kw_only=True)
class Scene:
    """Objects, an optional floor (the plane z = 0) and walls."""

    name: str
    objects: list[SceneObject]
    floor: bool = False
    walls: list[Wall] = field(default_factory=list)

    def __post_init__(self) -> None:
        if not self.objects:
            raise ModelError(f"scene {self.name!r} has no objects")
        ids = [o.id for o in self.objects]
        dupes = sorted({i for i in ids if ids.count(i) > 1})
        if dupes:
            raise ModelError(f"scene {self.name!r}: object ids repeat: {dupes}")


def single_model_scene(model: Model, *, free: bool = False) -> Scene:
    """One model at the origin with its joints at zero, named after the model: fixed, or
    `free` (a body that can be picked up) standing on a floor."""
    return Scene(name=model.name, objects=[SceneObject(id=model.name, model=model, free=free)], floor=free)
