"""Concave collision meshes as convex parts (V-HACD), with the parts' fidelity measured.

Simulators collide a mesh as its convex hull, which fills a concave object's opening: a
scanned cup cannot hold anything, a microwave's frame swallows its turntable. A closed
mesh whose hull is much larger than itself is split here into convex parts by V-HACD
(the `vhacdx` bindings trimesh calls), and the parts are measured against the real surface
both ways: how far they reach past it (`overshoot_m`, the 95th percentile over points on a
part's surface outside the solid), how far the real surface lies outside every part (`gap_m`),
and how much of the real volume they cover.

`cell_decomposition` is the cheap alternative for closed scans: the solid's points (a lattice
inside it and samples on its surface) split into k-means cells, each cell's convex hull a part.
A cell of a thin wall holds a short stretch of it, whose hull reaches past the wall by the
stretch's sagitta, so on cups, bowls and bottles it keeps as close to the surface as V-HACD
for a fraction of the time (see `cell_decomposition`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from homemodel.geometry.surface_distance import SurfaceDistance

# A closed mesh is split when its hull holds this much more than the mesh: a solid that is
# nearly convex (a box, a bottle) keeps its hull.
CONCAVE_HULL_RATIO = 1.3
MAX_PARTS = 8
# V-HACD's voxel budget: 20,000 split a microwave's frame into 8 tight parts in about 3 s here.
VOXEL_RESOLUTION = 10_000
# `cell_decomposition`'s points: the lattice's step as a share of the diagonal, the surface's
# samples, and the k-means iterations (a completed mug: 1,900 lattice points inside).
CELL_LATTICE_FRACTION = 1 / 48
CELL_SURFACE_POINTS = 8000
CELL_ITERATIONS = 20
_SAMPLES = 500
# `as_convex_hull` tests a mesh of up to this many vertex-face pairs (1.6 MB of them at once):
# a cell's or V-HACD part's hull has a few hundred faces, about 30,000 pairs. Spheres: 52,000
# pairs tested in 0.5 ms against qhull's 1.9, 822,000 in 17 ms against 11.
_OWN_HULL_PAIRS = 200_000
# `fidelity` measures the points that decide its figures in at most this many rounds (a
# completion's cells take two), then in one last, wider round.
_DECIDING_ROUNDS = 3
_SEED = 0


@dataclass(frozen=True)
class ConvexPart:
    mesh: trimesh.Trimesh
    overshoot_m: float  # 95th percentile distance from the part's surface to the real surface


@dataclass(frozen=True)
class Fidelity:
    """Convex shapes against the real surface, both ways, in the meshes' units."""

    overshoot_m: np.ndarray  # per shape: 95th percentile reach past the real surface
    overshoot_all_m: float  # the same over all the shapes' surface (by area)
    overshoot_max_m: float  # the farthest any sampled point of any shape reaches past it
    gap_m: float  # 95th percentile distance of the real surface outside every shape to the nearest one
    gap_max_m: float


@dataclass(frozen=True)
class Decomposition:
    parts: list[ConvexPart]
    coverage: float  # share of the real volume inside some part, 0..1
    hull_overshoot_m: float  # the same measure for the single convex hull, for comparison
    overshoot_m: float  # 95th percentile reach past the real surface over all the parts' surface
    overshoot_max_m: float
    gap_m: float  # 95th percentile of the real surface's distance outside every part
    gap_max_m: float

    def format(self) -> str:
        return (
            f"{len(self.parts)} convex parts covering {self.coverage:.0%} of the volume, reaching "
            f"{self.overshoot_m * 1000:.1f} mm past the surface and leaving it uncovered by "
            f"{self.gap_m * 1000:.1f} mm (95th percentiles; one hull: {self.hull_overshoot_m * 1000:.1f} mm past it)"
        )


def is_concave(mesh: trimesh.Trimesh) -> bool:
    """A closed mesh whose convex hull is `CONCAVE_HULL_RATIO` times its volume or more."""
    return bool(mesh.is_watertight and mesh.volume > 0 and mesh.convex_hull.volume >= CONCAVE_HULL_RATIO * mesh.volume)


def inside_convex(hull: trimesh.Trimesh, points: np.ndarray, tolerance: float = 1e-9) -> np.ndarray:
    """Which points lie inside the convex mesh `hull` (on the inner side of every face's plane)."""
    normals = hull.face_normals
    offsets = np.einsum("ij,ij->i", normals, hull.triangles[:, 0])
    return np.all(points @ normals.T - offsets <= tolerance, axis=1)


def as_convex_hull(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """`mesh` itself when it already bounds a convex solid, else its convex hull. A mesh bounds
    one when it is closed and consistently wound (every directed edge once, its reverse once),
    uses every vertex, holds a volume, and has every vertex on or behind every face's plane.
    The test costs a tenth of qhull's hull on a part (a scan's 32 cell hulls: 0.035 CPU-s
    rebuilt), but every vertex against every face grows as their product: above
    `_OWN_HULL_PAIRS` qhull builds the hull (a closed sphere of 10,000 vertices tested took
    8.5 CPU-s and 3.3 GB, qhull 0.07 s)."""
    vertices, faces = np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64)
    if 4 <= len(faces) and len(vertices) * len(faces) <= _OWN_HULL_PAIRS and len(np.unique(faces)) == len(vertices):
        edges = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
        directed = np.unique(edges[:, 0] * len(vertices) + edges[:, 1])
        reverse = edges[:, 1] * len(vertices) + edges[:, 0]
        corners = vertices[faces]
        normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        volume = np.einsum("ij,ij->", corners[:, 0], normals) / 6
        size = float(np.ptp(vertices, axis=0).max())
        # A vertex may stand a billionth of the size past a face's plane (round-off on coplanar
        # facets; the normals are not unit, so the allowance scales with them).
        tolerance = 1e-9 * size * np.linalg.norm(normals, axis=1)
        if (
            len(directed) == len(edges)
            and np.isin(reverse, directed).all()
            and volume > 1e-12 * size**3
            and np.all(vertices @ normals.T - np.einsum("ij,ij->i", normals, corners[:, 0]) <= tolerance)
        ):
            return mesh
    return mesh.convex_hull


def _contains(mesh: trimesh.Trimesh, points: np.ndarray) -> np.ndarray:
    """`mesh.contains(points)`, the same on every run. trimesh casts a second ray for a point
    whose two rays disagree (an open scan's) in a direction drawn from NumPy's global generator,
    unseeded: on Kermit's body 76-206 of 2,000 points changed with that generator's state, and
    the figures with them. The generator is seeded for the call and its state put back."""
    state = np.random.get_state()
    np.random.seed(_SEED)
    try:
        return mesh.contains(points)
    finally:
        np.random.set_state(state)


def _volume_points(mesh: trimesh.Trimesh, count: int) -> np.ndarray:
    """The points inside `mesh` of `count` drawn evenly in its box (trimesh's `volume_mesh`,
    which draws them from NumPy's unseeded global generator)."""
    points = np.random.default_rng(_SEED).random((count, 3)) * mesh.extents + mesh.bounds[0]
    return points[_contains(mesh, points)]


def _covered(shapes: list[trimesh.Trimesh], points: np.ndarray, tolerance: float) -> np.ndarray:
    """Which points lie inside some convex shape (each shape tests only the points still out
    within its bounding box)."""
    covered = np.zeros(len(points), dtype=bool)
    for shape in shapes:
        out = np.flatnonzero(~covered)
        low, high = shape.bounds
        out = out[np.all((points[out] >= low - tolerance) & (points[out] <= high + tolerance), axis=1)]
        covered[out[inside_convex(shape, points[out], tolerance)]] = True
    return covered


def fidelity(
    shapes: list[trimesh.Trimesh],
    real: trimesh.Trimesh,
    *,
    to_real: SurfaceDistance | None = None,
    samples: int = _SAMPLES,
    seed: int = _SEED,
    hold_real: bool = False,
) -> Fidelity:
    """How far convex `shapes` reach past the `real` surface (points on a shape inside the real
    solid, where parts meet inside a wall, count as zero: by ray parity, which a nearly closed
    scan with a few holes still answers for most points) and how
    far the real surface lies outside all of them (zero inside any). `to_real`: `real`'s
    distance measure already built (a large surface measured against several decompositions).
    `hold_real`: the shapes hold all of `real` (its convex hull), so no point of it lies outside
    them and the gap is zero unmeasured (testing 2,000 points against a completion's hull of
    1,254 faces cost 0.02 CPU-s)."""
    rng = np.random.default_rng(seed)
    to_real = to_real or SurfaceDistance(real)
    # Every shape's samples measured in one batch (one ray-parity pass, not one per shape);
    # only those outside the solid are measured.
    on_shapes = np.concatenate(
        [trimesh.sample.sample_surface(shape, samples, seed=int(rng.integers(1 << 31)))[0] for shape in shapes]
    )
    outside = ~_contains(real, on_shapes)
    # Each shape's samples weigh by its area in the figure over all the shapes.
    weights = np.concatenate([np.full(samples, shape.area / samples) for shape in shapes])
    distance = _deciding_distances(to_real, on_shapes, outside, samples, weights)
    distances = np.split(distance, len(shapes))
    overshoots = [float(np.percentile(d, 95)) for d in distances]
    overshoot_all = _weighted_95(distance, weights)
    gap = np.zeros(4 * samples)
    if not hold_real:
        points, _ = trimesh.sample.sample_surface(real, 4 * samples, seed=int(rng.integers(1 << 31)))
        uncovered = ~_covered(shapes, points, tolerance=1e-6 * float(real.scale))
        if uncovered.any():
            gap[uncovered] = SurfaceDistance(trimesh.util.concatenate(shapes)).distances(points[uncovered])
    return Fidelity(
        overshoot_m=np.array(overshoots),
        overshoot_all_m=overshoot_all,
        overshoot_max_m=float(max(d.max() for d in distances)),
        gap_m=float(np.percentile(gap, 95)),
        gap_max_m=float(gap.max()),
    )


def _weighted_95(values: np.ndarray, weights: np.ndarray) -> float:
    """The value below which 95 % of the weight lies."""
    order = np.argsort(values)
    at_95 = np.searchsorted(np.cumsum(weights[order]), 0.95 * weights[order].sum())
    return float(values[order][min(at_95, len(order) - 1)])


def _deciding_distances(
    to_real: SurfaceDistance, points: np.ndarray, outside: np.ndarray, samples: int, weights: np.ndarray
) -> np.ndarray:
    """Distances of the `points` (`samples` a shape, in order) to the real surface, zero inside
    it, that give `fidelity`'s figures as measuring every point would: each shape's 95th
    percentile, the `weights`' 95th percentile over all, and the maximum.

    Every point starts at its upper bound (`SurfaceDistance.bounds`, exact for most). A point
    whose bounds hold a figure, as these values give it, is measured exactly, and the figures
    are taken again. When none is left, each point not measured lies on the same side of every
    figure whatever its distance within its bounds, so the figures are those of the exact
    distances. If some are still left after `_DECIDING_ROUNDS`, the last round takes each
    figure's range from the points' lower bounds to their values: the figure lies in it, and
    the points whose bounds meet it are all measured at once. A completion's 32 cells: 10,000
    points outside, about a tenth measured, in two rounds."""
    lower, value = np.zeros(len(points)), np.zeros(len(points))
    lower[outside], value[outside] = to_real.bounds(points[outside])
    loose = lower < value
    for round_ in range(_DECIDING_ROUNDS + 1):
        if not loose.any():
            break
        # The figures' low ends: from the values (a guess) or, in the last round, the lower bounds.
        low = lower if round_ == _DECIDING_ROUNDS else value
        measure = np.flatnonzero(_holding_a_figure(low, value, lower, samples, weights) & loose)
        if not len(measure):
            break
        value[measure] = lower[measure] = to_real.distances(points[measure])
        loose[measure] = False
    return value


def _holding_a_figure(
    low: np.ndarray, high: np.ndarray, lower: np.ndarray, samples: int, weights: np.ndarray
) -> np.ndarray:
    """Which points' bounds (`lower`, `high`) meet a figure's range: from the figure of the
    `low` values to that of the `high` ones."""
    # np.percentile's 95th interpolates between these two ranks of a shape's samples.
    first = int(np.floor(0.95 * (samples - 1)))
    low_at = np.repeat(np.partition(low.reshape(-1, samples), first, axis=1)[:, first], samples)
    second = min(first + 1, samples - 1)
    high_at = np.repeat(np.partition(high.reshape(-1, samples), second, axis=1)[:, second], samples)
    holds = (high >= low_at) & (lower <= high_at)
    holds |= (high >= _weighted_95(low, weights)) & (lower <= _weighted_95(high, weights))
    return holds | (high >= low.max())


def spans_a_volume(vertices: np.ndarray) -> bool:
    """Whether a part's points span three dimensions: a flat or collapsed part (fewer
    than four distinct points, or all on one plane) has no convex hull (qhull refuses it)."""
    distinct = np.unique(vertices, axis=0)
    if len(distinct) < 4:
        return False
    spread = np.linalg.svd(distinct - distinct.mean(axis=0), compute_uv=False)
    return bool(spread[2] > 1e-6 * spread[0])


def _measured(
    meshes: list[trimesh.Trimesh],
    surface: trimesh.Trimesh,
    *,
    to_surface: SurfaceDistance,
    inside: np.ndarray,
    hull_overshoot_m: float | None,
) -> Decomposition:
    """The `Decomposition` of convex `meshes` against `surface`; `inside`: points of its solid."""
    fit = fidelity(meshes, surface, to_real=to_surface)
    if hull_overshoot_m is None:
        hull = fidelity([surface.convex_hull], surface, to_real=to_surface, seed=_SEED + 1, hold_real=True)
        hull_overshoot_m = float(hull.overshoot_m[0])
    covered = _covered(meshes, inside, tolerance=1e-6 * float(surface.scale))
    return Decomposition(
        parts=[ConvexPart(mesh=m, overshoot_m=float(o)) for m, o in zip(meshes, fit.overshoot_m, strict=True)],
        coverage=float(covered.mean()) if len(inside) else 0.0,
        hull_overshoot_m=hull_overshoot_m,
        overshoot_m=fit.overshoot_all_m,
        overshoot_max_m=fit.overshoot_max_m,
        gap_m=fit.gap_m,
        gap_max_m=fit.gap_max_m,
    )


def decompose(
    mesh: trimesh.Trimesh,
    *,
    max_parts: int = MAX_PARTS,
    resolution: int = VOXEL_RESOLUTION,
    surface: trimesh.Trimesh | None = None,
    to_surface: SurfaceDistance | None = None,
    hull_overshoot_m: float | None = None,
) -> Decomposition:
    """The convex parts of a closed `mesh` (at most `max_parts`, from V-HACD's `resolution`
    voxels) and how faithful they are to `surface` (default: `mesh`; a finer mesh of the same
    object when `mesh` is a reduced copy; `to_surface` its distance measure, if built;
    `hull_overshoot_m` the hull's overshoot, if measured)."""
    from trimesh.decomposition import convex_decomposition

    surface = mesh if surface is None else surface
    to_surface = to_surface or SurfaceDistance(surface)
    found = convex_decomposition(mesh, maxConvexHulls=max_parts, resolution=resolution)
    found = found if isinstance(found, list) else [found]
    meshes = [trimesh.Trimesh(**p) if isinstance(p, dict) else p for p in found]
    meshes = [m.convex_hull for m in meshes if spans_a_volume(m.vertices)]
    inside = _volume_points(surface, 4 * _SAMPLES)
    return _measured(meshes, surface, to_surface=to_surface, inside=inside, hull_overshoot_m=hull_overshoot_m)


@dataclass(frozen=True)
class SolidPoints:
    """Points filling a closed mesh (`solid_points`)."""

    inside: np.ndarray  # on a lattice, inside the mesh
    surface: np.ndarray  # on its surface, which is all a thin wall between the lattice's points holds

    @property
    def all(self) -> np.ndarray:
        return np.concatenate([self.inside, self.surface])


def solid_points(mesh: trimesh.Trimesh, *, seed: int = _SEED) -> SolidPoints:
    """A lattice inside the closed `mesh`, `CELL_LATTICE_FRACTION` of its diagonal apart (the
    inside by ray parity), and `CELL_SURFACE_POINTS` on its surface."""
    step = float(mesh.scale) * CELL_LATTICE_FRACTION
    low, high = mesh.bounds
    axes = [np.arange(lo + step / 2, hi, step) for lo, hi in zip(low, high, strict=True)]
    lattice = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    on_surface, _ = trimesh.sample.sample_surface(mesh, CELL_SURFACE_POINTS, seed=seed)
    return SolidPoints(inside=lattice[_contains(mesh, lattice)], surface=on_surface)


def cell_decomposition(
    mesh: trimesh.Trimesh,
    parts: int,
    *,
    points: SolidPoints | None = None,
    to_surface: SurfaceDistance | None = None,
    hull_overshoot_m: float | None = None,
    seed: int = _SEED,
) -> Decomposition:
    """`parts` convex parts of the closed `mesh`: its solid's points (`points`, default
    `solid_points(mesh)`) in k-means cells, each cell's hull, measured as `decompose`'s. On
    completed cups, bowls and bottles, 32 cells reached 2.7-3.8 mm past the surface where
    V-HACD's 32 parts from 10,000 voxels reached 4.2 mm, in 0.4 CPU-s against its 1.4."""
    from scipy.cluster.vq import kmeans2

    points = solid_points(mesh, seed=seed) if points is None else points
    # At the exported meshes' precision (`homemodel.exchange.numbers.fixed`), so a written part's
    # vertices read back as they are: hulls of points sampled on flat faces have near-coplanar
    # facets that rounding on export could fold inwards.
    every = np.round(points.all, 6)
    _, cell = kmeans2(every, parts, minit="++", seed=seed, iter=CELL_ITERATIONS)
    meshes = []
    for k in range(parts):
        member = every[cell == k]
        if len(member) >= 4 and spans_a_volume(member):
            meshes.append(trimesh.convex.convex_hull(member))
    return _measured(
        meshes, mesh, to_surface=to_surface or SurfaceDistance(mesh), inside=points.inside, hull_overshoot_m=hull_overshoot_m
    )
