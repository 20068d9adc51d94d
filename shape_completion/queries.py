"""Synthetic queries: the depth camera and the camera poses the filler trains on, and the
benchmark and the tests complete."""

from __future__ import annotations

import numpy as np
import trimesh

from homemodel.geometry.camera import Camera
from shape_completion.render import camera_from_object_on_sphere

# A VGA-like depth camera at half resolution.
FILLER_CAMERA = Camera(width=320, height=240, fx=285.0, fy=285.0, cx=159.5, cy=119.5)


def random_query_pose(mesh: trimesh.Trimesh, rng: np.random.Generator) -> np.ndarray:
    """A camera 0.35-0.7 m from the object on a random direction of the upper 3/4 of the sphere,
    the object a little off the optical axis: how a robot's head camera sees a table top."""
    direction = rng.normal(size=3)
    direction[2] = abs(direction[2]) if rng.uniform() < 0.75 else direction[2]
    direction /= np.linalg.norm(direction)
    centre = mesh.bounds.mean(axis=0)
    camera_from_object = camera_from_object_on_sphere(centre, direction, rng.uniform(0.35, 0.7))
    camera_from_object[:3, 3] += np.append(rng.uniform(-0.05, 0.05, size=2), 0.0)
    return camera_from_object
