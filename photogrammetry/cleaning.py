"""The manual clean-up of D3.1 Figure 17, done automatically.

In the model frame (z up from the support plane, which is z = 0) the support surface and
everything at its height is removed, the object is the cluster of points above it nearest to
where the photos look, small disconnected pieces are dropped, and after Poisson meshing the
mesh is cut at the support plane and its bottom closed with a flat cap.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from homemodel.core.checks import require_between, require_positive
from homemodel.core.errors import ModelError
from homemodel.geometry.mesh_ops import close_holes, largest_piece, point_cloud, poisson_surface
from homemodel.geometry.open3d_loader import load_open3d
from homemodel.geometry.raycast import RayCaster
from homemodel.geometry.voxel_cells import cell_keys, group_sums


@dataclass(kw_only=True)
class CleaningOptions:
    """Lengths are fractions of the scene scale (the median camera distance to the focus point)."""

    # Find the surface the object stands on (support_plane.py) and cut it away; False keeps
    # everything the cameras converge on, the object standing on its lowest point.
    remove_support: bool = True
    roi_fraction: float = 0.6  # only points this near the focus point (where the cameras look) count
    # Without markers, only points that this share of the views have in the middle of their
    # frame (less `in_frame_margin` of its size at each border) count (convergence.py).
    min_in_frame_share: float = 0.8
    in_frame_margin: float = 0.1
    voxel_fraction: float = 0.002  # points are averaged into voxels of this size
    plane_clearance_fraction: float = 0.006  # points lower than this above the plane are the plane
    cluster_gap_fraction: float = 0.012  # points further apart than this are separate pieces
    min_piece_share: float = 0.02  # pieces with fewer points than this share of the object are dropped
    poisson_cell_voxels: float = 3.0  # the finest Poisson cells, in voxels: finer only adds noise and time
    # Poisson surface farther than this from every point is invented, not filled in: cut away.
    max_fill_fraction: float = 0.024

    def check(self) -> None:
        for name in ("roi_fraction", "voxel_fraction", "plane_clearance_fraction", "cluster_gap_fraction"):
            require_positive(name, getattr(self, name))
        require_between("min_piece_share", self.min_piece_share, 0.0, 1.0)
        require_between("min_in_frame_share", self.min_in_frame_share, 0.0, 1.0)
        require_between("in_frame_margin", self.in_frame_margin, 0.0, 0.45)
        require_positive("poisson_cell_voxels", self.poisson_cell_voxels)
        require_positive("max_fill_fraction", self.max_fill_fraction)


@dataclass(kw_only=True)
class ObjectPoints:
    points: np.ndarray  # (N, 3), model frame
    normals: np.ndarray  # (N, 3), pointing out (towards the cameras that saw them)
    colours: np.ndarray  # (N, 3), 0..1
    removed_plane_points: int
    dropped_pieces: int


def downsample(
    points: np.ndarray, colours: np.ndarray, to_camera: np.ndarray, voxel: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Average points, colours and view directions per voxel (the fusion of overlapping depth maps)."""
    _, inverse, counts = np.unique(cell_keys(points, voxel), return_inverse=True, return_counts=True)

    def mean(values: np.ndarray) -> np.ndarray:
        return group_sums(inverse, values, len(counts)) / counts[:, None]

    directions = mean(to_camera)
    directions /= np.maximum(np.linalg.norm(directions, axis=1, keepdims=True), 1e-12)
    return mean(points), mean(colours), directions


def plane_clearance(heights: np.ndarray, minimum: float) -> float:
    """How far above the plane a point must lie not to be the plane: at least `minimum`, and
    four robust standard deviations of the plane's own height noise."""
    near = heights[np.abs(heights) < 4 * minimum]
    if len(near) < 100:
        return minimum
    sigma = 1.4826 * np.median(np.abs(near - np.median(near)))
    return float(max(minimum, 4 * sigma))


def piece_labels(points: np.ndarray, gap: float, *, min_points: int = 4) -> np.ndarray:
    """Per point, its piece: points joined by steps shorter than `gap` (-1: a piece of fewer
    than `min_points`, a stray). The steps are taken between one point per cell of a grid so
    fine that points of touching cells are within `gap`: pieces that join stay joined, gaps
    never narrow, and there are a third of the points with a third of the neighbours each
    (Open3D's DBSCAN on every point took 21 s on Kermit, this 2 s)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    _, first, inverse = np.unique(cell_keys(points, gap / (2 * np.sqrt(3))), return_index=True, return_inverse=True)
    pairs = cKDTree(points[first]).query_pairs(gap, output_type="ndarray")
    count = len(first)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(count, count))
    labels = connected_components(graph, directed=False)[1][inverse]
    sizes = np.bincount(labels)
    return np.where(sizes[labels] >= min_points, labels, -1)


def segment_object(
    points: np.ndarray,
    colours: np.ndarray,
    to_camera: np.ndarray,
    focus: np.ndarray,
    scene_scale: float,
    options: CleaningOptions,
    *,
    plane_noise: float | None = None,
) -> ObjectPoints:
    """The object's points: above the plane, in the piece nearest `focus`, with outward normals.
    `plane_noise`: the support plane's own height spread where it was found (its inliers);
    None: judged from the points near z = 0, which on a cluttered scene (Kermit's legs and
    books standing on his seat) hold the object's lowest parts too."""
    o3d = load_open3d()

    minimum = options.plane_clearance_fraction * scene_scale
    if plane_noise is None:
        clearance = plane_clearance(points[:, 2], minimum)
    else:
        clearance = max(minimum, 4 * plane_noise)
    above = points[:, 2] > clearance
    removed = int((~above).sum())
    points, colours, to_camera = points[above], colours[above], to_camera[above]
    # Stray points (the tail of the plane's noise, lone mismatches) have few neighbours; a
    # surface sampled at the voxel size has about 25 within three voxels.
    voxel = options.voxel_fraction * scene_scale
    cloud = point_cloud(points)
    _, dense_enough = cloud.remove_radius_outlier(nb_points=8, radius=3 * voxel)
    points, colours, to_camera = points[dense_enough], colours[dense_enough], to_camera[dense_enough]
    if len(points) < 100:
        raise ModelError(f"only {len(points)} dense points lie above the support plane: no object to mesh")
    labels = piece_labels(points, options.cluster_gap_fraction * scene_scale)
    # The object is the piece nearest the point the cameras look at; others (background
    # furniture, a cable, a stray mismatch) are dropped.
    pieces = [label for label in np.unique(labels) if label >= 0]
    if not pieces:
        raise ModelError("the dense points above the support plane form no object")
    distances = {label: np.min(np.linalg.norm(points[labels == label] - focus, axis=1)) for label in pieces}
    sizes = {label: int((labels == label).sum()) for label in pieces}
    nearest = min(pieces, key=lambda label: distances[label] / np.sqrt(sizes[label]))
    keep = labels == nearest
    # Pieces touching the object's bounding box that are large enough are parts of it (a handle).
    lo, hi = points[keep].min(axis=0), points[keep].max(axis=0)
    margin = options.cluster_gap_fraction * scene_scale * 2
    for label in pieces:
        if label == nearest or sizes[label] < options.min_piece_share * keep.sum():
            continue
        inside = np.all((points[labels == label] > lo - margin) & (points[labels == label] < hi + margin), axis=1)
        if inside.mean() > 0.5:
            keep |= labels == label
    cloud = point_cloud(points[keep])
    cloud.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(knn=24))
    normals = np.asarray(cloud.normals)
    flip = np.sum(normals * to_camera[keep], axis=1) < 0
    normals[flip] *= -1
    return ObjectPoints(
        points=points[keep],
        normals=normals,
        colours=colours[keep],
        removed_plane_points=removed,
        dropped_pieces=len(pieces) - len(np.unique(labels[keep])),
    )


# Sides about the object's centre whose lowest points each give the footprint.
FLOOR_SECTORS = 36


def floor_points(points: np.ndarray, *, spacing: float, inset: float, base_share: float = 0.1) -> np.ndarray:
    """Points on z = 0 filling the object's footprint (the convex hull of each side's lowest
    tenth in height, the sides FLOOR_SECTORS sectors about the centre), set in by `inset`: the
    bottom no photo sees, stated so that Poisson closes it flat, not in a bulge. Per side,
    because one side may be seen only high up (the rendered vase: from 36 mm, the other side
    from 3 mm): the lowest tenth of all points then outlined half the base, the rest bulged open."""
    from scipy.spatial import ConvexHull, QhullError

    offsets = points[:, :2] - points[:, :2].mean(axis=0)
    angle = np.arctan2(offsets[:, 1], offsets[:, 0])
    sector = np.minimum(((angle + np.pi) / (2 * np.pi) * FLOOR_SECTORS).astype(int), FLOOR_SECTORS - 1)
    lowest = np.full(FLOOR_SECTORS, np.inf)
    np.minimum.at(lowest, sector, points[:, 2])
    base = points[points[:, 2] <= lowest[sector] + base_share * np.ptp(points[:, 2])][:, :2]
    try:
        hull = ConvexHull(base)
    except (QhullError, ValueError):
        return np.zeros((0, 3))
    lo, hi = base.min(axis=0), base.max(axis=0)
    x, y = np.meshgrid(np.arange(lo[0], hi[0], spacing), np.arange(lo[1], hi[1], spacing))
    grid = np.column_stack([x.ravel(), y.ravel()])
    # Inside a convex polygon: on the inner side of every edge's line.
    inside = grid[np.all(grid @ hull.equations[:, :2].T + hull.equations[:, 2] <= -inset, axis=1)]
    return np.column_stack([inside, np.zeros(len(inside))])


def near_samples(
    surface: trimesh.Trimesh, samples: np.ndarray, distance: float, *, band_top: float
) -> trimesh.Trimesh:
    """The faces of `surface` whose corners all lie within `distance` of a sample point. Below
    `band_top` (the object's lowest point: nothing was kept between it and the floor at z = 0)
    a corner is judged as if raised to it, by how far it is across, not up."""
    from scipy.spatial import cKDTree

    corners = surface.vertices.copy()
    corners[:, 2] = np.maximum(corners[:, 2], band_top)
    gap, _ = cKDTree(samples).query(corners, distance_upper_bound=distance, workers=-1)
    supported = np.isfinite(gap)
    return trimesh.Trimesh(surface.vertices, surface.faces[supported[surface.faces].all(axis=1)], process=True)


def mesh_object(obj: ObjectPoints, scene_scale: float, options: CleaningOptions) -> trimesh.Trimesh:
    """Poisson surface of the object's points, cut at the support plane and closed at the bottom."""
    voxel = options.voxel_fraction * scene_scale
    # The floor's rim set in by two Poisson cells: stated out to an unseen wall's radius (the
    # rendered vase, a side seen from 36 mm up) Poisson swelled the corner 7 mm beyond the wall.
    floor = floor_points(obj.points, spacing=voxel, inset=2 * options.poisson_cell_voxels * voxel)
    samples = np.vstack([obj.points, floor])
    normals = np.vstack([obj.normals, np.tile([0.0, 0.0, -1.0], (len(floor), 1))])
    surface, _ = poisson_surface(samples, normals, width_m=options.poisson_cell_voxels * voxel, scale=1.1)
    # Poisson pins its surface down only near the points. Where the photos saw one side (Kermit:
    # an arrangement seen from the front) the surface runs on to the faces of the octree's cube,
    # whose size doubles when the points' extent crosses a power of two of the cell width: the
    # same scene came out closed and room-sized in one run, half as large in the next.
    reach = options.max_fill_fraction * scene_scale
    mesh = near_samples(surface, samples, reach, band_top=obj.points[:, 2].min())
    if len(mesh.faces) == 0:
        raise ModelError("the Poisson surface lies nowhere near the object's points")
    # Poisson closes the surface below the object, where no photo saw it, with a smooth bulge
    # through the support plane: cut it at the plane and close the cut with a flat cap.
    mesh = mesh.slice_plane(np.zeros(3), np.array([0.0, 0.0, 1.0]), cap=True)
    if len(mesh.faces) == 0:
        raise ModelError("the Poisson surface lies entirely below the support plane")
    piece = largest_piece(mesh)
    return close_bottom_holes(piece, top=BOTTOM_HOLE_SHARE * piece.bounds[1, 2])


# A hole whose border stays below this share of the object's height is its unseen bottom.
BOTTOM_HOLE_SHARE = 0.5


def close_bottom_holes(mesh: trimesh.Trimesh, top: float) -> trimesh.Trimesh:
    """`mesh` with each hole whose border stays below `top` closed by a fan, whatever its size.
    The cap closes only the cut's own outlines. Where a side was seen only high up (the
    rendered vase: one side's points start 36 mm above the plane) the trim removes the surface
    there, and the cut meets that hole: 134 edges, beyond what the repair closes as a defect.
    A higher opening (the back of Kermit, seen from the front) is left open: a fan across it
    was most of the surface, a median 4.5 times further from the points."""
    # A 3-edge hole is a defect of the surface, not its bottom: one triangle, at any height.
    return close_holes(
        mesh, max_edges=len(mesh.vertices), closes=lambda ring: len(ring) == 3 or mesh.vertices[ring, 2].max() <= top
    )


# Rays cast from each camera towards its faces by `face_the_cameras`: Buddha's 67 views, 33,500
# rays, on a 100,000-face mesh in a tenth of a second.
FACING_RAYS_PER_CAMERA = 500


def face_the_cameras(mesh: trimesh.Trimesh, centres: np.ndarray) -> trimesh.Trimesh:
    """`mesh`, or it inverted when most of what the cameras at `centres` (N, 3) see first of it
    faces away from them. Rays go from each camera towards points of the mesh (area-weighted);
    the face each ray meets first is one the camera sees, and it faces the camera unless the
    winding is inverted. A surface seen from one side (Kermit on his chair) or with holes is
    open: it has no inside to wind it outward from, and the repair's Open3D `orient_triangles`
    winds it either way; Kermit with two photos of broken EXIF came out inside out, and the
    texture, baked only where a view faces the surface, covered 13 % of the atlas instead of
    79 %. Counting the cameras on each face's front side is no vote: cameras all round an
    object have most of them behind any one face (Buddha's lowest band, open at the crown, came
    out with 0 % of the first hits facing the cameras). A closed mesh is already wound outward
    and is returned as it is."""
    if mesh.is_watertight or not mesh.area > 0:  # closed; or nothing to see (area 0: no face to aim at)
        return mesh
    rng = np.random.default_rng(0)  # the same mesh is faced the same way every run
    caster = RayCaster(mesh)
    targets = mesh.triangles_center[rng.choice(len(mesh.faces), (len(centres), FACING_RAYS_PER_CAMERA), p=mesh.area_faces / mesh.area)]
    directions = targets - centres[:, None, :]
    directions = (directions / np.linalg.norm(directions, axis=2, keepdims=True)).reshape(-1, 3)
    hits = caster.first_hits(np.repeat(centres, FACING_RAYS_PER_CAMERA, axis=0), directions)
    facing = np.einsum("ij,ij->i", mesh.face_normals[hits.triangle[hits.hit]], -directions[hits.hit]) > 0
    if 2 * facing.sum() >= len(facing):
        return mesh
    inverted = mesh.copy()
    inverted.invert()
    return inverted
