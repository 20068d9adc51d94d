"""Where the depth camera sits beside the colour one, for a recording that does not say (a ROS
bag of the image topics alone, without /tf_static): found from a few frames. The board's table
pins two of the six unknowns' worth of turn and the offset along its normal: the depth's own
table, a plane fitted to its points on the board's disk, is turned and moved onto the plane the
board's tags give in colour's frame. The edges pin the rest: the offset along the table and a
turn about its normal that land the depth's silhouette edges on the colour image's edges. A
stereo depth camera's offset is mostly such a baseline (15 mm on a D435, 50-59 mm on a D455);
taken for none, it put the check's box 13 mm from its truth. By the edges alone (the board's
tags unseen), a sideways offset and a turn of at most 3 degrees, which an upright silhouette
pins loosely: readme_check's bottle was placed 22 mm too high, its table tilted 1.6 deg.
(An Azure Kinect's depth camera is turned ~6 degrees: its recordings give the extrinsic.)"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from turntable.board import Board
from turntable.real_frames import drop_flying_pixels, focal_px_of_rays
from turntable.recordings.depth_units import board_pose
from turntable.recordings.source import RgbdPair, StreamSetup

SAMPLE_FRAMES = 4  # spread over the recording
# The placement is taken only when its edges agree this much better than at colour's own point:
# the check's bags read 2.4-7.5x; colour whose edges are not the depth's (speckle) 1.06-1.1x at
# the best of the offsets searched, chance's, up to 80 mm off.
MIN_AGREEMENT = 1.5
# Depth points this near the board's plane (by its tags, the depth taken at colour's point: a
# baseline and a turn of a few degrees move the table less) start the fit of the depth's table;
# then those this near the fitted plane.
_TABLE_BAND_M = (0.04, 0.01, 0.005)
_MIN_TABLE_POINTS = 500
# The offsets searched: sideways (along colour's x), past any RGB-D camera's baseline; and
# across (along the table, or up), where a depth camera sits within a few mm of colour's axis.
# At 30 mm check29b's L515-like box was placed 13 mm across (the edges 8 % better there than at
# the truth) and came out 3.9 mm from its truth.
_REACH_M = (0.08, 0.008)
_EDGE_JUMP_M, _EDGE_JUMP_RELATIVE = 0.01, 0.02
_NEAR_FACTOR = 1.5  # edges kept up to this times the nearest ones' distance (their 5th percentile)
# A coarse search in steps of 2 px (at the edges' distance) on edges blurred as wide, through the
# pinhole; then 0.25 px steps within 3 px on the sharp edges, through the lens.
_COARSE_STEP_PX, _COARSE_BLUR_PX = 2.0, 2.0
_FINE_STEP_PX, _FINE_REACH_PX, _FINE_BLUR_PX = 0.25, 3.0, 1.0
_TURN_STEP_DEG, _MAX_TURN_DEG = 0.3, 3.0  # the refinement's first step and the largest turn it may find
# The edges cannot tell a turn from a sideways offset when they lie at about one distance (a
# ridge: 0.6 deg or 7.5 mm at 0.5 m align the check's box within 1 %): the refinement takes
# the least turn along it, the edges' agreement counted this much less a degree squared.
_TURN_COST_PER_DEG2 = 0.01


@dataclass
class Placement:
    color_from_depth: np.ndarray  # 4x4
    agreement: float  # the edges' agreement at it over that at no offset
    frames: int  # frames whose depth had silhouette edges
    by_table: bool  # the table pinned its tilt and height (else the edges alone placed it)


@dataclass
class _Edges:
    points: np.ndarray  # (n, 3) the foreground side of the depth's jumps, in the depth camera's frame
    sharp: np.ndarray  # colour's gradient magnitude, blurred by _FINE_BLUR_PX (the fine search)
    wide: np.ndarray  # and by _COARSE_BLUR_PX (the coarse grid)


@dataclass
class _Search:
    """The poses searched: `start` moved by `a u + b v` and turned by the angles about `axes`
    (through colour's origin)."""

    start: np.ndarray  # 4x4 color_from_depth at no offset
    u: np.ndarray  # the sideways direction searched, in colour's frame
    v: np.ndarray  # the other one
    axes: np.ndarray  # (k, 3) the turns searched

    def pose(self, x: np.ndarray) -> np.ndarray:
        """color_from_depth of (a, b offsets m, turns in degrees)."""
        from scipy.spatial.transform import Rotation

        turn = np.eye(4)
        turn[:3, :3] = Rotation.from_rotvec(np.radians(x[2:]) @ self.axes).as_matrix()
        moved = np.eye(4)
        moved[:3, 3] = x[0] * self.u + x[1] * self.v
        return moved @ turn @ self.start


def _depth_m(pair: RgbdPair, setup: StreamSetup) -> np.ndarray:
    """The pair's depth in metres in the depth camera's pixels, NaN where it reads none (0, or NaN in a float depth)."""
    depth = pair.depth.astype(np.float64)
    if pair.depth.dtype == np.uint16:
        depth *= setup.color_camera.depth_scale_m
    depth[~(depth > 0)] = np.nan
    return depth


def _edges(pair: RgbdPair, setup: StreamSetup) -> _Edges | None:
    import cv2

    depth = _depth_m(pair, setup)
    depth = drop_flying_pixels(depth, focal_px_of_rays(setup.depth_pixel_rays(), depth.shape[1]))[0].astype(np.float64)
    rays = setup.depth_pixel_rays().reshape(*depth.shape, 3)
    found = []
    with np.errstate(invalid="ignore"):
        for first, second in ((np.s_[:, :-1], np.s_[:, 1:]), (np.s_[:-1], np.s_[1:])):
            a, b = depth[first], depth[second]
            jump = np.abs(a - b) > np.maximum(_EDGE_JUMP_M, _EDGE_JUMP_RELATIVE * np.fmin(a, b))
            # The silhouette lies between the two pixels, at the nearer one's depth: the nearer
            # pixel alone sat half a depth pixel inside it (1.8 mm on readme_check's 320x240
            # depth), and the table's far rim, a one-sided edge, pulled the placement that way.
            between = 0.5 * (rays[first][jump] + rays[second][jump])
            found.append(between * np.fmin(a, b)[jump].reshape(-1, 1))
    points = np.concatenate(found)
    points = points[np.isfinite(points).all(axis=1)]
    # The nearest edges, the object's and the table's: a room's far edges barely move with the offset.
    points = points[points[:, 2] <= _NEAR_FACTOR * np.percentile(points[:, 2], 5)] if len(points) else points
    if len(points) < 50:
        return None
    gray = cv2.cvtColor(pair.color, cv2.COLOR_RGB2GRAY).astype(np.float32)
    magnitude = np.hypot(cv2.Sobel(gray, cv2.CV_32F, 1, 0), cv2.Sobel(gray, cv2.CV_32F, 0, 1))
    blurred = (cv2.GaussianBlur(magnitude, (0, 0), sigma) for sigma in (_FINE_BLUR_PX, _COARSE_BLUR_PX))
    return _Edges(points, *blurred)


def _plane(points: np.ndarray) -> tuple[np.ndarray, float]:
    """The least-squares plane n.p = d of `points` (n a unit vector)."""
    centre = points.mean(axis=0)
    normal = np.linalg.svd(points - centre, full_matrices=False)[2][2]
    return normal, float(normal @ centre)


@dataclass
class _Tables:
    """The board's table in colour's frame by its tags (normal . p = distance) and the depth's
    own table in the depth camera's frame."""

    normal: np.ndarray
    distance: float
    depth_normal: np.ndarray
    depth_distance: float

    def laid(self, color_from_depth: np.ndarray) -> np.ndarray:
        """`color_from_depth` turned the least and moved along the normal that lay the depth's
        table on the board's."""
        from scipy.spatial.transform import Rotation

        turn = Rotation.align_vectors(self.normal[None], (color_from_depth[:3, :3] @ self.depth_normal)[None])[0].as_matrix()
        laid = np.eye(4)
        laid[:3, :3] = turn @ color_from_depth[:3, :3]
        moved = turn @ color_from_depth[:3, 3]
        laid[:3, 3] = moved + self.normal * (self.distance - self.depth_distance - self.normal @ moved)
        return laid


def _tables(pairs: list[RgbdPair], setup: StreamSetup, board: Board) -> _Tables | None:
    """The board's table (the tags' normals averaged, their distances' median over the frames
    posed) and the depth's (a plane fitted to its points on the board's disk of every such
    frame); None when no frame gives both."""
    normals, distances, table = [], [], []
    for pair in pairs:
        pose = board_pose(pair.color, board, setup.color_camera)
        if pose is None:
            continue
        normal = pose.camera_from_table[:3, 2]
        points = setup.depth_pixel_rays() * _depth_m(pair, setup).reshape(-1, 1)
        points = points[np.isfinite(points).all(axis=1)]
        # Those over the board's disk, the depth taken as seen from colour's point.
        on_table = points - pose.camera_from_table[:3, 3]
        height = on_table @ normal
        over_disk = np.linalg.norm(on_table - np.outer(height, normal), axis=1) < board.radius_m
        points, height = points[over_disk], height[over_disk]
        normals.append(normal)
        distances.append(float(normal @ pose.camera_from_table[:3, 3]))
        table.append(points[np.abs(height) < _TABLE_BAND_M[0]])
    if not normals:
        return None
    points = np.concatenate(table)
    for band in _TABLE_BAND_M[1:]:
        if len(points) < _MIN_TABLE_POINTS:
            return None
        depth_normal, depth_distance = _plane(points)
        points = points[np.abs(points @ depth_normal - depth_distance) < band]
    if len(points) < _MIN_TABLE_POINTS:
        return None
    depth_normal, depth_distance = _plane(points)
    normal = np.mean(normals, axis=0)
    normal /= np.linalg.norm(normal)
    if depth_normal @ normal < 0:
        depth_normal, depth_distance = -depth_normal, -depth_distance
    return _Tables(normal, float(np.median(distances)), depth_normal, depth_distance)


def laid_on_table(pairs: list[RgbdPair], setup: StreamSetup, board: Board, color_from_depth: np.ndarray) -> np.ndarray | None:
    """A depth camera's pose given without the board (a datasheet's baseline, unturned) with its
    tilt and height taken from the board's table; None when the frames do not show it."""
    tables = _tables(pairs, setup, board)
    return None if tables is None else tables.laid(color_from_depth)


def _table_search(pairs: list[RgbdPair], setup: StreamSetup, board: Board) -> _Search | None:
    """The search with the depth's table laid on the board's (`_tables`); None when the frames
    do not show it."""
    tables = _tables(pairs, setup, board)
    if tables is None:
        return None
    normal = tables.normal
    u = np.array([1.0, 0.0, 0.0]) - normal[0] * normal  # colour's x along the table: a baseline's direction
    u /= np.linalg.norm(u)
    return _Search(start=tables.laid(np.eye(4)), u=u, v=np.cross(normal, u), axes=normal[None])


def _agreement(frames: list[_Edges], setup: StreamSetup, color_from_depth: np.ndarray) -> float:
    """The colour edges' mean strength under the depth's edges seen from `color_from_depth`."""
    camera = setup.color_camera
    total = 0.0
    for frame in frames:
        points = frame.points @ color_from_depth[:3, :3].T + color_from_depth[:3, 3]
        pixels = np.round(camera.project(points)).astype(np.int64)
        inside = (pixels[:, 0] >= 0) & (pixels[:, 0] < camera.width) & (pixels[:, 1] >= 0) & (pixels[:, 1] < camera.height)
        total += float(frame.sharp[pixels[inside, 1], pixels[inside, 0]].sum()) / len(frame.points)
    return total / len(frames)


def _coarse_best(frames: list[_Edges], setup: StreamSetup, search: _Search, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """The best offsets (a, b) on the wide edges, seen through the pinhole without the lens's
    distortion (the fine search after it projects through the lens): each column of offsets b
    at once."""
    camera = setup.color_camera
    total = np.zeros((len(xs), len(ys)))
    for frame in frames:
        started = frame.points @ search.start[:3, :3].T + search.start[:3, 3]
        along = started[:, :, None] + search.v[None, :, None] * ys[None, None, :]  # (n, 3, len(ys))
        for i, offset in enumerate(xs):
            x, y, z = (along + (offset * search.u)[None, :, None]).transpose(1, 0, 2)
            columns = np.rint(camera.fx * x / z + camera.cx).astype(np.int64)
            rows = np.rint(camera.fy * y / z + camera.cy).astype(np.int64)
            inside = (columns >= 0) & (columns < camera.width) & (rows >= 0) & (rows < camera.height)
            sampled = frame.wide[np.clip(rows, 0, camera.height - 1), np.clip(columns, 0, camera.width - 1)]
            total[i] += (sampled * inside).sum(axis=0) / len(frame.points)
    i, j = np.unravel_index(np.argmax(total), total.shape)
    return np.array([xs[i], ys[j]])


def _refined(frames: list[_Edges], setup: StreamSetup, search: _Search, offset: np.ndarray, pixel_m: float) -> np.ndarray:
    """The offsets and the turns that align the edges best, from the grids' offset: the edges
    at several distances (the object's, the table's) tell a turn from an offset. The colour
    edges sampled between pixels, for a smooth search."""
    import cv2
    from scipy.optimize import minimize

    camera = setup.color_camera

    def misalignment(x: np.ndarray) -> float:
        pose = search.pose(x)
        total = 0.0
        for frame in frames:
            pixels = camera.project(frame.points @ pose[:3, :3].T + pose[:3, 3]).astype(np.float32)
            sampled = cv2.remap(frame.sharp, pixels[:, :1], pixels[:, 1:], cv2.INTER_LINEAR, borderValue=0)
            total += float(sampled.sum()) / len(frame.points)
        return -total / len(frames) * (1.0 - _TURN_COST_PER_DEG2 * float(np.sum(x[2:] ** 2)))

    start = np.concatenate([offset, np.zeros(len(search.axes))])
    steps = np.diag([_FINE_REACH_PX * pixel_m] * 2 + [_TURN_STEP_DEG] * len(search.axes))
    found = minimize(misalignment, start, method="Nelder-Mead", options={"initial_simplex": np.vstack([start, start + steps])}).x
    return search.pose(found) if np.all(np.abs(found[2:]) <= _MAX_TURN_DEG) else search.pose(start)


def place_depth_camera(pairs: list[RgbdPair], setup: StreamSetup, board: Board | None) -> Placement | None:
    """The depth camera's pose in colour's frame that lays the depth's table on the board's (when
    the tags give it) and lands the depth's silhouette edges in `pairs` on colour edges: offsets
    searched on a grid, then refined with a turn (about the table's normal; by the edges alone,
    yaw and pitch); None when their depth shows too few edges to say."""
    frames = [edges for pair in pairs if (edges := _edges(pair, setup)) is not None]
    if not frames:
        return None
    search = None if board is None else _table_search(pairs, setup, board)
    by_edges = _Search(start=np.eye(4), u=np.array([1.0, 0, 0]), v=np.array([0, 1.0, 0]), axes=np.array([[0, 1.0, 0], [1.0, 0, 0]]))
    search, by_table = (search, True) if search is not None else (by_edges, False)
    pixel_m = float(np.median(np.concatenate([frame.points[:, 2] for frame in frames]))) / setup.color_camera.fx
    coarse = _COARSE_STEP_PX * pixel_m
    xs, ys = (np.arange(-reach, reach + coarse / 2, coarse) for reach in _REACH_M)
    found = _coarse_best(frames, setup, search, xs, ys)
    fine = np.arange(-_FINE_REACH_PX, _FINE_REACH_PX + _FINE_STEP_PX / 2, _FINE_STEP_PX) * pixel_m
    nearby = [np.array([a, b]) for a in found[0] + fine for b in found[1] + fine]
    found = max(nearby, key=lambda ab: _agreement(frames, setup, search.pose(np.concatenate([ab, np.zeros(len(search.axes))]))))
    color_from_depth = _refined(frames, setup, search, found, pixel_m)
    agreement = _agreement(frames, setup, color_from_depth) / max(_agreement(frames, setup, np.eye(4)), 1e-9)
    return Placement(color_from_depth=color_from_depth, agreement=agreement, frames=len(frames), by_table=by_table)
