"""Exact distances from points to a triangle mesh's surface.

`raycast.RayCaster.distances` answers the question through Open3D's tree of boxes, whose import
costs about half a CPU-second: a small mesh (a completion, its convex parts) is measured here
with numpy and scipy alone, float64 throughout. A large one (a scan's 100k triangles: 8x faster
there) goes to Open3D, about the mesh's centre so that float32 keeps far-away frames' digits.
"""

from __future__ import annotations

import numpy as np
import trimesh

from homemodel.geometry.raycast import RayCaster

# Triangles measured first per point, by nearest site (`_covering_sites`): their nearest
# distance bounds the point's from above, and only triangles with a site near enough to come
# nearer are measured after.
_FIRST_CANDIDATES = 8
# `bounds` takes fewer: its upper bound stays exact for most points, and its callers measure
# the few that matter. A completion's 32 cells' fidelity (medians of 8 alternating, load 15):
# 0.174 CPU-s with 8 (926 of 10,207 points then measured exactly), 0.148-0.152 with 4,
# 0.141 with 3, 0.137-0.142 with 2 (977), 0.140 with 1 (984).
_BOUND_CANDIDATES = 2
_MAX_SPLITS = 64  # a triangle's subdivision at most this fine (its sites then reach farther)
_SITES_PER_TRIANGLE = 2  # on average, at most (and 1000 more)
# Up to this many point-triangle pairs, bounds for every pair at once (blocks of this many when
# the sites reach far). Past 300,000 the tree was as fast or faster on every mesh tried; at
# 3,000,000, 460 points to a completion's convex parts took 0.057 CPU-s against 0.012 by the
# tree, to a capsule of 3,840 triangles 0.128 against 0.009, with the same distances.
_DENSE_PAIRS = 300_000
# The tree of sites serves when they reach no farther than this share of the mesh. At 20, a
# completion's 32 convex parts (sites reaching 7% of their size) took the dense bounds: 1,500
# points 0.20 -> 0.05 CPU-s, 40,000 points 7.2 -> 1.8, the same distances.
_TREE_REACH_DIVISOR = 10
_SLIVER_SINE2 = 1e-10
_OPEN3D_FROM_TRIANGLES = 20_000  # from here Open3D's measure repays its import (0.8 against 0.6 CPU-s at 20k)


class SurfaceDistance:
    """One mesh's triangles, ready for many distance queries (the tree of their sites is built once)."""

    def __init__(self, mesh: trimesh.Trimesh, *, open3d: bool | None = None) -> None:
        """`open3d`: measured by Open3D's caster, or by numpy (None: Open3D from _OPEN3D_FROM_TRIANGLES)."""
        self._caster: RayCaster | None = None
        if (len(mesh.faces) >= _OPEN3D_FROM_TRIANGLES) if open3d is None else open3d:
            self._centre = mesh.bounds.mean(axis=0)
            self._caster = RayCaster(trimesh.Trimesh(mesh.vertices - self._centre, mesh.faces, process=False))
            return
        from scipy.spatial import cKDTree

        triangles = np.asarray(mesh.triangles, dtype=np.float64)
        if len(triangles) == 0:
            raise ValueError("the mesh has no triangles to measure distances to")
        self._centres = triangles.mean(axis=1)
        self._radii = np.linalg.norm(triangles - self._centres[:, None], axis=2).max(axis=1)
        self._sites, self._owner, self._site_reach = _covering_sites(triangles, self._centres, self._radii)
        self._reach = float(self._site_reach.max())
        self._size = float(np.ptp(triangles.reshape(-1, 3), axis=0).max())
        self._tree = cKDTree(self._sites)
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
        # A determinant below the smallest normal float (a corner repeated beside a sub-nm edge:
        # the threshold underflows to 0) is flat too: its inverse would overflow to inf, a
        # RuntimeWarning on reconstruct's stderr.
        flat = (determinant <= _SLIVER_SINE2 * self._lengths2[:, 0] * self._lengths2[:, 1]) | (
            determinant < np.finfo(np.float64).tiny
        )
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
        points = _as_points(points)
        if len(points) == 0:
            return np.zeros(0)
        if self._caster is not None:
            return self._caster.distances(points - self._centre)
        if self._dense(points):
            # Few pairs, or sites that reach across the mesh (long thin triangles): every pair
            # bounded, a block of points at a time.
            step = max(1, _DENSE_PAIRS // len(self._centres))
            return np.concatenate([self._dense_distances(points[i : i + step]) for i in range(0, len(points), step)])
        best, kth_site = self._nearest_sites(points, _FIRST_CANDIDATES)
        # Every point of a triangle lies within `reach` of one of its sites, so a triangle
        # nearer than `best` has a site within best + reach: when the k-th site lies beyond
        # that, the k measured include the nearest.
        open_rows = np.flatnonzero(kth_site < best + self._reach)
        if len(open_rows):
            found = self._tree.query_ball_point(points[open_rows], best[open_rows] + self._reach, return_sorted=False)
            counts = np.fromiter((len(f) for f in found), dtype=np.int64, count=len(found))
            rows = np.repeat(open_rows, counts)
            sites = np.concatenate(found).astype(np.int64) if counts.sum() else np.zeros(0, dtype=np.int64)
            near = np.linalg.norm(points[rows] - self._sites[sites], axis=1) - self._site_reach[sites] < best[rows]
            rows, cols = rows[near], self._owner[sites[near]]  # a split triangle may come twice: harmless
            # Nor can a triangle whose plane lies farther than `best` come nearer (a sliver's
            # plane is noise: it stays).
            plane = np.abs(np.einsum("ij,ij->i", points[rows] - self._a[cols], self._normals[cols]))
            near = (plane < best[rows]) | np.isnan(self._inverse[cols])
            rows, cols = rows[near], cols[near]
            np.minimum.at(best, rows, self._pairs(points, rows, cols))
        return best

    def bounds(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper): (N,) bounds on each point's `distances`, from the triangles of its
        nearest sites alone (the tree's first step, about a third of its cost on points near a
        completion's surface); exact (lower == upper) where the measure has no such step."""
        points = _as_points(points)
        if len(points) == 0 or self._caster is not None or self._dense(points):
            exact = self.distances(points)
            return exact, exact
        best, kth_site = self._nearest_sites(points, _BOUND_CANDIDATES)
        return np.clip(kth_site - self._reach, 0.0, best), best

    def _dense(self, points: np.ndarray) -> bool:
        return len(points) * len(self._centres) <= _DENSE_PAIRS or self._reach > self._size / _TREE_REACH_DIVISOR

    def _nearest_sites(self, points: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """(N,) nearest distance to the triangles of each point's `k` nearest sites, and (N,)
        the k-th site's distance."""
        k = min(k, len(self._sites))
        to_sites, nearest = self._tree.query(points, k=k)
        to_sites, nearest = to_sites.reshape(len(points), k), nearest.reshape(len(points), k)
        rows = np.repeat(np.arange(len(points)), k)
        best = self._pairs(points, rows, self._owner[nearest.ravel()]).reshape(-1, k).min(axis=1)
        return best, to_sites[:, -1]

    def _dense_distances(self, points: np.ndarray) -> np.ndarray:
        """`distances` for a block of points: every pair's bounds at once (no tree),
        measured where the sphere and the plane of a triangle both come nearer than the
        nearest of the triangles with the nearest centres."""
        from scipy.spatial.distance import cdist

        to_centres = cdist(points, self._centres)
        k = min(_FIRST_CANDIDATES, len(self._centres))
        nearest = np.argpartition(to_centres, k - 1, axis=1)[:, :k]
        best = self._pairs(points, np.repeat(np.arange(len(points)), k), nearest.ravel()).reshape(-1, k).min(axis=1)
        to_planes = np.abs(points @ self._normals.T - np.einsum("ij,ij->i", self._normals, self._a))
        to_planes[:, np.isnan(self._inverse)] = 0.0  # a sliver's plane is noise
        rows, cols = np.nonzero(np.maximum(to_centres - self._radii, to_planes) < best[:, None])
        np.minimum.at(best, rows, self._pairs(points, rows, cols))
        return best


def _as_points(points: np.ndarray) -> np.ndarray:
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3:
        raise ValueError(f"{points.shape=} but expected (N, 3)")
    return points


def _covering_sites(
    triangles: np.ndarray, centres: np.ndarray, radii: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points on the triangles such that every point of a triangle lies within its sites'
    reach of one of them: a triangle's centre (reach: its farthest corner) when it is within
    the limit, else the centres of an n x n subdivision of it (n^2 similar triangles of 1/n its
    size and reach). Returns (sites, owning triangle, reach) per site."""
    # The smallest reach (from a 200th of the mesh's size up) whose sites stay within budget:
    # a fine mesh keeps its centres, a coarse mesh of long triangles gets its triangles split.
    limit = max(float(np.ptp(triangles.reshape(-1, 3), axis=0).max()) / 200, 1e-12)
    while np.sum(np.minimum(np.ceil(radii / limit), _MAX_SPLITS) ** 2) > _SITES_PER_TRIANGLE * len(radii) + 1000:
        limit *= 1.25
    splits = np.minimum(np.ceil(radii / limit), _MAX_SPLITS).astype(np.int64)
    whole = np.flatnonzero(splits <= 1)
    sites, owners, reaches = [centres[whole]], [whole], [radii[whole]]
    for n in np.unique(splits[splits > 1]):
        which = np.flatnonzero(splits == n)
        i, j = (g.ravel() for g in np.meshgrid(np.arange(n), np.arange(n), indexing="ij"))
        up, down = i + j <= n - 1, i + j <= n - 2
        u = np.concatenate([(i[up] + 1 / 3) / n, (i[down] + 2 / 3) / n])
        v = np.concatenate([(j[up] + 1 / 3) / n, (j[down] + 2 / 3) / n])
        a, b, c = triangles[which, 0], triangles[which, 1], triangles[which, 2]
        sites.append((a[:, None] + u[:, None] * (b - a)[:, None] + v[:, None] * (c - a)[:, None]).reshape(-1, 3))
        owners.append(np.repeat(which, len(u)))
        reaches.append(np.repeat(radii[which] / n, len(u)))
    return np.concatenate(sites), np.concatenate(owners), np.concatenate(reaches)
