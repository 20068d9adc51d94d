"""From the merged cloud to a closed, coloured mesh: lone strays and clumps dropped, normals
turned towards the cameras (outward), then the surface: marching cubes over the points' signed
distance (the default), or screened Poisson with density trimming (the fallback)."""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np
import trimesh

from homemodel.core.checks import require_at_least, require_between
from homemodel.core.errors import ModelError
from homemodel.geometry.mesh_ops import decimate_closed, largest_piece, point_cloud, poisson_surface, repair_surface
from homemodel.geometry.open3d_loader import load_open3d
from turntable.fusion import Cylinder, MergedCloud

if TYPE_CHECKING:
    from scipy.spatial import cKDTree

# Poisson's cube around the points, relative to their extent: room for the surface to close
# below the footprint instead of being cut open by the cube's face.
_POISSON_SCALE = 1.5
_UNMEASURED_SKIN = 0.25  # of the signed-distance solid's skin: more is a leak (see `distance_surface`)
_SPLAT_CHUNK = 1536  # points added to the grid at once: (P, S) arrays of ~1.5 MB, in cache (4096: 20 % more CPU)
_SPLAT_THREADS = 2  # threads making the splat's chunks (NumPy lets go of the GIL in each of their steps)


@dataclass(kw_only=True)
class MeshingOptions:
    # distance: marching cubes over the signed distance to the points' tangent planes (fast, keeps
    # unseen concavities open); poisson: screened Poisson, which closes them smoothly.
    surface: Literal["distance", "poisson"] = "distance"
    # The signed-distance grid's cells, in the merge's voxels (the reach, seal and smoothing are
    # in these cells). 1.25 (1.9 mm): the bench mug's 40 frames 0.426 -> 0.326 mm, VoxelIOU
    # 0.884 -> 0.894, 69k -> 44k triangles, mesh and texture 0.62 -> 0.48 CPU-s; the accuracy
    # captures' box 0.087 -> 0.090, cylinder 0.064 -> 0.072 mm. At 1.5 the box's edges round
    # over (0.13 mm) and a cup's unseen floor is lidded.
    grid_voxels: float = 1.25
    distance_reach_voxels: float = 3.0  # a grid node's signed distance comes from points this near
    # ... and this near their normal's line: a tangent plane carried sideways past an edge puts
    # the outside beyond the edge inside (a box's corners grew blobs; 0.203 -> 0.186 mm there).
    distance_lateral_voxels: float = 1.5
    seal_voxels: int = 3  # gaps in the points' band about twice this wide are closed over, not leaked through
    smoothing_voxels: float = 0.6  # Gaussian sigma on the signed distance (bench mug: 0.448 -> 0.421 mm; noisy 0.568 -> 0.484)
    # A point with fewer than `stray_neighbours` others within two voxels is a stray (a flying
    # pixel that survived the merge), and one with fewer than `clump_neighbours` within three is
    # in a clump of them: either's tangent planes alone would make a blob of solid beside the
    # surface, the seal plugging the gap between them. Open3D's statistical filter (20
    # neighbours, 2.5 sigma), which these replace, took voxels at the bench mug's rim and handle
    # (0.326 -> 0.310 mm without it at 40 frames, 0.310 -> 0.284 at 200; noisy the same) and
    # cost 45 CPU-ms; the clumps are what it caught besides (the ROS 1 recording's fisheye and
    # depth camera: 0.340 mm with the strays' rule alone, 0.275 with it, 0.265 with the clumps').
    stray_neighbours: int = 2
    clump_neighbours: int = 5
    normal_neighbours: int = 24
    poisson_depth: int | None = None  # None: octree cells about one voxel wide
    density_quantile: float = 0.03  # drop the Poisson vertices least supported by points
    max_triangles: int = 80_000  # quadric decimation above this
    close_bottom: bool = True  # add the footprint on the table top, so the mesh closes there
    snap_to_points: bool = True  # move the vertices onto the merged points' surface (see `snap_to_points`)
    min_points: int = 200

    def check(self) -> None:
        require_between("grid_voxels", self.grid_voxels, 0.5, 4.0)
        require_between("distance_reach_voxels", self.distance_reach_voxels, 1.0, 10.0)
        require_between("distance_lateral_voxels", self.distance_lateral_voxels, 1.0, 10.0)
        require_between("seal_voxels", self.seal_voxels, 0, 20)
        require_between("smoothing_voxels", self.smoothing_voxels, 0.0, 3.0)
        require_between("stray_neighbours", self.stray_neighbours, 0, 50)
        require_between("clump_neighbours", self.clump_neighbours, 0, 50)
        require_at_least("normal_neighbours", self.normal_neighbours, 3)
        if self.poisson_depth is not None:
            require_between("poisson_depth", self.poisson_depth, 1, 16)
        require_between("density_quantile", self.density_quantile, 0.0, 0.5)
        require_at_least("max_triangles", self.max_triangles, 100)
        require_at_least("min_points", self.min_points, 4)


@dataclass(kw_only=True)
class MeshingFigures:
    points_in: int
    points_after_outliers: int
    triangles_poisson: int | None  # None: the signed-distance surface was kept, no Poisson ran
    triangles: int
    density_trimmed: bool | None  # False: trimming would have left the mesh open, Poisson's closed surface kept


def point_tree(points: np.ndarray) -> "cKDTree":
    """A k-d tree of points on a surface (merged voxels, a mesh's vertices), built as SciPy's
    sliding-midpoint tree without shrinking its boxes: on the bench mug's 25k merged points it
    builds in 1.8 CPU-ms instead of 4.6 and answers the vertex colours' 4 nearest in 25 instead
    of 31 (the same neighbours: a k-d tree's query is exact whatever its splits)."""
    from scipy.spatial import cKDTree

    return cKDTree(points, balanced_tree=False, compact_nodes=False)


def remove_outliers(cloud: MergedCloud, options: MeshingOptions, voxel_size_m: float) -> MergedCloud:
    """The cloud less its lone strays and small clumps (stray depth at silhouettes, the odd
    mis-posed frame): points with fewer than `stray_neighbours` others within two voxels or
    fewer than `clump_neighbours` within three."""
    rules = [(others, reach) for others, reach in ((options.stray_neighbours, 2.0), (options.clump_neighbours, 3.0)) if others]
    if not rules:
        return cloud
    # Each rule's n-th other point's distance, from one query of one SciPy tree on every core
    # (Open3D's radius filter keeps the same points, and its own tree cost 1.7x the CPU time).
    radii = np.array([reach for _, reach in rules]) * voxel_size_m
    distances, _ = point_tree(cloud.points).query(
        cloud.points, k=[others + 1 for others, _ in rules], distance_upper_bound=radii.max(), workers=-1
    )
    kept = np.all(distances < radii, axis=1)
    return MergedCloud(
        points=cloud.points[kept], colors=cloud.colors[kept], view_dirs=cloud.view_dirs[kept], counts=cloud.counts[kept]
    )


def object_mesh(
    cloud: MergedCloud, cylinder: Cylinder, voxel_size_m: float, options: MeshingOptions
) -> tuple[trimesh.Trimesh, np.ndarray, MeshingFigures]:
    """A watertight-as-possible mesh in the table frame and its vertex colours (V, 3) in [0, 1]."""
    mesh, kept, figures = object_surface(cloud, cylinder, voxel_size_m, options)
    return mesh, vertex_colors(mesh, kept), figures


def object_surface(
    cloud: MergedCloud, cylinder: Cylinder, voxel_size_m: float, options: MeshingOptions
) -> tuple[trimesh.Trimesh, MergedCloud, MeshingFigures]:
    """`object_mesh`'s mesh without its colours, and the merged points the outlier filters kept
    (which `vertex_colors` takes them from)."""
    o3d = load_open3d()

    points_in = len(cloud.points)
    if points_in < options.min_points:
        raise ModelError(f"only {points_in} merged points above the table: too few for a mesh")
    cloud = remove_outliers(cloud, options, voxel_size_m)
    pcd = point_cloud(cloud.points)
    pcd.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(options.normal_neighbours))
    normals = np.asarray(pcd.normals)
    # Outward = towards the cameras that saw the point (a turntable sees no inside).
    flip = np.sum(normals * cloud.view_dirs, axis=1) < 0
    normals[flip] *= -1

    def with_footprint(inset_cells: int, spacing_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The points, their normals and weights, and the footprint's under them (each weighing as
        much as a typical merged point). A point weighs the square root of the raw points its
        voxel averaged: depth noise spreads a surface's points over the voxels along its normal,
        the tails' voxels from a point or two each, and more frames fill more of them (the bench
        mug's noisy depth, 40 / 200 frames: 0.408 / 0.431 -> 0.388 / 0.382 mm; a TUM box of 72
        frames 0.356 -> 0.294 mm; noise-free the same)."""
        weights = np.sqrt(cloud.counts)
        if not options.close_bottom:
            return cloud.points, normals, weights
        base = footprint_points(cloud.points, cylinder.z_min_m, spacing_m, inset_cells=inset_cells)
        return (
            np.concatenate([cloud.points, base]),
            np.concatenate([normals, np.tile([0.0, 0.0, -1.0], (len(base), 1))]),
            np.concatenate([weights, np.full(len(base), np.median(weights))]),
        )

    mesh, closed = None, False
    if options.surface == "distance":
        # The footprint held back from the walls by the reach: its tangent plane would carry
        # the inside out past them (a skirt round the base). The table top closes the rest.
        grid_m = voxel_size_m * options.grid_voxels
        points, point_normals, weights = with_footprint(math.ceil(options.distance_reach_voxels), grid_m)
        mesh = distance_surface(
            points,
            point_normals,
            grid_m,
            weights=weights,
            reach_voxels=options.distance_reach_voxels,
            lateral_voxels=options.distance_lateral_voxels,
            seal_voxels=options.seal_voxels,
            smoothing_voxels=options.smoothing_voxels,
            table_top=options.close_bottom,
        )
        if len(mesh.faces):
            mesh, closed = _marched_on_table_top(mesh)
            if not closed:
                mesh = repair_surface(mesh)
    triangles_poisson = trimmed = None
    if mesh is None or len(mesh.faces) == 0 or not (closed or mesh.is_watertight):  # Poisson closes: the fallback
        points, point_normals, _ = with_footprint(0, voxel_size_m)
        mesh, triangles_poisson, trimmed = _poisson_closed(points, point_normals, cloud, cylinder, voxel_size_m, options)
        if options.snap_to_points:
            mesh = snap_to_points(mesh, cloud.points, normals, voxel_size_m)
    mesh = decimate_closed(mesh, options.max_triangles)
    if len(mesh.faces) == 0:
        raise ModelError("the object's mesh is empty")
    figures = MeshingFigures(
        points_in=points_in,
        points_after_outliers=len(cloud.points),
        triangles_poisson=triangles_poisson,
        triangles=len(mesh.faces),
        density_trimmed=trimmed,
    )
    return mesh, cloud, figures


def distance_surface(
    points: np.ndarray,
    normals: np.ndarray,
    voxel_size_m: float,
    *,
    reach_voxels: float,
    seal_voxels: int,
    lateral_voxels: float | None = None,
    smoothing_voxels: float = 0.0,
    table_top: bool = False,
    weights: np.ndarray | None = None,
) -> trimesh.Trimesh:
    """Marching cubes over a signed distance on a grid of voxel-wide cells: near the points, the
    mean distance to the tangent planes, weighted by a Gaussian of the distance to each point and
    by its `weights` (default: all 1), of the points within `reach_voxels`
    and `lateral_voxels` of their normal's line (default: the reach; the merge's voxel centroids
    are already averages, so this stays on them); elsewhere the outside is what the grid's
    border reaches without crossing that band, the rest inside.
    Gaps in the band narrower than about 2 `seal_voxels` (an unseen or dark patch on a closed
    object) are closed over, so the outside cannot leak into the object. Concavities no camera
    saw into stay open (a mug's floor), where Poisson would balloon a lid across them. The field
    is smoothed by a Gaussian `smoothing_voxels` wide before marching cubes. With `table_top`,
    nothing lies below z = 0 and the outside cannot come in from under the table: the solid ends
    on the table top, closed there. The mesh may have small islands; it is empty when the
    outside leaked in after all."""
    from scipy import ndimage
    from skimage.measure import marching_cubes

    reach_m = reach_voxels * voxel_size_m
    pad = int(np.ceil(reach_voxels)) + seal_voxels + 2
    # Nodes lie half a cell off the table top (z = 0): a node exactly on a plane of points (the
    # footprint) would be exactly zero, which marching cubes meshes with holes.
    origin = np.floor(points.min(axis=0) / voxel_size_m - pad) * voxel_size_m - 0.5 * voxel_size_m
    shape = tuple(int(n) for n in np.ceil((points.max(axis=0) - origin) / voxel_size_m) + pad + 1)
    field, known = _plane_distances(
        points, normals, origin, shape, voxel_size_m, reach_voxels, lateral_voxels or reach_voxels, weights
    )
    field[known & (field == 0.0)] = 1e-9 * voxel_size_m
    # The rest (the inside, and the plugs in gaps the ball could not pass: see below) will be
    # signed like the nearest measured node: inside behind the band, the band's sides across a
    # gap. Those lie in the band's box, and so does every measured node: the transform runs
    # there alone (the padding round it is a third of the grid); beyond it, what is not outside
    # lies under the table. On another thread, beside the flood fill (SciPy lets go of the GIL).
    band = _box_of(known)
    with ThreadPoolExecutor(max_workers=1) as pool:
        nearest = pool.submit(ndimage.distance_transform_edt, ~known[band], return_distances=False, return_indices=True)
        # The outside: where a ball `seal_voxels` wide rolls in from the border without touching
        # the band (a flood fill of the band's complement, opened by that ball).
        blocked = _dilated(known, seal_voxels)
        below_table = np.zeros(shape, dtype=bool)
        if table_top:
            below_table[:, :, : max(int(round(-origin[2] / voxel_size_m + 0.5)), 0)] = True
            blocked |= below_table
        labels, _ = ndimage.label(~blocked)
        outside = labels == labels[0, 0, -1]  # the padding is free and in one piece
        outside = _dilated(outside, seal_voxels)
        nearest = nearest.result()
    nearest_sign = np.full(shape, reach_m)
    nearest_sign[band] = np.where(field[band][tuple(nearest)] >= 0, reach_m, -reach_m)
    field = np.where(known, field, np.where(outside, reach_m, nearest_sign))
    if table_top:  # the solid's intersection with the half-space above the table top
        heights = origin[2] + voxel_size_m * np.arange(shape[2])
        field = np.maximum(field, -heights)
    solid = field < 0
    if not np.any(solid):
        return trimesh.Trimesh()
    # Where the outside reaches the solid without crossing the band, the surface lies on the
    # band's inner edge, measured by no point: an unseen floor does that over a few percent of
    # the surface; a leak (a gap wider than the seal) all round the inside. Refused: the caller
    # falls back to Poisson.
    skin = _dilated(solid, 1) & ~solid
    measured = known | below_table  # the table top measures the base
    if np.count_nonzero(skin & ~measured) > _UNMEASURED_SKIN * np.count_nonzero(skin):
        return trimesh.Trimesh()
    # Smoothed and meshed in the solid's box: the smoothing carries the sign no farther than its
    # reach, so the surface lies within that of the solid (the box is half the grid).
    margin = int(4.0 * smoothing_voxels + 0.5) + 2  # gaussian_filter's radius (truncate 4), and a node more each side
    box = _box_of(solid, margin=margin)
    field = field[box]
    if smoothing_voxels > 0:  # the depth noise the voxel averages kept: fewer bumps and triangles
        field = ndimage.gaussian_filter(field, smoothing_voxels)
    # Its faces come wound outward: marching cubes winds each face the same way about the field's
    # gradient, and the solid lies below zero (no volume check needed: 5 CPU-ms on the bench mug).
    vertices, faces, _, _ = marching_cubes(field, level=0.0, spacing=(voxel_size_m,) * 3)
    corner = origin + voxel_size_m * np.array([side.start for side in box])
    # Marching cubes gives each vertex once (shared by its faces): no merging needed.
    return trimesh.Trimesh(vertices + corner, faces, process=False)


def _dilated(mask: np.ndarray, iterations: int) -> np.ndarray:
    """`mask` grown by its 6 face neighbours `iterations` times (nothing comes in from beyond
    the border): SciPy's `binary_dilation` with its default cross, bit for bit, from six shifted
    ORs of whole slices a round (the signed distance's three dilations of the bench mug's
    83 x 62 x 71 grid: 10.2 -> 1.6 CPU-ms)."""
    for _ in range(iterations):
        grown = mask.copy()
        for axis in range(mask.ndim):
            ahead = [slice(None)] * mask.ndim
            behind = [slice(None)] * mask.ndim
            ahead[axis], behind[axis] = slice(1, None), slice(None, -1)
            grown[tuple(ahead)] |= mask[tuple(behind)]
            grown[tuple(behind)] |= mask[tuple(ahead)]
        mask = grown
    return mask


def _box_of(mask: np.ndarray, margin: int = 0) -> tuple[slice, ...]:
    """The slices of the box round `mask`'s True entries, `margin` wider each side (within the array)."""
    box = []
    for axis, size in enumerate(mask.shape):
        along = np.flatnonzero(np.any(mask, axis=tuple(a for a in range(mask.ndim) if a != axis)))
        box.append(slice(max(int(along[0]) - margin, 0), min(int(along[-1]) + 1 + margin, size)))
    return tuple(box)


def _plane_distances(
    points: np.ndarray,
    normals: np.ndarray,
    origin: np.ndarray,
    shape: tuple[int, int, int],
    voxel_size_m: float,
    reach_voxels: float,
    lateral_voxels: float,
    weights: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Each grid node's Gaussian-weighted (sigma: a voxel over the square root of 2; times each
    point's `weights`, if given) mean signed distance to the tangent planes of the points within
    `reach_voxels` (and `lateral_voxels` of the normal's line), and which nodes have any. Each
    point adds itself to the nodes round it (one bin count over all points' entries), not each
    node looking for its points: a third of a k-d tree's CPU time on the bench mug."""
    reach = int(np.ceil(reach_voxels + np.sqrt(3) / 2))  # a point lies within half a cell of its nearest node
    steps = np.stack(np.meshgrid(*[np.arange(-reach, reach + 1)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    strides = np.array([shape[1] * shape[2], shape[2], 1])
    size = int(np.prod(shape))
    # In voxels and float32, nodes as int32, fewer (P, S) temporaries: 0.19 -> 0.15 CPU-s on the
    # bench mug's 26k points, the same field to 2 nm.
    nearest = np.round((points - origin) / voxel_size_m).astype(np.int64)
    to_nearest = ((origin - points) / voxel_size_m + nearest).astype(np.float32)  # from each point to its node
    index_type = np.int32 if size < 2**31 else np.int64
    point_nodes = (nearest @ strides).astype(index_type)
    point_weights = None if weights is None else np.asarray(weights, dtype=np.float32)
    reach_squared, lateral_squared = np.float32(reach_voxels**2), np.float32(lateral_voxels**2)
    # The points by the octant their node lies in, seen from them: a node offset can reach a
    # point of that octant only if it lies within the reach of the octant's half-cell box, two
    # thirds of the offsets that reach some point of any octant (the same entries, a third fewer
    # tried).
    octant = (to_nearest > 0) @ np.array([4, 2, 1])
    order = np.argsort(octant, kind="stable")
    ends = np.searchsorted(octant[order], np.arange(9))
    tasks = []
    for code in range(8):
        positive = np.array([(code >> 2) & 1, (code >> 1) & 1, code & 1], dtype=bool)
        low, high = np.where(positive, 0.0, -0.5), np.where(positive, 0.5, 0.0)  # its points' `to_nearest`
        closest = np.clip(0.0, steps + low, steps + high)  # the offset's nearest reach from that box
        octant_steps = steps[np.sum(closest**2, axis=1) <= reach_voxels**2]
        stencil = (octant_steps.astype(np.float32), (octant_steps @ strides).astype(index_type))  # (S, 3), (S,)
        group = order[ends[code] : ends[code + 1]]
        tasks += [(stencil, group[start : start + _SPLAT_CHUNK]) for start in range(0, len(group), _SPLAT_CHUNK)]

    def entries(task: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A chunk's kept (node, weight, weight x signed distance) entries."""
        (offsets, step_nodes), chunk = task
        here, normal = to_nearest[chunk], normals[chunk].astype(np.float32)
        squared = here @ (2 * offsets.T)  # (P, S): |here + offset|^2
        squared += np.sum(offsets**2, axis=1)
        squared += np.sum(here**2, axis=1)[:, None]
        values = normal @ offsets.T  # (P, S): the signed distance to the point's plane
        values += np.sum(normal * here, axis=1)[:, None]
        inside = squared <= reach_squared
        lateral = values * values
        np.subtract(squared, lateral, out=lateral)
        inside &= lateral <= lateral_squared
        # The ~20 % of the (P, S) entries kept, found once and gathered from the flat arrays.
        kept = np.flatnonzero(inside)
        point, step = np.divmod(kept, len(offsets))
        weight = np.exp(-squared.ravel()[kept])
        if point_weights is not None:
            weight *= point_weights[chunk][point]
        # As the bin counts take them (intp, float64): cast here on the two threads, not twice
        # on the main thread inside each bin count (6.5 -> 2.7 CPU-ms a count at 1M entries).
        weighted = (weight * values.ravel()[kept]).astype(np.float64)
        return (point_nodes[chunk][point] + step_nodes[step]).astype(np.intp), weight.astype(np.float64), weighted

    # On two threads: NumPy lets go of the GIL in each step of a chunk; the entries come back in
    # the tasks' order, so the sums are the same whichever thread made them.
    with ThreadPoolExecutor(max_workers=_SPLAT_THREADS) as pool:
        nodes, entry_weights, weighted = zip(*pool.map(entries, tasks))
    # One sum over all chunks (a whole-grid bin count per chunk had cost a fifth of the splat).
    nodes = np.concatenate(nodes)
    weight_sums = np.bincount(nodes, np.concatenate(entry_weights), minlength=size)
    value_sums = np.bincount(nodes, np.concatenate(weighted), minlength=size)
    known = weight_sums > 0
    field = np.zeros(size)
    field[known] = value_sums[known] / weight_sums[known] * voxel_size_m
    return field.reshape(shape), known.reshape(shape)


def _poisson_closed(
    points: np.ndarray,
    normals: np.ndarray,
    cloud: MergedCloud,
    cylinder: Cylinder,
    voxel_size_m: float,
    options: MeshingOptions,
) -> tuple[trimesh.Trimesh, int, bool]:
    """Screened Poisson of the oriented points, trimmed where weakly supported if it stays closed;
    (mesh, Poisson's triangles, whether trimmed)."""
    extent = float(np.max(np.ptp(cloud.points, axis=0)))
    depth = options.poisson_depth or int(np.clip(math.ceil(math.log2(_POISSON_SCALE * extent / voxel_size_m)), 6, 10))
    surface, densities = poisson_surface(points, normals, depth=depth, scale=_POISSON_SCALE)
    triangles_poisson = len(surface.faces)
    if triangles_poisson == 0:
        raise ModelError("Poisson reconstruction returned an empty mesh")
    vertices = surface.vertices
    # Trim unsupported surface (Poisson's closure where no camera looked) and anything
    # outside the cylinder the object stands in. The band between the footprint and the
    # lowest kept points has no points by construction: trimming it would cut the bottom off.
    weak = densities < np.quantile(densities, options.density_quantile)
    weak &= vertices[:, 2] > cylinder.z_min_m + 3 * voxel_size_m
    radial = np.hypot(vertices[:, 0] - cylinder.axis_xy_m[0], vertices[:, 1] - cylinder.axis_xy_m[1])
    kept = ~(weak | (radial > cylinder.radius_m))
    faces = surface.faces[kept[surface.faces].all(axis=1)]
    mesh = _on_table_top(trimesh.Trimesh(vertices[kept], (np.cumsum(kept) - 1)[faces]))
    # Trimming opens holes where the surface was unsupported (inside a mug, under a handle); a
    # closed solid is what collision, inertia and VoxelIOU need, so small holes are closed and,
    # if the trimmed mesh stays open, Poisson's closed surface is kept.
    trimmed = bool(len(mesh.faces))
    if trimmed:
        mesh = repair_surface(mesh)
        trimmed = mesh.is_watertight
    if not trimmed:
        mesh = repair_surface(_on_table_top(trimesh.Trimesh(vertices, surface.faces)))
    return mesh, triangles_poisson, trimmed


def snap_to_points(
    mesh: trimesh.Trimesh, points: np.ndarray, normals: np.ndarray, voxel_size_m: float
) -> trimesh.Trimesh:
    """Each vertex moved along its normal onto the tangent planes of the merged points near it
    (within two voxels, facing the same way, weighted by a Gaussian of their distance): Poisson's
    smoothing undone where there are points, its closure left where there are none. On the
    bench mug the mean distance to the truth went 0.790 -> 0.758 mm, at 0.1 s."""
    vertex_normals = mesh.vertex_normals
    distances, index = point_tree(points).query(mesh.vertices, k=8, distance_upper_bound=2 * voxel_size_m, workers=-1)
    found = np.isfinite(distances)
    index = np.where(found, index, 0)
    facing = found & (np.einsum("vd,vkd->vk", vertex_normals, normals[index]) > 0.5)
    weights = facing * np.exp(-((np.where(found, distances, 0.0) / voxel_size_m) ** 2))
    offsets = np.einsum("vkd,vkd->vk", points[index] - mesh.vertices[:, None], normals[index])
    total = weights.sum(axis=1)
    shift = np.where(total > 1e-9, (weights * offsets).sum(axis=1) / np.maximum(total, 1e-12), 0.0)
    vertices = mesh.vertices + np.clip(shift, -voxel_size_m, voxel_size_m)[:, None] * vertex_normals
    vertices[:, 2] = np.maximum(vertices[:, 2], 0.0)  # the object stands on the table top
    return trimesh.Trimesh(vertices, mesh.faces, process=False)


def _on_table_top(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """The biggest connected piece (trimming leaves islands) of a processed mesh (its
    vertices merged), flattened onto the table top: the object stands on it, so nothing lies
    below z = 0."""
    if len(mesh.faces):
        mesh = largest_piece(mesh)
    return _flattened(mesh.vertices, mesh.faces)


def _marched_on_table_top(mesh: trimesh.Trimesh) -> tuple[trimesh.Trimesh, bool]:
    """`_on_table_top` for marching cubes' mesh, and whether the piece is closed with its faces
    wound one way (each directed edge once, and its reverse once). Its pieces are found through
    shared vertices: marching cubes gives each crossing of a grid edge one vertex, so pieces
    meet at none. A quarter of trimesh's face adjacency and watertight check (6 against 26 ms on
    the bench mug's 44k triangles)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    vertices, faces = mesh.vertices, mesh.faces
    count = len(vertices)
    graph = coo_matrix(
        (np.ones(2 * len(faces), dtype=np.int8), (faces[:, :2].ravel(), faces[:, 1:].ravel())), shape=(count, count)
    )
    pieces, labels = connected_components(graph, directed=False)
    if pieces > 1:
        kept = labels == np.argmax(np.bincount(labels[faces[:, 0]]))
        vertices, faces = vertices[kept], (np.cumsum(kept) - 1)[faces[kept[faces[:, 0]]]]
        count = len(vertices)
    ends, starts = faces.ravel().astype(np.int64), faces[:, [1, 2, 0]].ravel().astype(np.int64)
    edges, reversed_edges = np.sort(starts * count + ends), np.sort(ends * count + starts)
    closed = bool(np.all(edges[1:] != edges[:-1]) and np.array_equal(edges, reversed_edges))
    return _flattened(vertices, faces), closed


def _flattened(vertices: np.ndarray, faces: np.ndarray) -> trimesh.Trimesh:
    """The mesh with nothing below z = 0: the object stands on the table top."""
    vertices = vertices.copy()
    vertices[:, 2] = np.maximum(vertices[:, 2], 0.0)
    return trimesh.Trimesh(vertices, faces, process=False)


def footprint_points(points: np.ndarray, z_min_m: float, spacing_m: float, *, inset_cells: int = 0) -> np.ndarray:
    """Points on the table top (z = 0) under the object: the outline of its lowest points,
    holes filled, eroded by `inset_cells`. Depth cannot see where the object touches the table,
    and without these Poisson leaves the bottom open or balloons below it."""
    from scipy import ndimage

    low = points[points[:, 2] < z_min_m + 4 * spacing_m]
    if len(low) < 3:
        return np.zeros((0, 3))
    origin = low[:, :2].min(axis=0) - 3 * spacing_m
    cells = np.floor((low[:, :2] - origin) / spacing_m).astype(np.int64)
    mask = np.zeros(tuple(cells.max(axis=0) + 4), dtype=bool)
    mask[cells[:, 0], cells[:, 1]] = True
    outline = ndimage.binary_closing(mask, iterations=2)
    mask = ndimage.binary_fill_holes(outline)
    if mask.sum() < 1.2 * outline.sum():
        # The outline has gaps (sparse low points at a box's corners), so nothing was enclosed:
        # its convex hull instead. Without a bottom the signed-distance surface leaks inside.
        from skimage.morphology import convex_hull_image

        mask = convex_hull_image(outline)
    if inset_cells:
        mask = ndimage.binary_erosion(mask, iterations=inset_cells)
    ii, jj = np.nonzero(mask)
    return np.column_stack([origin + (np.column_stack([ii, jj]) + 0.5) * spacing_m, np.zeros(len(ii))])


def vertex_colors(mesh: trimesh.Trimesh, cloud: MergedCloud, neighbours: int = 4, *, workers: int = -1) -> np.ndarray:
    """Colour of each vertex, (V, 3) in [0, 1]: inverse-distance mean of its nearest merged
    points, found on `workers` threads (-1: every core)."""
    distances, index = point_tree(cloud.points).query(mesh.vertices, k=neighbours, workers=workers)
    weights = 1.0 / np.maximum(distances, 1e-6)
    return np.einsum("vk,vkc->vc", weights, cloud.colors[index]) / weights.sum(axis=1, keepdims=True)
