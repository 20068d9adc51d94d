"""Exact distances from points to a triangle mesh's surface with numpy and scipy alone.

`raycast.RayCaster.distances` answers the same question through Open3D, whose import costs
about a second of CPU: a command that only measures a mesh (a completion's two meshes, their
convex parts) measures here instead. Float64 throughout, so far-away frames keep their digits.
"""

from __future__ import annotations

import numpy as np
import trimesh

# Triangles measured first per point, by nearest centre: their nearest distance bounds the
# point's from above, and only triangles whose bounding sphere comes nearer are measured after.
_FIRST_CANDIDATES = 8
_SLIVER_SINE2 = 1e-10


class SurfaceDistance:
    """One mesh's triangles, ready for many distance queries (the tree is built once)."""

    def __init__(self, mesh: trimesh.Trimesh) -> None:
        from scipy.spatial import cKDTree

        triangles = np.asarray(mesh.triangles, dtype=np.float64)
        if len(triangles) == 0:
            raise ValueError("the mesh has no triangles to measure distances to")
        self._centres = triangles.mean(axis=1)
        self._radii = np.linalg.norm(triangles - self._centres[:, None], axis=2).max(axis=1)
        self._tree = cKDTree(self._centres)
        # Per triangle: corner a, edges a->b, a->c, b->c, their squared lengths, the unit normal
        # and the barycentric system's terms (NaN for a sliver: never inside).
        self._a, self._b = triangles[:, 0], triangles[:, 1]
        self._edges = np.stack([triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0],
                                triangles[:, 2] - triangles[:, 1]], axis=1)  # fmt: skip
        self._lengths2 = np.maximum(np.einsum("tej,tej->te", self._edges, self._edges), 1e-300)
        e0, e1 = self._edges[:, 0], self._edges[:, 1]
        normal = np.cross(e0, e1)
        self._normals = normal / np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
        d01 = np.einsum("ij,ij->i", e0, e1)
        determinant = self._lengths2[:, 0] * self._lengths2[:, 1] - d01**2
        # A sliver (its sine of angle below 1e-5) has no trustworthy plane: measured by its edges
        # alone, which lie within 1e-5 of its longest edge of every point of it.
        flat = determinant <= _SLIVER_SINE2 * self._lengths2[:, 0] * self._lengths2[:, 1]
        self._inverse = np.where(flat, np.nan, 1.0 / np.where(flat, 1.0, determinant))
        self._d01 = d01

    def _pairs(self, points: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Distance from points[rows] to triangles[cols]: to the plane where the point projects
        inside the triangle, else to the nearest of its three edges."""
        p = points[rows]
        v = p - self._a[cols]
        edges, lengths2 = self._edges[cols], self._lengths2[cols]
        e0, e1 = edges[:, 0], edges[:, 1]
        d20, d21 = np.einsum("ij,ij->i", v, e0), np.einsum("ij,ij->i", v, e1)
        d01, inverse = self._d01[cols], self._inverse[cols]
        with np.errstate(invalid="ignore"):
            s = (lengths2[:, 1] * d20 - d01 * d21) * inverse
            t = (lengths2[:, 0] * d21 - d01 * d20) * inverse
            inside = (s >= 0) & (t >= 0) & (s + t <= 1)
        best = np.full(len(rows), np.inf)
        for start, edge, along, length2 in ((v, e0, d20, lengths2[:, 0]), (v, e1, d21, lengths2[:, 1]),
                                            (p - self._b[cols], edges[:, 2], None, lengths2[:, 2])):  # fmt: skip
            along = np.einsum("ij,ij->i", start, edge) if along is None else along
            off = start - np.clip(along / length2, 0.0, 1.0)[:, None] * edge
            np.minimum(best, np.einsum("ij,ij->i", off, off), out=best)
        plane = np.einsum("ij,ij->i", v, self._normals[cols])
        return np.sqrt(np.where(inside, plane**2, best))

    def distances(self, points: np.ndarray) -> np.ndarray:
        """(N,) exact unsigned distance from each point to the nearest point of the triangles."""
        points = np.asarray(points, dtype=np.float64)
        if points.ndim != 2 or points.shape[1] != 3:
            raise ValueError(f"{points.shape=} but expected (N, 3)")
        if len(points) == 0:
            return np.zeros(0)
        k = min(_FIRST_CANDIDATES, len(self._centres))
        to_centres, nearest = self._tree.query(points, k=k)
        to_centres, nearest = to_centres.reshape(len(points), k), nearest.reshape(len(points), k)
        best = self._pairs(points, np.repeat(np.arange(len(points)), k), nearest.ravel()).reshape(-1, k).min(axis=1)
        # A triangle nearer than `best` has its centre within best + its radius: when the k-th
        # centre lies beyond best + the largest radius, the k measured include the nearest.
        open_rows = np.flatnonzero(to_centres[:, -1] < best + self._radii.max())
        if len(open_rows):
            found = self._tree.query_ball_point(points[open_rows], best[open_rows] + self._radii.max(), return_sorted=False)
            counts = np.fromiter((len(f) for f in found), dtype=np.int64, count=len(found))
            rows = np.repeat(open_rows, counts)
            cols = np.concatenate(found).astype(np.int64) if counts.sum() else np.zeros(0, dtype=np.int64)
            near = np.linalg.norm(points[rows] - self._centres[cols], axis=1) - self._radii[cols] < best[rows]
            rows, cols = rows[near], cols[near]
            np.minimum.at(best, rows, self._pairs(points, rows, cols))
        return best
