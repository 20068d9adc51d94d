"""One builder per spec kind: each makes its objects in the Blender scene and returns the
`Assembly` (collisions, joints, grasp points, semantics) that completes them.

Helpers shared by the builders live here.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from articulation.model import Box, Collision
from homemodel.core.transforms import translation_transform

# The faces of an axis-aligned box by their outward normal, with names as seen from in
# front (the installer's left is -y).
FACE_NORMALS: dict[str, tuple[float, float, float]] = {
    "+x": (1, 0, 0),
    "-x": (-1, 0, 0),
    "+y": (0, 1, 0),
    "-y": (0, -1, 0),
    "+z": (0, 0, 1),
    "-z": (0, 0, -1),
}
FACE_NAMES = {"+x": "front", "-x": "back", "+y": "right", "-y": "left", "+z": "top", "-z": "bottom"}


def box_collision(name: str, size_m: Sequence[float], centre_m: Sequence[float]) -> Collision:
    size = tuple(float(s) for s in size_m)
    return Collision(name=name, geometry=Box(size_m=size), link_from_collision=translation_transform(centre_m))


def wall_collisions(
    name: str, size_m: Sequence[float], centre_m: Sequence[float], faces: Sequence[str], thickness_m: float
) -> list[Collision]:
    """One box per wall of an open box: a slab `thickness_m` thick inside each of its `faces`.

    Slabs overlap at the edges, which a collision shape may do, so open doors and drawers
    are never mistaken for touching a solid hull of the body.
    """
    shapes = []
    for face in faces:
        axis, sign = "xyz".index(face[1]), (1.0 if face[0] == "+" else -1.0)
        size, centre = np.array(size_m, dtype=np.float64), np.array(centre_m, dtype=np.float64)
        centre[axis] += sign * (size[axis] - thickness_m) / 2
        size[axis] = thickness_m
        shapes.append(box_collision(f"{name}_{FACE_NAMES[face]}", size, centre))
    return shapes


def grasp_frame(position_m: Sequence[float], approach: Sequence[float], along: Sequence[float]) -> np.ndarray:
    """`link_from_grasp`: x along the hand's approach, z along the bar it closes on."""
    x = np.asarray(approach, dtype=np.float64)
    z = np.asarray(along, dtype=np.float64)
    frame = np.eye(4)
    frame[:3, 0], frame[:3, 1], frame[:3, 2] = x, np.cross(z, x), z
    frame[:3, 3] = position_m
    return frame
