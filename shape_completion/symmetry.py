"""Reflective symmetry planes of a mesh, found by testing candidate planes through its centroid.

Candidates are the principal axes' planes and planes with normals on a Fibonacci lattice; a
plane is kept when the mirrored surface samples lie within a small fraction of the object's
size of the surface. Revolved objects have many such planes; the best distinct ones are kept.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from homemodel.evaluation.surface import distances_to_surface
from shape_completion.render import sphere_directions


@dataclass(kw_only=True, frozen=True)
class Plane:
    """The plane {x : normal . x = offset}, normal of unit length."""

    normal: np.ndarray
    offset: float

    def reflect(self, points: np.ndarray) -> np.ndarray:
        distance = points @ self.normal - self.offset
        return points - 2.0 * distance[:, None] * self.normal

    def reflect_vectors(self, vectors: np.ndarray) -> np.ndarray:
        return vectors - 2.0 * (vectors @ self.normal)[:, None] * self.normal

    def transformed(self, b_from_a: np.ndarray) -> Plane:
        """This plane (given in frame a) in frame b."""
        normal = b_from_a[:3, :3] @ self.normal
        point = b_from_a[:3, :3] @ (self.normal * self.offset) + b_from_a[:3, 3]
        return Plane(normal=normal, offset=float(normal @ point))


def symmetry_planes(
    mesh: trimesh.Trimesh,
    *,
    max_planes: int = 3,
    tolerance: float = 0.01,
    min_angle_deg: float = 25.0,
    n_samples: int = 1500,
    seed: int = 0,
) -> list[Plane]:
    """Up to `max_planes` symmetry planes, best first; a plane's mean mirror error must be under
    `tolerance` times the bounding diagonal, and kept normals differ by at least `min_angle_deg`."""
    points, _ = trimesh.sample.sample_surface(mesh, n_samples, seed=seed)
    centroid = points.mean(axis=0)
    diagonal = float(np.linalg.norm(mesh.extents))
    _, axes = np.linalg.eigh(np.cov((points - centroid).T))
    lattice = sphere_directions(60)
    normals = np.concatenate([axes.T, lattice[lattice[:, 2] >= 0]])  # a normal and its opposite are one plane
    planes = [Plane(normal=normal, offset=float(normal @ centroid)) for normal in normals]
    # Exact distances to the surface (not to other samples), so sampling noise does not hide a symmetry.
    mirrored = np.concatenate([plane.reflect(points) for plane in planes])
    errors = distances_to_surface(mirrored, mesh).reshape(len(planes), -1).mean(axis=1) / diagonal
    scored = [(float(error), plane) for error, plane in zip(errors, planes) if error < tolerance]
    kept: list[Plane] = []
    cos_limit = np.cos(np.radians(min_angle_deg))
    for _, plane in sorted(scored, key=lambda item: item[0]):
        if all(abs(plane.normal @ other.normal) < cos_limit for other in kept):
            kept.append(plane)
        if len(kept) == max_planes:
            break
    return kept
