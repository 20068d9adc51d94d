"""A structured-light depth sensor's noise (Kinect-like), for simulated observations.

The axial model is Nguyen, Izadi and Lovell's measurement for the Kinect ("Modeling Kinect
sensor noise for improved 3D reconstruction and tracking", 3DIMPVT 2012):
sigma(z) = 0.0012 + 0.0019 (z - 0.4)^2 m. On top of it the sensor quantises depth to 1 mm,
returns nothing where the surface is seen at grazing incidence (beyond about 75 deg, where
the projected pattern smears out) and drops random pixels.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from homemodel.core.checks import require_between, require_choice, require_positive

NOISE_MODELS: tuple[str, ...] = ("kinect", "none")


def axial_sigma_m(depth_m: np.ndarray | float) -> np.ndarray:
    """The standard deviation (m) of a structured-light depth reading at `depth_m` (Nguyen 2012)."""
    z = np.asarray(depth_m, dtype=np.float64)
    return 0.0012 + 0.0019 * (z - 0.4) ** 2


@dataclass(kw_only=True)
class SensorNoise:
    """`kinect`: the model above; `none`: depth exactly as rendered."""

    model: Literal["kinect", "none"] = "kinect"
    quantum_m: float = 0.001
    max_incidence_deg: float = 75.0
    dropout_fraction: float = 0.01  # of the pixels that would read, dropped at random
    seed: int = 0

    def check(self) -> None:
        require_choice("model", self.model, NOISE_MODELS)
        require_positive("quantum_m", self.quantum_m)
        require_between("max_incidence_deg", self.max_incidence_deg, 0.0, 90.0)
        require_between("dropout_fraction", self.dropout_fraction, 0.0, 1.0)


def incidence_deg(normals_camera: np.ndarray, rays_camera: np.ndarray) -> np.ndarray:
    """The angle (deg) between each pixel's ray and the surface normal it meets: 0 head-on,
    90 grazing. `normals_camera` (H, W, 3) unit normals, `rays_camera` (H * W, 3) rays."""
    normals = np.asarray(normals_camera, dtype=np.float64).reshape(-1, 3)
    rays = np.asarray(rays_camera, dtype=np.float64)
    if rays.shape != normals.shape:
        raise ValueError(f"{rays.shape=} but expected {normals.shape}")
    cosine = np.abs(np.einsum("ij,ij->i", normals, rays)) / np.linalg.norm(rays, axis=1)
    return np.degrees(np.arccos(np.clip(cosine, 0.0, 1.0))).reshape(np.shape(normals_camera)[:-1])


def noisy_depth(
    depth_m: np.ndarray, normals_camera: np.ndarray, rays_camera: np.ndarray, noise: SensorNoise
) -> np.ndarray:
    """What the sensor reads of an exact `depth_m` image (0 = no surface): 0 where it reads nothing."""
    noise.check()
    depth = np.asarray(depth_m, dtype=np.float64)
    if noise.model == "none":
        return depth.copy()
    rng = np.random.default_rng(noise.seed)
    seen = depth > 0
    reading = np.where(seen, depth + rng.normal(size=depth.shape) * axial_sigma_m(depth), 0.0)
    reading = np.round(reading / noise.quantum_m) * noise.quantum_m
    seen &= incidence_deg(normals_camera, rays_camera) <= noise.max_incidence_deg
    seen &= rng.random(depth.shape) >= noise.dropout_fraction
    seen &= reading > 0
    return np.where(seen, reading, 0.0)
