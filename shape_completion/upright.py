"""The completed shape's frame: homemodel's object frame (+z up, origin on the support under the
object) when something says where up is, else the query camera's.

Up comes from the camera's pose in the map (`map_from_camera` in camera.yaml) when given: the
object frame's axes are then the map's, so `map_from_object` is a translation. Else it comes
from the support plane seen around the object (`shape_completion.support`): x is the camera's
x (right in the image) laid flat, y points away from the camera. The origin is on the support
under the object: below its revolution axis when the match is revolved and the axis stands
upright, else below the middle of its box; at the plane's height when one is seen, else at
the completed mesh's lowest point.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from shape_completion.support import SupportPlane
from shape_completion.symmetry import RevolutionAxis

CAMERA_FRAME = "query camera, OpenCV (x right, y down, z forward), metres"
UPRIGHT_AXIS_COSINE = np.cos(np.radians(15))  # a revolution axis this close to up gives the origin
PLANE_AGREES_COSINE = np.cos(np.radians(10))  # a seen plane this close to the pose's up gives the height


@dataclass(kw_only=True)
class ObjectFrame:
    """Where the output mesh's frame is: `camera_from_object` (identity when it is the camera's)."""

    camera_from_object: np.ndarray
    up_from: str | None  # "camera pose", "support plane", or None: no up known
    description: str
    map_from_object: np.ndarray | None = None


def _rotation_with_up(up: np.ndarray, x_hint: np.ndarray) -> np.ndarray:
    """Columns x, y, z (in the camera frame) of a right-handed frame with z = `up`, x nearest `x_hint`."""
    z = up / np.linalg.norm(up)
    x = x_hint - (x_hint @ z) * z
    if np.linalg.norm(x) < 1e-6:  # the hint stands along up: the camera's optical axis laid flat
        x = np.array([0.0, 0.0, 1.0]) - z[2] * z
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def _origin(
    mesh: trimesh.Trimesh, rotation: np.ndarray, axis: RevolutionAxis | None, support: SupportPlane | None
) -> np.ndarray:
    """The point on the support under the object, in the camera frame."""
    up = rotation[:, 2]
    local = np.asarray(mesh.vertices) @ rotation  # vertices in the frame's axes, origin at the camera
    centre = 0.5 * (local.min(axis=0) + local.max(axis=0))
    if axis is not None and abs(axis.direction @ up) >= UPRIGHT_AXIS_COSINE:
        through = axis.point @ rotation
        direction = axis.direction @ rotation
        centre[:2] = (through + (centre[2] - through[2]) / direction[2] * direction)[:2]
    if support is not None:
        # The plane's height at the object: support.height_m(p) = 0 with p = rotation @ local.
        base = -(support.offset_m + (rotation[:, :2] @ centre[:2]) @ support.normal) / (up @ support.normal)
    else:
        base = local[:, 2].min()
    return rotation @ np.array([centre[0], centre[1], base])


def object_frame(
    mesh: trimesh.Trimesh,
    *,
    map_from_camera: np.ndarray | None,
    support: SupportPlane | None,
    axis: RevolutionAxis | None,
) -> ObjectFrame:
    """The frame the completed `mesh` (camera frame) is written in, and how up was found."""
    if map_from_camera is not None:
        camera_from_map = np.linalg.inv(map_from_camera)
        rotation = camera_from_map[:3, :3]  # columns: the map's axes in the camera frame
        agrees = support is not None and abs(support.normal @ rotation[:, 2]) >= PLANE_AGREES_COSINE
        camera_from_object = np.eye(4)
        camera_from_object[:3, :3] = rotation
        camera_from_object[:3, 3] = _origin(mesh, rotation, axis, support if agrees else None)
        on = "the support plane seen under it" if agrees else "its lowest point"
        return ObjectFrame(
            camera_from_object=camera_from_object,
            up_from="camera pose",
            description=f"object: +z up from the camera pose (the map's axes), origin at {on}, metres",
            map_from_object=map_from_camera @ camera_from_object,
        )
    if support is not None:
        rotation = _rotation_with_up(support.normal, np.array([1.0, 0.0, 0.0]))
        camera_from_object = np.eye(4)
        camera_from_object[:3, :3] = rotation
        camera_from_object[:3, 3] = _origin(mesh, rotation, axis, support)
        return ObjectFrame(
            camera_from_object=camera_from_object,
            up_from="support plane",
            description="object: +z up from the support plane seen in the depth image, origin on it under the"
            " object, x along the camera's x laid flat, y away from the camera, metres",
        )
    return ObjectFrame(
        camera_from_object=np.eye(4),
        up_from=None,
        description=f"{CAMERA_FRAME}: no camera pose (map_from_camera) and no support plane seen, so up is unknown",
    )
