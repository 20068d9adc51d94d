"""A scan's two meshes (turntable, photogrammetry, shape completion): the visual mesh with the
detail its points hold, and a collision mesh of convex shapes within a tolerance of it.

The visual is the pipeline's mesh at full detail: an untextured one is decimated only above
`max_visual_faces` (a textured one comes capped by its pipeline: its UVs are tied to its
vertices), and it is measured against the points it was made from (fused dense points, merged
depth points, a completion's query points): the median distance from the points to its
surface should stay within the points' own spacing. The collision is the mesh's convex hull
when the hull keeps within the tolerance of the surface (a box, a can), else convex parts
(`articulation.convex_parts`) tried from cheap to fine until they keep within the tolerance
both ways (no part reaching past the surface, no surface left outside every part): the hulls
of k-means cells of a closed mesh's solid, then V-HACD's parts (few parts from coarse voxels
first).
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field

import numpy as np
import trimesh

from articulation.convex_parts import Decomposition, cell_decomposition, decompose, fidelity, solid_points
from homemodel.core.checks import require_at_least, require_between, require_positive
from homemodel.core.errors import ModelError
from homemodel.core.model_summary import CollisionMesh, MeshFit, ScanMeshes as ScanMeshFigures, VisualMesh
from homemodel.core.progress import Progress, no_progress
from homemodel.geometry.mesh_ops import decimate, from_open3d, to_open3d
from homemodel.geometry.surface_distance import SurfaceDistance

# The k-means cell counts tried on a closed mesh, fewest first. On the completions of 11 real
# cups, bowls and bottles, 32 cells kept all but one bowl within 5 mm (95th percentiles, both
# ways) and 48 all of them, at 0.3-0.6 CPU-s a try; 24 failed on half the cups.
CELL_COUNTS = (32, 48, 64)
# V-HACD's attempts, cheapest first: (at most this many parts, from this many voxels). On a
# 2-core machine at a load of 15, 32 parts from 10,000 voxels kept a completed cup and bottle
# within 4 mm (95th percentiles, both ways) in 3-5 s; 8 or 16 parts left a cup's rim 5-7 mm out.
ATTEMPTS = ((32, 10_000), (32, 40_000), (64, 100_000))
# V-HACD voxelises its input, so a mesh above this many faces is first reduced by vertex
# clustering into cells of this share of its diagonal (the parts are then measured against the
# full surface): on a 108,000-face completed cup that took 0.6 s and gave parts as faithful as
# the full mesh's, where quadric decimation to 5,000 faces took 10 s.
DECOMPOSITION_FACES = 5_000
DECOMPOSITION_CELL_FRACTION = 1 / 64
_MEASURED_POINTS = 40_000  # points (and surface samples) measured, drawn with a fixed seed
# Up to this many points, the closed mesh is measured by numpy unless Open3D is already imported:
# Open3D's import costs 0.3-0.7 CPU-s. A completion (50,000 triangles, 1,500 query points; with the
# convex parts' samples outside it about 12,000 points measured) took 0.2 CPU-s by numpy against
# 0.03 and the import by Open3D (the first scan meshes of a process 0.86-0.87 -> 0.71-0.73 CPU-s,
# docs/shape_completion.md); a scan's 40,000 points take 1.3 CPU-s by numpy against 0.09, so
# they stay with Open3D.
_NUMPY_MEASURE_POINTS = 5_000
_SEED = 0
_PROBE_QUERIES = 800  # the median search's bound comes from this many random queries


@dataclass(kw_only=True)
class ScanMeshOptions:
    max_visual_faces: int = 500_000  # an untextured visual above this is decimated to it
    collision_tolerance_m: float = 0.005  # the parts keep this close to the visual surface, both ways
    unscaled_tolerance_fraction: float = 0.025  # the tolerance of an unscaled model, of its diagonal
    max_collision_parts: int = 64

    def check(self) -> None:
        require_at_least("max_visual_faces", self.max_visual_faces, 100)
        require_positive("collision_tolerance_m", self.collision_tolerance_m)
        require_between("unscaled_tolerance_fraction", self.unscaled_tolerance_fraction, 1e-4, 0.5)
        require_between("max_collision_parts", self.max_collision_parts, 1, 64)


@dataclass(kw_only=True)
class ScanMeshPair:
    visual: trimesh.Trimesh
    uv: np.ndarray | None  # one per visual vertex, when textured
    collisions: list[trimesh.Trimesh]  # the convex hull alone, or the convex parts
    decomposition: Decomposition | None  # None: the hull
    figures: ScanMeshFigures = field(repr=False)


def _closed(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """The mesh's geometry with coincident vertices welded: a textured mesh split along its UV
    seams becomes the closed surface it is, which containment tests need."""
    welded = trimesh.Trimesh(np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces), process=False)
    welded.merge_vertices(merge_tex=True, merge_norm=True)
    return welded


def _sample(points: np.ndarray, count: int) -> np.ndarray:
    if len(points) <= count:
        return points
    return points[np.random.default_rng(_SEED).choice(len(points), count, replace=False)]


def point_spacing(points: np.ndarray) -> float:
    """The points' median distance to their nearest neighbour."""
    from scipy.spatial import cKDTree

    distances, _ = cKDTree(points).query(_sample(points, _MEASURED_POINTS), k=2)
    return float(np.median(distances[:, 1]))


def mesh_fit(
    mesh: trimesh.Trimesh, points: np.ndarray | None, *, to_mesh: SurfaceDistance | None = None
) -> dict[str, float | None]:
    """`MeshFit`'s figures: the points' distance to the surface and the surface's to the points
    (`to_mesh`: the distance measure of `mesh`'s triangles, when built)."""
    if points is None or len(points) == 0:
        return {"points_to_surface_median": None, "points_to_surface_p95": None, "surface_to_points_median": None}
    to_surface = (to_mesh or SurfaceDistance(mesh)).distances(_sample(points, _MEASURED_POINTS))
    on_surface, _ = trimesh.sample.sample_surface(mesh, _MEASURED_POINTS, seed=_SEED)
    return {
        "points_to_surface_median": float(np.median(to_surface)),
        "points_to_surface_p95": float(np.percentile(to_surface, 95)),
        "surface_to_points_median": _median_nearest(points, on_surface),
    }


def _median_nearest(points: np.ndarray, queries: np.ndarray) -> float:
    """The median of the `queries`' distances to their nearest of `points`, exactly. Searched
    first only within the 60th percentile of 800 random queries' distances (the far side of a
    completion, which the query points do not see, lies centimetres from them and is the slowest
    to search): when over half the distances lie within that bound, the median is among them
    (40,000 samples of a completion and its 1,500 points: 0.06 CPU-s searched unbounded, 0.03
    within twice the median of every 50th query, 0.024 now)."""
    from scipy.spatial import cKDTree

    tree = cKDTree(points)
    probe, _ = tree.query(_sample(queries, _PROBE_QUERIES))
    found, _ = tree.query(queries, distance_upper_bound=float(np.quantile(probe, 0.6)))
    if np.count_nonzero(np.isfinite(found)) <= len(found) // 2:
        found, _ = tree.query(queries)
    return float(np.median(found))


def _collision(
    solid: trimesh.Trimesh, to_solid: SurfaceDistance, tolerance: float, options: ScanMeshOptions, progress: Progress
):
    """(shapes, decomposition or None, method, overshoot p95, overshoot max, gap p95, gap max)."""
    hull = solid.convex_hull
    fit = fidelity([hull], solid, to_real=to_solid, hold_real=True)
    best = ([hull], None, "convex hull", fit.overshoot_all_m, fit.overshoot_max_m, fit.gap_m, fit.gap_max_m)
    if best[3] <= tolerance:
        return best
    cells = [count for count in CELL_COUNTS if count <= options.max_collision_parts] if solid.is_watertight else []
    voxels = [a for a in ATTEMPTS if a[0] <= options.max_collision_parts] or [(options.max_collision_parts, ATTEMPTS[0][1])]
    attempts = [("cells", count, 0) for count in cells] + [("V-HACD", parts, resolution) for parts, resolution in voxels]
    points = solid_points(solid) if cells else None
    reduced = None
    for done, (kind, parts, resolution) in enumerate(attempts):
        progress("export", done, len(attempts))
        if kind == "cells":
            split = cell_decomposition(solid, parts, points=points, to_surface=to_solid, hull_overshoot_m=fit.overshoot_all_m)
            method = f"k-means cells: {parts} convex hulls"
        else:
            reduced = _reduced(solid) if reduced is None else reduced
            split = decompose(reduced, max_parts=parts, resolution=resolution, surface=solid, to_surface=to_solid,
                              hull_overshoot_m=fit.overshoot_all_m)  # fmt: skip
            method = f"V-HACD: at most {parts} parts from {resolution} voxels"
        found = ([p.mesh for p in split.parts], split, method, split.overshoot_m, split.overshoot_max_m, split.gap_m,
                 split.gap_max_m)  # fmt: skip
        if max(found[3], found[5]) < max(best[3], best[5]):
            best = found
        if max(best[3], best[5]) <= tolerance:
            break
    progress("export", len(attempts), len(attempts))
    return best


def _reduced(solid: trimesh.Trimesh) -> trimesh.Trimesh:
    """The mesh V-HACD voxelises: above DECOMPOSITION_FACES, reduced by vertex clustering."""
    if len(solid.faces) <= DECOMPOSITION_FACES:
        return solid
    cell = float(solid.scale) * DECOMPOSITION_CELL_FRACTION
    return from_open3d(to_open3d(solid).simplify_vertex_clustering(voxel_size=cell))


def scan_meshes(
    mesh: trimesh.Trimesh,
    points: np.ndarray | None,
    *,
    textured_mesh: trimesh.Trimesh | None = None,
    uv: np.ndarray | None = None,
    metric: bool = True,
    options: ScanMeshOptions | None = None,
    progress: Progress | None = None,
) -> ScanMeshPair:
    """The visual and collision meshes of the closed scan `mesh`, measured against `points`
    ((N, 3) in the mesh's frame; None: no distances). With `uv`, the visual is `textured_mesh`
    (default `mesh`) with those UVs, as the pipeline textured it. `metric` False: the mesh is in
    arbitrary units and the tolerance a share of its diagonal. Progress under "export"."""
    options = options or ScanMeshOptions()
    options.check()
    progress = progress or no_progress
    start = time.perf_counter()
    if len(mesh.faces) == 0:
        raise ModelError("the scan's mesh has no triangles")
    if points is not None:
        points = np.asarray(points, dtype=np.float64)
        if points.ndim != 2 or points.shape[1] != 3:
            raise ValueError(f"{points.shape=} but expected (N, 3)")
    visual = textured_mesh if uv is not None and textured_mesh is not None else mesh
    faces_before_cap = len(visual.faces)
    if uv is None:
        visual = decimate(visual, options.max_visual_faces)
    solid = _closed(mesh)
    tolerance = options.collision_tolerance_m if metric else options.unscaled_tolerance_fraction * float(solid.scale)
    few_points = points is None or len(points) <= _NUMPY_MEASURE_POINTS
    to_solid = SurfaceDistance(solid, open3d=False if few_points and "open3d" not in sys.modules else None)
    shapes, split, method, overshoot, overshoot_max, gap, gap_max = _collision(solid, to_solid, tolerance, options, progress)
    spacing = point_spacing(points) if points is not None and len(points) > 1 else None
    # The visual is often the mesh itself (untextured, under the cap): its triangles measured once.
    same = len(visual.faces) == len(solid.faces) and np.array_equal(visual.triangles, solid.triangles)
    visual_fit = mesh_fit(visual, points, to_mesh=to_solid if same else None)
    median = visual_fit["points_to_surface_median"]
    figures = ScanMeshFigures(
        points=0 if points is None else len(points),
        point_spacing=spacing,
        visual=VisualMesh(
            faces=len(visual.faces),
            faces_before_cap=faces_before_cap,
            within_point_spacing=None if median is None or spacing is None else bool(median <= spacing),
            **visual_fit,
        ),
        collision=CollisionMesh(
            method=method,
            parts=len(shapes),
            faces=sum(len(s.faces) for s in shapes),
            tolerance=tolerance,
            overshoot_p95=overshoot,
            overshoot_max=overshoot_max,
            gap_p95=gap,
            gap_max=gap_max,
            within_tolerance=bool(max(overshoot, gap) <= tolerance),
            **mesh_fit(trimesh.util.concatenate(shapes), points),
        ),
        seconds=round(time.perf_counter() - start, 3),
    )
    return ScanMeshPair(visual=visual, uv=uv, collisions=shapes, decomposition=split, figures=figures)


def warnings(figures: ScanMeshFigures) -> list[str]:
    """What the summary should warn of: detail lost, or collision parts beyond the tolerance."""
    said = []
    if figures.visual.within_point_spacing is False:
        said.append(
            f"visual mesh: the points lie {figures.visual.points_to_surface_median:.4g} from its surface (median), "
            f"more than their spacing {figures.point_spacing:.4g}"
        )
    if not figures.collision.within_tolerance:
        c = figures.collision
        said.append(
            f"collision mesh: {c.parts} convex parts reach {c.overshoot_p95:.4g} past the visual surface and leave "
            f"{c.gap_p95:.4g} of it uncovered (95th percentiles), beyond the tolerance {c.tolerance:.4g}"
        )
    return said
