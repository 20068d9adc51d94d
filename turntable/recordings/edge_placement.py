"""Where the depth camera sits beside the colour one, for a recording that does not say (a ROS
bag of the image topics alone, without /tf_static): found from a few frames, as the sideways
offset that lands the depth's silhouette edges on the colour image's edges, with a turn of at
most 3 degrees. A stereo depth camera's offset is mostly such a baseline (15 mm on a D435,
50-59 mm on a D455); taken for none, it put the check's box 13 mm from its truth. (An Azure
Kinect's depth camera is turned ~6 degrees: its recordings give the extrinsic, and a placement
past 3 degrees keeps the offset alone.)"""

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
# The depth's table, placed, within this of the plane the board's tags give. readme_check's
# bottle (320x240 depth, the camera 0.4 m out, 0.55 m up): placed 21 mm up and turned 2.2 deg,
# its table tilted 1.4-1.6 deg, a table slab; the check's five placed bags 0.17-0.53 (the
# median; a frame's 0.05-0.59: the tags' own pose ~0.5 at 1 m), the recorded pose 0.03-0.15.
MAX_TABLE_TILT_DEG = 1.0
_TABLE_BAND_M = 0.01  # depth points this near the board's plane are the table's
_REACH_M = (0.08, 0.03)  # the offsets searched, sideways and up: past any RGB-D camera's baseline
_EDGE_JUMP_M, _EDGE_JUMP_RELATIVE = 0.01, 0.02
_NEAR_FACTOR = 1.5  # edges kept up to this times the nearest ones' distance (their 5th percentile)
# A coarse search in steps of 2 px (at the edges' distance) on edges blurred as wide, through the
# pinhole; then 0.25 px steps within 3 px on the sharp edges, through the lens.
_COARSE_STEP_PX, _COARSE_BLUR_PX = 2.0, 2.0
_FINE_STEP_PX, _FINE_REACH_PX, _FINE_BLUR_PX = 0.25, 3.0, 1.0
_TURN_STEP_DEG, _MAX_TURN_DEG = 0.3, 3.0  # the refinement's first step and the largest turn it may find


@dataclass
class Placement:
    color_from_depth: np.ndarray  # 4x4: a sideways offset and a small turn (yaw, pitch)
    agreement: float  # the edges' agreement at it over that at no offset
    frames: int  # frames whose depth had silhouette edges


@dataclass
class _Edges:
    points: np.ndarray  # (n, 3) the foreground side of the depth's jumps, in the depth camera's frame
    sharp: np.ndarray  # colour's gradient magnitude, blurred by _FINE_BLUR_PX (the fine search)
    wide: np.ndarray  # and by _COARSE_BLUR_PX (the coarse grid)


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
    front = np.zeros(depth.shape, dtype=bool)
    with np.errstate(invalid="ignore"):
        for near, far, near_at, far_at in (
            (depth[:, :-1], depth[:, 1:], np.s_[:, :-1], np.s_[:, 1:]),
            (depth[:-1], depth[1:], np.s_[:-1], np.s_[1:]),
        ):
            jump = np.abs(near - far) > np.maximum(_EDGE_JUMP_M, _EDGE_JUMP_RELATIVE * np.fmin(near, far))
            front[near_at] |= jump & (near < far)
            front[far_at] |= jump & (far < near)
    points = setup.depth_pixel_rays()[front.ravel()] * depth[front].reshape(-1, 1)
    points = points[np.isfinite(points).all(axis=1)]
    # The nearest edges, the object's and the table's: a room's far edges barely move with the offset.
    points = points[points[:, 2] <= _NEAR_FACTOR * np.percentile(points[:, 2], 5)] if len(points) else points
    if len(points) < 50:
        return None
    gray = cv2.cvtColor(pair.color, cv2.COLOR_RGB2GRAY).astype(np.float32)
    magnitude = np.hypot(cv2.Sobel(gray, cv2.CV_32F, 1, 0), cv2.Sobel(gray, cv2.CV_32F, 0, 1))
    blurred = (cv2.GaussianBlur(magnitude, (0, 0), sigma) for sigma in (_FINE_BLUR_PX, _COARSE_BLUR_PX))
    return _Edges(points, *blurred)


def _agreement(frames: list[_Edges], setup: StreamSetup, offset: np.ndarray) -> float:
    """The colour edges' mean strength under the depth's edges seen from `offset` (3 m, or a
    4x4 color_from_depth)."""
    camera = setup.color_camera
    pose = offset if offset.shape == (4, 4) else np.block([[np.eye(3), offset.reshape(3, 1)], [np.zeros((1, 3)), 1.0]])
    total = 0.0
    for frame in frames:
        pixels = np.round(camera.project(frame.points @ pose[:3, :3].T + pose[:3, 3])).astype(np.int64)
        inside = (pixels[:, 0] >= 0) & (pixels[:, 0] < camera.width) & (pixels[:, 1] >= 0) & (pixels[:, 1] < camera.height)
        total += float(frame.sharp[pixels[inside, 1], pixels[inside, 0]].sum()) / len(frame.points)
    return total / len(frames)


def _best(frames: list[_Edges], setup: StreamSetup, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    offsets = [np.array([x, y, 0.0]) for x in xs for y in ys]
    return max(offsets, key=lambda offset: _agreement(frames, setup, offset))


def _coarse_best(frames: list[_Edges], setup: StreamSetup, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """The best offset on the wide edges, seen through the pinhole without the lens's distortion (the
    fine search after it projects through the lens): an offset moves each point's pixel by
    f t / z, so a column of offsets is one gather, not a projection of every point each."""
    camera = setup.color_camera
    total = np.zeros((len(xs), len(ys)))
    for frame in frames:
        x, y, z = frame.points.T
        rows = np.rint(camera.fy * (y[:, None] + ys[None, :]) / z[:, None] + camera.cy).astype(np.int64)
        row_in = (rows >= 0) & (rows < camera.height)
        rows = np.clip(rows, 0, camera.height - 1)
        for i, offset in enumerate(xs):
            columns = np.rint(camera.fx * (x + offset) / z + camera.cx).astype(np.int64)
            column_in = (columns >= 0) & (columns < camera.width)
            sampled = frame.wide[rows, np.clip(columns, 0, camera.width - 1)[:, None]]
            total[i] += (sampled * (row_in & column_in[:, None])).sum(axis=0) / len(frame.points)
    i, j = np.unravel_index(np.argmax(total), total.shape)
    return np.array([xs[i], ys[j], 0.0])


def _pose(x: np.ndarray) -> np.ndarray:
    """color_from_depth of (x, y offsets m, yaw and pitch degrees)."""
    from scipy.spatial.transform import Rotation

    color_from_depth = np.eye(4)
    color_from_depth[:3, :3] = Rotation.from_euler("yx", x[2:4], degrees=True).as_matrix()
    color_from_depth[:2, 3] = x[:2]
    return color_from_depth


def _refined(frames: list[_Edges], setup: StreamSetup, offset: np.ndarray, pixel_m: float) -> np.ndarray:
    """The offset and a small turn (yaw, pitch) that align the edges best, from the grid's offset:
    the edges at several distances (the object's, the table's) tell a turn from an offset. The
    colour edges sampled between pixels, for a smooth search."""
    import cv2
    from scipy.optimize import minimize

    camera = setup.color_camera

    def misalignment(x: np.ndarray) -> float:
        pose = _pose(x)
        total = 0.0
        for frame in frames:
            pixels = camera.project(frame.points @ pose[:3, :3].T + pose[:3, 3]).astype(np.float32)
            sampled = cv2.remap(frame.sharp, pixels[:, :1], pixels[:, 1:], cv2.INTER_LINEAR, borderValue=0)
            total += float(sampled.sum()) / len(frame.points)
        return -total / len(frames)

    start = np.array([offset[0], offset[1], 0.0, 0.0])
    steps = np.diag([_FINE_REACH_PX * pixel_m, _FINE_REACH_PX * pixel_m, _TURN_STEP_DEG, _TURN_STEP_DEG])
    found = minimize(misalignment, start, method="Nelder-Mead", options={"initial_simplex": np.vstack([start, start + steps])}).x
    return _pose(found) if np.all(np.abs(found[2:]) <= _MAX_TURN_DEG) else _pose(start)


def place_depth_camera(pairs: list[RgbdPair], setup: StreamSetup) -> Placement | None:
    """The depth camera's pose in colour's frame that lands the depth's silhouette edges in
    `pairs` on colour edges: a sideways offset searched on a grid, then refined with a small
    turn; None when their depth shows too few edges to say."""
    frames = [edges for pair in pairs if (edges := _edges(pair, setup)) is not None]
    if not frames:
        return None
    pixel_m = float(np.median(np.concatenate([frame.points[:, 2] for frame in frames]))) / setup.color_camera.fx
    coarse = _COARSE_STEP_PX * pixel_m
    xs, ys = (np.arange(-reach, reach + coarse / 2, coarse) for reach in _REACH_M)
    found = _coarse_best(frames, setup, xs, ys)
    fine = np.arange(-_FINE_REACH_PX, _FINE_REACH_PX + _FINE_STEP_PX / 2, _FINE_STEP_PX) * pixel_m
    found = _best(frames, setup, found[0] + fine, found[1] + fine)
    color_from_depth = _refined(frames, setup, found, pixel_m)
    at_none = _agreement(frames, setup, np.zeros(3))
    agreement = _agreement(frames, setup, color_from_depth) / max(at_none, 1e-9)
    return Placement(color_from_depth=color_from_depth, agreement=agreement, frames=len(frames))


def table_tilt_deg(pairs: list[RgbdPair], setup: StreamSetup, color_from_depth: np.ndarray, board: Board) -> float | None:
    """How far the depth's table, seen from `color_from_depth`, tilts against the board's plane
    by its tags: the median over the frames whose tags give a pose (a plane fitted to the depth
    points on the board's disk within _TABLE_BAND_M of it); None when none does. A depth scale
    bias moves the plane but does not tilt it."""
    tilts = []
    for pair in pairs:
        pose = board_pose(pair.color, board, setup.color_camera)
        if pose is None:
            continue
        points = setup.depth_pixel_rays() * _depth_m(pair, setup).reshape(-1, 1)
        table_from_depth = np.linalg.inv(pose.camera_from_table) @ color_from_depth
        points = points[np.isfinite(points).all(axis=1)] @ table_from_depth[:3, :3].T + table_from_depth[:3, 3]
        on = (np.hypot(points[:, 0], points[:, 1]) < board.radius_m) & (np.abs(points[:, 2]) < _TABLE_BAND_M)
        if np.count_nonzero(on) < 100:
            continue
        x, y, z = points[on].T
        slope = np.linalg.lstsq(np.column_stack([x, y, np.ones_like(x)]), z, rcond=None)[0][:2]
        tilts.append(float(np.degrees(np.arctan(np.hypot(*slope)))))
    return float(np.median(tilts)) if tilts else None
