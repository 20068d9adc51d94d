"""Where the completion's cameras stand around an object: viewpoints spread over a sphere, and
the camera at one of them looking at the object. Depth images are ray cast from there with
`homemodel.geometry.raycast.RayCaster` (cameras follow OpenCV: x right, y down, z forward).
"""

from __future__ import annotations

import numpy as np

from homemodel.core.transforms import world_from_camera_looking_along


def sphere_directions(count: int) -> np.ndarray:
    """`count` unit vectors spread evenly over the sphere (a Fibonacci lattice), deterministic."""
    if count < 1:
        raise ValueError(f"{count=} but expected at least 1")
    i = np.arange(count) + 0.5
    z = 1.0 - 2.0 * i / count
    azimuth = np.pi * (1.0 + 5.0**0.5) * i
    r = np.sqrt(1.0 - z**2)
    return np.stack([r * np.cos(azimuth), r * np.sin(azimuth), z], axis=1)


def camera_from_object_on_sphere(target_m: np.ndarray, direction: np.ndarray, distance_m: float) -> np.ndarray:
    """The camera at `target + distance * direction` (direction made unit) looking at `target`,
    image up along the object's +z where possible."""
    direction = np.asarray(direction, dtype=np.float64)
    eye = np.asarray(target_m, dtype=np.float64) + distance_m * (direction / np.linalg.norm(direction))
    return np.linalg.inv(world_from_camera_looking_along(eye, -direction))
