"""Reflective symmetry planes of a mesh, found by testing candidate planes through its centroid.

Candidates are the principal axes' planes and planes with normals on a Fibonacci lattice; a
plane is kept when the mirrored surface samples lie within a small fraction of the object's
size of the surface. Revolved objects have many such planes; the best distinct ones are kept.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh
from scipy.optimize import least_squares

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


@dataclass(kw_only=True, frozen=True)
class RevolutionAxis:
    """The line {point + t * direction} a shape is (nearly) a surface of revolution about."""

    point: np.ndarray
    direction: np.ndarray  # unit length

    def transformed(self, b_from_a: np.ndarray) -> RevolutionAxis:
        return RevolutionAxis(
            point=b_from_a[:3, :3] @ self.point + b_from_a[:3, 3], direction=b_from_a[:3, :3] @ self.direction
        )

    def offset_to(self, points: np.ndarray) -> np.ndarray:
        """The component of each point's offset from the axis perpendicular to it."""
        relative = points - self.point
        return relative - np.outer(relative @ self.direction, self.direction)

    def turned_toward(self, points: np.ndarray, direction: np.ndarray) -> np.ndarray:
        """`points` turned about the axis into the half-plane leaving it along `direction` (a unit
        vector perpendicular to the axis)."""
        offset = self.offset_to(points)
        return points - offset + np.outer(np.linalg.norm(offset, axis=1), direction)

    def fitted_to(self, points: np.ndarray, normals: np.ndarray, *, tolerance_m: float) -> RevolutionAxis:
        """This axis moved onto a cloud seen of a surface of revolution: every surface normal line
        of such a surface meets the axis, so the axis (direction and point, four degrees of
        freedom) is the line the cloud's normal lines come closest to meeting (robust least
        squares, `tolerance_m` the scale of the residuals that still count fully; a handle's
        normals are outliers). The axis of a fitted library mesh is a few millimetres off the
        object's, and the back wall mirrored through it twice that."""
        across = np.linalg.svd(self.direction[None])[2][1:]  # two unit vectors perpendicular to the axis
        point = self.point + ((points.mean(axis=0) - self.point) @ self.direction) * self.direction

        def line(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            direction = self.direction + x[:2] @ across
            return direction / np.linalg.norm(direction), point + x[2:] @ across

        def residuals(x: np.ndarray) -> np.ndarray:
            # (p - c) . (n x d): zero when the normal line through p meets the axis.
            direction, on_axis = line(x)
            return np.einsum("ni,ni->n", points - on_axis, np.cross(normals, direction))

        solution = least_squares(
            residuals, np.zeros(4), loss="soft_l1", f_scale=tolerance_m, x_scale=[0.05, 0.05, tolerance_m, tolerance_m]
        )
        direction, on_axis = line(solution.x)
        return RevolutionAxis(point=on_axis, direction=direction)

    def plane_facing(self, viewpoint: np.ndarray) -> Plane | None:
        """The plane through the axis whose normal points at `viewpoint` (None when it looks along the axis).

        Mirroring through it carries the surface a camera at `viewpoint` sees onto the back of
        the object: the one symmetry plane, of a revolved object's many, that completes a view.
        """
        normal = self.offset_to(np.asarray(viewpoint, dtype=np.float64)[None])[0]
        length = float(np.linalg.norm(normal))
        if length < 1e-9 or length < 0.05 * float(np.linalg.norm(viewpoint - self.point)):
            return None
        normal /= length
        return Plane(normal=normal, offset=float(normal @ self.point))


# Of the bounding diagonal, for a mesh's exact normals (a query's noisier ones: pipeline.AXIS_FIT_TOLERANCE_M).
MESH_AXIS_FIT_TOLERANCE = 0.005


def revolution_axis(
    mesh: trimesh.Trimesh, *, tolerance: float = 0.12, n_samples: int = 1500, seed: int = 0
) -> RevolutionAxis | None:
    """The axis, near a principal axis through the centroid, about which the surface turns into itself, if any.

    Each principal axis is first moved to the line the surface's normal lines come closest to
    meeting (`RevolutionAxis.fitted_to`): a mug's handle pulls its centroid and principal axes
    off its body's axis, and the fit puts them back. A candidate is accepted when samples
    turned by 40, 95 and 160 degrees about it lie, at the median, within `tolerance` times the
    samples' median distance from the axis and within 1% of the bounding diagonal. The median
    lets a mug count as revolved: its body is, its handle (a minority of the samples) is not.
    Measured on the generated classes (error over radius): bottles, bowls, glasses and mugs
    0.001-0.007 (mugs 0.028-0.083 before the fit, up to 2% of the diagonal, so half were
    refused), spoons 0.27-0.36. The radius alone lets a flat box pass, turned about its thinnest
    axis (its large faces map onto themselves); the diagonal does not.
    """
    points, faces = trimesh.sample.sample_surface(mesh, n_samples, seed=seed)
    normals = mesh.face_normals[faces]
    areas = mesh.area_faces
    centroid = (mesh.triangles_center * areas[:, None]).sum(axis=0) / areas.sum()
    diagonal = float(np.linalg.norm(mesh.extents))
    _, axes = np.linalg.eigh(np.cov((points - centroid).T))
    best: tuple[float, RevolutionAxis] | None = None
    for direction in axes.T:
        candidate = RevolutionAxis(point=centroid, direction=direction).fitted_to(
            points, normals, tolerance_m=MESH_AXIS_FIT_TOLERANCE * diagonal
        )
        turned = [
            (points - candidate.point)
            @ trimesh.transformations.rotation_matrix(np.radians(angle), candidate.direction)[:3, :3].T
            + candidate.point
            for angle in (40.0, 95.0, 160.0)
        ]
        radius = float(np.median(np.linalg.norm(candidate.offset_to(points), axis=1)))
        error_m = float(np.median(distances_to_surface(np.concatenate(turned), mesh)))
        error = error_m / max(radius, 1e-12)
        if error < tolerance and error_m < 0.01 * diagonal and (best is None or error < best[0]):
            best = (error, candidate)
    return None if best is None else best[1]

