"""Mesh operations the reconstructions share: conversions to and from Open3D, screened Poisson,
the largest connected piece, decimation, hole closing and the watertight finish.

Decimation is Open3D's quadric edge collapse, the one library for it. It was measured against
pymeshlab's (topology kept, quality threshold 0.5, as the photogrammetry finish had it) on the
meshes the tests produce:

- turntable Poisson meshes (box, cylinder, mug, with and without depth noise; 75,000-139,000
  triangles) to 80,000 and 40,000: the same mean distance to the truth within 0.002 mm, VoxelIOU
  the same or higher with Open3D (box 0.997 against 0.995), every result closed with both; the
  times alike (0.5-8.5 s, neither faster throughout);
- photogrammetry meshes: the rendered vase (22,000) to 20,000 and 10,000, closed with both and
  still closed through an OBJ read back by position; Kermit (61,000) to 40,000, 20,000 and 10,000:
  pymeshlab's finish stopped at 59,658 whatever the target (its repair left the bottom cap wound
  against the rest, and its collapse then did nothing), Open3D after `repair_surface` reached
  the target, closed;
- library meshes subdivided to 28,000-92,000 triangles (with T-junctions) to 5,000: Open3D's
  within 0.001 mm of the dense mesh, pymeshlab's 0.02-3.3 mm off.

Open3D does not guard the topology: `watertight_finish` closes what a collapse may open, and keeps
the undecimated mesh if the decimated one stays open, so a closed mesh stays closed.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import trimesh

from homemodel.core.errors import ModelError
from homemodel.geometry.open3d_loader import load_open3d

MERGE_FRACTION = 1e-4  # of the mesh's diagonal: vertices nearer than this are one (20 um on a 0.2 m vase)
MAX_HOLE_EDGES = 100  # holes bounded by more edges than this are openings, not defects


def to_open3d(mesh: trimesh.Trimesh):  # noqa: ANN201 (open3d is imported lazily)
    o3d = load_open3d()

    # int32: Open3D copies int64 faces element by element (5.7 s against 0.03 s for 330k faces).
    faces = np.ascontiguousarray(mesh.faces, dtype=np.int32)
    return o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(mesh.vertices), o3d.utility.Vector3iVector(faces))


def from_open3d(o3d_mesh) -> trimesh.Trimesh:  # noqa: ANN001
    """The Open3D mesh as a trimesh, duplicate and unreferenced vertices merged away."""
    return trimesh.Trimesh(np.asarray(o3d_mesh.vertices), np.asarray(o3d_mesh.triangles), process=True)


def point_cloud(points: np.ndarray, *, normals: np.ndarray | None = None):  # noqa: ANN201
    o3d = load_open3d()

    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.asarray(points, dtype=np.float64)))
    if normals is not None:
        cloud.normals = o3d.utility.Vector3dVector(np.asarray(normals, dtype=np.float64))
    return cloud


def poisson_surface(
    points: np.ndarray, normals: np.ndarray, *, scale: float, depth: int = 0, width_m: float = 0.0
) -> tuple[trimesh.Trimesh, np.ndarray]:
    """Screened Poisson surface (Open3D) of oriented points, as Open3D returns it (vertices not
    merged), and each vertex's density: how many points support it. The octree is `depth` levels
    deep, or (depth 0) has finest cells `width_m` wide; its cube is `scale` times the points' extent."""
    o3d = load_open3d()

    with o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error):
        # One thread: Open3D's multi-threaded Poisson segfaults now and then on a busy
        # machine (isl-org/Open3D#6828, #7229); it did here, in a test run.
        surface, densities = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(
            point_cloud(points, normals=normals), depth=depth, width=width_m, scale=scale, linear_fit=False, n_threads=1
        )
    mesh = trimesh.Trimesh(np.asarray(surface.vertices), np.asarray(surface.triangles), process=False)
    return mesh, np.asarray(densities)


def largest_piece(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """The connected piece with the most faces (Poisson and trimming leave small islands);
    `mesh` itself if it is one piece. Pieces are faces joined by shared edges, as trimesh's
    `split`, whose copy of every piece took 0.17 s on a 70k-face mesh in one piece (this: 0.05 s)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    if len(mesh.faces) == 0:
        raise ModelError("the mesh has no faces")
    pairs = mesh.face_adjacency
    count = len(mesh.faces)
    graph = coo_matrix((np.ones(len(pairs), dtype=np.int8), (pairs[:, 0], pairs[:, 1])), shape=(count, count))
    pieces, labels = connected_components(graph, directed=False)
    if pieces == 1:
        return mesh
    largest = np.argmax(np.bincount(labels))
    return mesh.submesh([np.flatnonzero(labels == largest)], append=True)


def decimate(mesh: trimesh.Trimesh, max_faces: int) -> trimesh.Trimesh:
    """`mesh` itself if it has at most `max_faces` faces, else a copy simplified to that many by
    quadric edge collapse (Open3D; see the module's note)."""
    if len(mesh.faces) <= max_faces:
        return mesh
    return from_open3d(to_open3d(mesh).simplify_quadric_decimation(target_number_of_triangles=max_faces))


def close_holes(
    mesh: trimesh.Trimesh,
    max_edges: int = MAX_HOLE_EDGES,
    closes: Callable[[np.ndarray], bool] | None = None,
) -> trimesh.Trimesh:
    """Each hole bounded by at most `max_edges` edges (and, given `closes`, whose border's vertex
    indices it accepts) closed: a triangle, or a fan around the hole's centroid, wound like the
    faces around it. A hole that passes a vertex twice is closed as two. Borders wound
    inconsistently (no loop) are left open."""
    edges = mesh.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)  # directed, in each face's winding
    border = edges[trimesh.grouping.group_rows(np.sort(edges, axis=1), require_count=1)]
    outgoing: dict[int, list[int]] = {}
    for a, b in border.tolist():
        outgoing.setdefault(a, []).append(b)
    loops = []
    for start in list(outgoing):
        walk, position = [start], {start: 0}
        while nexts := outgoing.get(walk[-1]):
            b = nexts.pop()
            if b in position:  # a loop closes: cut it off the walk
                cut = position[b]
                loops.append(walk[cut:])
                for v in walk[cut + 1 :]:
                    del position[v]
                walk = walk[: cut + 1]
            else:
                position[b] = len(walk)
                walk.append(b)
    vertices, faces = [mesh.vertices], [mesh.faces]
    for loop in loops:
        if len(loop) > max_edges or (closes is not None and not closes(np.array(loop))):
            continue
        # A border edge a -> b is matched by a new face with b -> a.
        if len(loop) == 3:
            faces.append(np.array([loop[::-1]]))
            continue
        ring = np.array(loop)
        centre = sum(len(v) for v in vertices)
        vertices.append(mesh.vertices[ring].mean(axis=0, keepdims=True))
        faces.append(np.column_stack([np.roll(ring, -1), ring, np.full(len(ring), centre)]))
    if len(faces) == 1:
        return mesh
    return trimesh.Trimesh(np.vstack(vertices), np.vstack(faces), process=False)


def merge_close_vertices(mesh: trimesh.Trimesh, distance: float) -> trimesh.Trimesh:
    """Vertices joined by a chain of steps shorter than `distance` become one (the first of
    them, where it is), so no two vertices left are that near; faces that lose a corner and
    faces made duplicates go. `mesh` itself if no two vertices are that near."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    pairs = cKDTree(mesh.vertices).query_pairs(distance, output_type="ndarray")
    if len(pairs) == 0:
        return mesh
    count = len(mesh.vertices)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(count, count))
    _, labels = connected_components(graph, directed=False)
    _, first = np.unique(labels, return_index=True)
    faces = labels[mesh.faces]
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 2] != faces[:, 0])]
    _, unique = np.unique(np.sort(faces, axis=1), axis=0, return_index=True)
    merged = trimesh.Trimesh(mesh.vertices[first], faces[np.sort(unique)], process=False)
    merged.remove_unreferenced_vertices()
    return merged


def drop_non_manifold_faces(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Where more than two faces share an edge, all but the two largest go, until no edge has
    more. `mesh` itself if none has."""
    while True:
        keys = trimesh.grouping.hashable_rows(mesh.edges_sorted)
        order = np.lexsort((-mesh.area_faces[mesh.edges_face], keys))  # by edge, the largest face first
        first = np.r_[True, keys[order][1:] != keys[order][:-1]]
        position = np.arange(len(order))
        rank = position - np.maximum.accumulate(np.where(first, position, 0))
        extra = mesh.edges_face[order[rank >= 2]]
        if len(extra) == 0:
            return mesh
        keep = np.ones(len(mesh.faces), bool)
        keep[extra] = False
        mesh = trimesh.Trimesh(mesh.vertices, mesh.faces[keep], process=False)


def repair_surface(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Vertices nearer than MERGE_FRACTION of the diagonal merged, faces on non-manifold edges
    dropped, the faces wound one way (outward where closed), holes of up to MAX_HOLE_EDGES
    edges closed."""
    if len(mesh.faces) == 0:
        raise ModelError("the mesh has no faces")
    # Marching cubes leaves edges of a micrometre or less; a file's 6 decimals would fuse their
    # ends, and a reader merging vertices by position would find holes and folds there.
    repaired = drop_non_manifold_faces(
        merge_close_vertices(mesh, MERGE_FRACTION * float(np.linalg.norm(mesh.extents)))
    )
    if not repaired.is_winding_consistent:
        # A cap cut along a self-touching outline can come out wound against the rest; holes
        # are found by following the wound border.
        o3d_mesh = to_open3d(repaired)
        o3d_mesh.orient_triangles()
        repaired = from_open3d(o3d_mesh)
    repaired = close_holes(repaired)
    if repaired is mesh:
        repaired = mesh.copy()  # the caller's mesh is left as it is
    repaired.remove_unreferenced_vertices()
    if len(repaired.faces) == 0:
        raise ModelError("the mesh has no faces after repair")
    if repaired.is_watertight and repaired.volume < 0:
        repaired.invert()  # outward: a closed solid's volume and inertia need it
    return repaired


def decimate_closed(mesh: trimesh.Trimesh, max_faces: int) -> trimesh.Trimesh:
    """`decimate`, keeping a closed mesh closed: holes a collapse opens are closed, and if the
    decimated mesh stays open, `mesh` is returned undecimated."""
    decimated = decimate(mesh, max_faces)
    if decimated is mesh:
        return mesh
    decimated = close_holes(decimated)
    return mesh if mesh.is_watertight and not decimated.is_watertight else decimated


def watertight_finish(mesh: trimesh.Trimesh, max_faces: int) -> trimesh.Trimesh:
    """`repair_surface`, then `decimate_closed` to `max_faces`."""
    return decimate_closed(repair_surface(mesh), max_faces)


# Relative to the squared size of a mesh's bounding box: below this a triangle has no area,
# whatever the units (float rounding of a real triangle stays far above).
ZERO_AREA_TOLERANCE = 1e-12


def zero_area_faces(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Boolean mask of the triangles with no area (collinear or repeated corners), relative
    to the mesh's size: the validation gate refuses them, the OBJ writer leaves them out."""
    vertices, faces = np.asarray(vertices, dtype=np.float64), np.asarray(faces)
    if len(faces) == 0:
        return np.zeros(0, dtype=bool)
    size = float(np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0)))
    corners = vertices[faces]
    doubled = np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    return 0.5 * doubled <= ZERO_AREA_TOLERANCE * size**2
