"""A UV atlas in time linear in the faces: charts projected flat along the direction they
face, packed in shelves; the photo texture and the turntable's baked vertex colours use it.

xatlas took 2.7 CPU-s on Kermit's 34k faces and 6.2 on 138k, this 0.4 and 1.5 (the visual
mesh may hold 500k); its charts fill less of the texture (31 % against xatlas's 46 % on Kermit:
0.83 of its texels per metre). Here every face goes to the one of 14
directions (the cube's faces and corners) it faces most nearly (no face is more than 37
degrees off), then the direction most of its neighbours have (up to MAX_CHART_ANGLE_DEG off:
each face keeps at least half its area in the projection). Faces of one
direction in one square tile of the model, joined by shared edges, are a chart: the tile
keeps a chart small enough that a surface curling over itself (which a projection would
fold onto itself) is rare. Every chart gets the same texels per metre, the most that the
shelves fit into the texture.
"""

from __future__ import annotations

import bisect

import numpy as np
import trimesh

from homemodel.core.errors import ModelError
from homemodel.geometry.uv_atlas import Atlas

_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], np.float64) / np.sqrt(3)
DIRECTIONS = np.vstack([np.eye(3), -np.eye(3), _CORNERS])
MAX_CHART_ANGLE_DEG = 60.0  # a face joins its neighbours' chart only while it faces it this squarely
TILES_PER_SIDE = 8  # tiles along the mesh's longest side


def _plane_axes(direction: np.ndarray) -> np.ndarray:
    """Two unit axes (2, 3) spanning the plane perpendicular to `direction`, right-handed with it."""
    helper = np.array([0.0, 0.0, 1.0]) if abs(direction[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    a = np.cross(helper, direction)
    a /= np.linalg.norm(a)
    return np.stack([a, np.cross(direction, a)])


AXES = np.stack([_plane_axes(d) for d in DIRECTIONS])  # (14, 2, 3)


def _smoothed_directions(mesh: trimesh.Trimesh, rounds: int = 6) -> np.ndarray:
    """Per face the direction its neighbourhood faces most nearly, where the face itself still
    faces it within MAX_CHART_ANGLE_DEG (else its own nearest): the normals are averaged with
    the edge neighbours' a few rounds over, and then each face takes the direction most of it
    and its neighbours have. A reconstructed surface's noisy normals would otherwise scatter
    it into thousands of one-face charts (2,300 of Kermit's 3,300)."""
    count = len(mesh.faces)
    pairs = mesh.face_adjacency
    neighbours = np.full((count, 4), -1, np.int64)  # itself and up to three across its edges
    neighbours[:, 0] = np.arange(count)
    a, b = np.concatenate([pairs[:, 0], pairs[:, 1]]), np.concatenate([pairs[:, 1], pairs[:, 0]])
    order = np.argsort(a, kind="stable")
    a, b = a[order], b[order]
    slot = np.arange(len(a)) - np.searchsorted(a, a)  # 0, 1, 2 within each face's run
    fits = slot < 3
    neighbours[a[fits], 1 + slot[fits]] = b[fits]
    present = neighbours >= 0
    neighbours = np.maximum(neighbours, 0)
    facing = mesh.face_normals @ DIRECTIONS.T
    allowed = facing >= np.cos(np.radians(MAX_CHART_ANGLE_DEG))
    nearest = np.argmax(facing, axis=1)

    def fit(direction: np.ndarray) -> np.ndarray:
        return np.where(np.take_along_axis(allowed, direction[:, None], axis=1)[:, 0], direction, nearest)

    # A missing neighbour reads a zero row; the slots are added in order, as a sum over them would.
    smooth = np.vstack([mesh.face_normals * mesh.area_faces[:, None], np.zeros((1, 3))])
    padded = np.where(present, neighbours, count)
    for _ in range(rounds):
        smooth[:count] = smooth[padded[:, 0]] + smooth[padded[:, 1]] + smooth[padded[:, 2]] + smooth[padded[:, 3]]
    direction = fit(np.argmax(smooth[:count] @ DIRECTIONS.T, axis=1))
    for _ in range(rounds):
        labels = direction[neighbours]
        # Each slot's votes: the slots (itself included) holding its label; none for a missing
        # neighbour or a label the face may not take.
        votes = np.zeros((count, 4), np.int8)
        for k in range(4):
            votes += (labels == labels[:, k, None]) & present[:, k, None]
        votes[~present | ~np.take_along_axis(allowed, labels, axis=1)] = 0
        choice = fit(np.take_along_axis(labels, np.argmax(votes, axis=1)[:, None], axis=1)[:, 0])  # ties: its own first
        if np.array_equal(choice, direction):
            break  # a round is a function of the directions alone: the rest would not change them
        direction = choice
    return direction


def _charts(mesh: trimesh.Trimesh, tile: float) -> tuple[np.ndarray, np.ndarray]:
    """Per face its chart (0..C-1) and its corners' flat coordinates (F, 3, 2) in the chart's plane."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    direction = _smoothed_directions(mesh)
    flat = np.einsum("fkd,fad->fka", mesh.triangles, AXES[direction])  # (F, 3 corners, 2)
    key = np.column_stack([direction, np.floor(flat.mean(axis=1) / tile).astype(np.int64)])  # direction, tile
    pairs = mesh.face_adjacency
    pairs = pairs[np.all(key[pairs[:, 0]] == key[pairs[:, 1]], axis=1)]
    count = len(mesh.faces)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(count, count))
    return connected_components(graph, directed=False)[1], flat


def _shelf_pack(sizes: np.ndarray, width: int) -> tuple[np.ndarray, int]:
    """Top-left corners (C, 2) of boxes `sizes` (C, 2: width, height in texels) laid in rows of
    at most `width`, tallest first, and the height used (inf when a box is wider than `width`)."""
    if sizes[:, 0].max() > width:
        return np.zeros((len(sizes), 2), np.int64), np.inf
    order = np.argsort(-sizes[:, 1], kind="stable")
    widths, heights = sizes[order, 0], sizes[order, 1]
    ends = np.cumsum(widths)  # where each box ends if all were in one row
    # One row at a time: the boxes that fit after the row's first. On Python ints, as the
    # bisection lays the charts out some 20 times.
    ends_list, widths_list = ends.tolist(), widths.tolist()
    starts = []
    start = 0
    while start < len(order):
        starts.append(start)
        start = bisect.bisect_right(ends_list, ends_list[start] - widths_list[start] + width)
    row_heights = heights[starts]  # the tallest first
    row = np.repeat(np.arange(len(starts)), np.diff(starts + [len(order)]))
    corners = np.zeros((len(sizes), 2), np.int64)
    corners[order, 0] = ends - widths - (ends - widths)[starts][row]
    corners[order, 1] = (np.cumsum(row_heights) - row_heights)[row]
    y = int(row_heights.sum())
    return corners, y


def chart_atlas(mesh: trimesh.Trimesh, *, size_px: int, padding_px: int) -> Atlas:
    """Charts of `mesh` packed into a `size_px` square texture, `padding_px` texels apart (less
    when they do not fit so), all at one texel density: the largest that fits (a bisection
    over the shelf packing)."""
    if len(mesh.faces) == 0:
        raise ModelError("cannot lay out a texture for a mesh without faces")
    tile = float(np.max(mesh.extents)) / TILES_PER_SIDE
    chart, flat = _charts(mesh, tile)
    count = int(chart.max()) + 1
    low = np.full((count, 2), np.inf)
    high = np.full((count, 2), -np.inf)
    np.minimum.at(low, chart, flat.min(axis=1))
    np.maximum.at(high, chart, flat.max(axis=1))
    extent = high - low

    def layout(texels_per_unit: float, padding: int) -> tuple[np.ndarray, int]:
        return _shelf_pack(np.ceil(extent * texels_per_unit).astype(np.int64) + 1 + 2 * padding, size_px)

    # The density that would fill the texture with no gaps at all is an upper bound. A small
    # texture for many charts is laid out with less padding than asked, down to none.
    for padding in sorted({padding_px, min(padding_px, 1), 0}, reverse=True):
        lower, upper = 0.0, np.sqrt(size_px**2 / max(float(np.sum(np.prod(extent, axis=1))), 1e-300))
        for _ in range(20):
            middle = (lower + upper) / 2
            lower, upper = (middle, upper) if layout(middle, padding)[1] <= size_px else (lower, middle)
        if lower > 0.0:
            break
    else:
        raise ModelError(f"{count} charts do not fit a {size_px} px texture: give a larger texture size")
    corners, _ = layout(lower, padding)
    # Texel coordinates (texel centres at whole numbers) of every face corner.
    pixels = (flat - low[chart][:, None, :]) * lower + (corners[chart] + padding)[:, None, :]
    # One vertex per (chart, vertex): a vertex on a chart's border is copied into each chart.
    keys = chart[:, None].astype(np.int64) * len(mesh.vertices) + mesh.faces
    unique, first, faces = np.unique(keys.ravel(), return_index=True, return_inverse=True)
    source = (unique % len(mesh.vertices)).astype(np.int64)
    corner_pixels = pixels.reshape(-1, 2)[first]
    uv = np.column_stack([(corner_pixels[:, 0] + 0.5) / size_px, 1 - (corner_pixels[:, 1] + 0.5) / size_px])
    split = trimesh.Trimesh(mesh.vertices[source], faces.reshape(-1, 3), process=False)
    return Atlas(mesh=split, uv=uv, source_vertex=source)
