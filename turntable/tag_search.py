"""How a capture's frames are searched for tags. The camera is fixed and the board turns in
the table's plane, so every frame shows the tags at about the same sizes and inside the same
part of the image: one frame's pose sets AprilTag's decimation and a window of the image to
search. A frame whose pose shows a tag the window cut off, or which gives no pose, is searched
again over the whole image, and then at full resolution, so the window and the decimation
only save time (on the 640 x 480 bench mug: the window is 35 % of the image).

Most frames need no search at all: the table turns evenly, so the last two frames' poses
predict the next one's (the same turn again) and with it where every tag falls (`tracked_pose`).
A predicted tag counts only where the image shows its code there (`BoardCodes`): the object
hiding it, or a prediction off by more than a fraction of a cell, fails that. Its predicted
corners are then refined on the image's edges as a detected tag's are, and again from where
the pose puts them if the prediction was off: the refinement leans towards where it starts (on
the bench mug, predictions turned 0.1 / 0.2 / 0.4 degrees off gave poses 0.24 / 0.36 / 0.53 mm
from the truth after one pass, 0.13 / 0.15 / 0.18 after two; the search's 0.19). A frame whose
prediction leaves too few tags or a pose that fits worse than `_TRACKED_RMS_PX` is searched."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from homemodel.geometry.camera import Camera
from turntable.board import TAG_CELLS, Board, tag_bits
from turntable.pose import FramePose, PoseOptions, PoseSkip, estimate_camera_from_table, pose_from_corners
from turntable.tags import LINEAR_LEVELS, DetectionOptions, PixelWindow, bilinear_levels, detect_tags, refined_edges

_COARSE_DECIMATION = 1.5
_COARSE_TAG_PX = 18.0  # the tags' tenth-percentile size (square root of the area) it needs
# The window holds the board turned about any axis this far from its origin (a fraction of the
# board's radius: 1.9 cm on the bench's 40 cm table): the axis is not known before the poses are.
_AXIS_OFFSET_FRACTION = 0.1
_WINDOW_MARGIN_PX = 4  # round the board's outline in the image
_WHOLE_IMAGE_FRACTION = 0.8  # a window larger than this part of the image saves too little: none
_TRACKED_MIN_SIDE_PX = 12.0  # predicted tags smaller than this are left to the search (cells under 1.5 px)
_TRACKED_MIN_CONTRAST = 0.1  # of the 8-bit range, between a predicted tag's white and black cells
_TRACKED_FRACTION = 0.5  # of the tags predicted in the image, the least a prediction must confirm
_TRACKED_RMS_PX = 1.0  # a pose from predicted tags fitting worse than this is searched for instead
# Corners refined from a prediction this far (RMS) from where the pose puts them are refined again
# from there, once (the bench mug's predictions: 0.04 px median, 0.08 at the 90th percentile).
_TRACKED_START_PX = 0.15


@dataclass(frozen=True, kw_only=True)
class BoardCodes:
    """What each board tag looks like, in the table frame: its corners and the centres of its
    10 x 10 cells (the 8 x 8 black square and the white ring round it), white or not."""

    ids: np.ndarray  # (T,)
    corners_m: np.ndarray  # (T, 4, 3) ArUco order
    cells_m: np.ndarray  # (T, 100, 3)
    white: np.ndarray  # (T, 100) bool


@dataclass(frozen=True, kw_only=True)
class TagSearch:
    detection: DetectionOptions
    window: PixelWindow | None = None  # None: the whole image
    codes: BoardCodes | None = None  # the board's tags, to confirm predicted ones; None: no prediction


def board_codes(board: Board) -> BoardCodes:
    table = board.corners_table()
    ids = np.array(sorted(table))
    corners = np.stack([table[i] for i in ids])
    # Cell (row, column) of the square, -1 and 8 being the white ring; row 0 is the top row, at
    # the top-left corner's side (+y), column 0 at its x (see `turntable.board`).
    steps = (np.arange(-1, TAG_CELLS + 1) + 0.5) / TAG_CELLS
    rows, cols = np.meshgrid(steps, steps, indexing="ij")
    top_left, right, down = corners[:, 0], corners[:, 1] - corners[:, 0], corners[:, 3] - corners[:, 0]
    cells = top_left[:, None] + cols.reshape(1, -1, 1) * right[:, None] + rows.reshape(1, -1, 1) * down[:, None]
    white = np.ones((len(ids), TAG_CELLS + 2, TAG_CELLS + 2), dtype=bool)
    for k, tag_id in enumerate(ids):
        white[k, 1:-1, 1:-1] = tag_bits(int(tag_id))
    return BoardCodes(ids=ids, corners_m=corners, cells_m=cells, white=white.reshape(len(ids), -1))


def predicted_pose(before: np.ndarray, last: np.ndarray) -> np.ndarray:
    """camera_from_table of the frame after two consecutive frames': the table turned again by
    as much as between them."""
    return last @ np.linalg.inv(before) @ last


def tracked_pose(
    gray: np.ndarray,
    predicted: np.ndarray,
    codes: BoardCodes,
    camera: Camera,
    detection: DetectionOptions,
    options: PoseOptions,
) -> FramePose | None:
    """The frame's pose from the tags a predicted camera_from_table puts in the image and the
    image confirms (each tag's 100 cells on the side of the midway level its code says, up to
    `max_hamming` not), with their corners refined; None when the prediction does not hold."""
    rotation, shift = predicted[:3, :3], predicted[:3, 3]
    in_camera = codes.corners_m @ rotation.T + shift
    front = np.flatnonzero(np.all(in_camera[..., 2] > 0, axis=1))
    if len(front) < options.min_tags:
        return None
    corners = camera.project(in_camera[front].reshape(-1, 3)).reshape(-1, 4, 2)
    side_px = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=-1)
    margin = np.maximum(2.0, 0.2 * side_px.max(axis=1))[:, None]  # the edge refinement's reach
    inside = PixelWindow(top=0, bottom=camera.height, left=0, right=camera.width).holds(corners, margin)
    seen = np.all(inside, axis=1) & (side_px.min(axis=1) >= _TRACKED_MIN_SIDE_PX)
    tags, corners = front[seen], corners[seen]
    if len(tags) < options.min_tags:
        return None
    cells = camera.project((codes.cells_m[tags] @ rotation.T + shift).reshape(-1, 3)).reshape(len(tags), -1, 2)
    levels = bilinear_levels(gray, LINEAR_LEVELS["linear"], cells[..., 0], cells[..., 1])
    white = codes.white[tags]
    bright = np.sum(levels * white, axis=1) / np.sum(white, axis=1)
    dark = np.sum(levels * ~white, axis=1) / np.sum(~white, axis=1)
    wrong = np.sum((levels > ((bright + dark) / 2)[:, None]) != white, axis=1)
    shown = (wrong <= detection.max_hamming) & (bright - dark >= _TRACKED_MIN_CONTRAST)
    if np.count_nonzero(shown) < max(options.min_tags, _TRACKED_FRACTION * len(tags)):
        return None
    tags, corners = tags[shown], corners[shown]
    for second in (False, True):
        refined, clear = refined_edges(gray, corners, LINEAR_LEVELS[detection.intensity])
        whole = np.all(clear, axis=1)
        try:
            table_points, image_points = codes.corners_m[tags[whole]].reshape(-1, 3), refined[whole].reshape(-1, 2)
            pose = pose_from_corners(table_points, image_points, camera, options, near=predicted)
        except PoseSkip:
            return None
        # The refinement leans towards where it started (its profiles' ends are taken as the
        # black and white levels): if that was off, it starts again where the pose puts the corners.
        in_camera = codes.corners_m[tags] @ pose.camera_from_table[:3, :3].T + pose.camera_from_table[:3, 3]
        fitted = camera.project(in_camera.reshape(-1, 3)).reshape(-1, 4, 2)
        if second or np.sqrt(np.mean(np.sum((fitted - corners) ** 2, axis=-1))) <= _TRACKED_START_PX:
            break
        predicted, corners = pose.camera_from_table, fitted
    return pose if pose.reprojection_error_px <= _TRACKED_RMS_PX else None


def tag_decimation(board: Board, camera: Camera, camera_from_table: np.ndarray) -> float:
    """AprilTag's decimation for a capture, from one frame's pose: the board's tags seen in
    that frame, projected, are large enough or not for a 1.5 x coarser search. On the 640 x 480
    mug (tags' tenth percentile 20 px) it halves the detection's time, losing 2 % of the tags,
    none of the poses' accuracy; half again (2 x) lost 40 %."""
    corners = np.stack(list(board.corners_table().values()))  # (T, 4, 3)
    in_camera = corners @ camera_from_table[:3, :3].T + camera_from_table[:3, 3]
    in_front = np.all(in_camera[..., 2] > 0, axis=1)
    if not np.any(in_front):
        return 1.0
    pixels = camera.project(in_camera[in_front].reshape(-1, 3)).reshape(-1, 4, 2)
    x, y = pixels[..., 0], pixels[..., 1]
    area = 0.5 * np.abs(np.sum(x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y, axis=1))
    sizes = np.sqrt(area[np.all(_in_image(pixels, camera), axis=1)])
    return _COARSE_DECIMATION if len(sizes) and np.percentile(sizes, 10) >= _COARSE_TAG_PX else 1.0


def tag_window(board: Board, camera: Camera, camera_from_table: np.ndarray) -> PixelWindow | None:
    """The part of the image the board's tags can reach as the table turns, seen from one
    frame's pose: the box round the table-top circle holding every tag corner turned about an
    axis near the board's origin. None when that is most of the image or reaches behind the
    camera."""
    corners = np.concatenate(list(board.corners_table().values()))[:, :2]
    reach = float(np.max(np.linalg.norm(corners, axis=1)))
    radius = reach * (1 + 2 * _AXIS_OFFSET_FRACTION)  # a corner turned about an axis at `a` stays within reach + 2 |a|
    angles = np.linspace(0.0, 2 * np.pi, 180, endpoint=False)
    circle = np.column_stack([radius * np.cos(angles), radius * np.sin(angles), np.zeros(len(angles))])
    in_camera = circle @ camera_from_table[:3, :3].T + camera_from_table[:3, 3]
    if np.any(in_camera[:, 2] <= 0.05 * np.max(in_camera[:, 2])):  # behind or grazing the camera
        return None
    pixels = camera.project(in_camera)
    left, top = np.floor(pixels.min(axis=0)).astype(int) - _WINDOW_MARGIN_PX
    right, bottom = np.ceil(pixels.max(axis=0)).astype(int) + _WINDOW_MARGIN_PX + 1
    window = PixelWindow(
        top=max(int(top), 0), bottom=min(int(bottom), camera.height), left=max(int(left), 0), right=min(int(right), camera.width)
    )
    area = (window.bottom - window.top) * (window.right - window.left)
    if window.bottom - window.top < 8 or window.right - window.left < 8:
        return None
    return window if area < _WHOLE_IMAGE_FRACTION * camera.width * camera.height else None


def capture_search(
    board: Board, camera: Camera, camera_from_table: np.ndarray, detection: DetectionOptions, *, predict: bool = True
) -> TagSearch:
    """The search for a capture's frames from one frame's pose: the decimation, unless the
    options fix it, the window, and the board's codes when frames' tags may be predicted (a
    predicted tag's corners are only as good as their edge refinement: none without it)."""
    if detection.decimate is None:
        detection = replace(detection, decimate=tag_decimation(board, camera, camera_from_table))
    window = tag_window(board, camera, camera_from_table)
    codes = board_codes(board) if predict and detection.edge_refinement else None
    return TagSearch(detection=detection, window=window, codes=codes)


def frame_pose(
    gray: np.ndarray,
    search: TagSearch,
    board: Board,
    camera: Camera,
    options: PoseOptions,
    predicted: np.ndarray | None = None,
) -> FramePose:
    """`camera_from_table` of one frame from the tags a `predicted` camera_from_table shows, if
    given and the search has the board's codes (see `tracked_pose`); else searched in the window
    first, then over the whole image if the window gave no pose or cut off a tag the pose shows
    in the image, then at full resolution if the coarse search gave no pose; raises PoseSkip."""
    if predicted is not None and search.codes is not None:
        pose = tracked_pose(gray, predicted, search.codes, camera, search.detection, options)
        if pose is not None:
            return pose
    attempts = [search]
    if search.window is not None:
        attempts.append(replace(search, window=None))
    if (search.detection.decimate or 1.0) > 1.0:
        attempts.append(TagSearch(detection=replace(search.detection, decimate=1.0)))
    skip: PoseSkip | None = None
    for attempt in attempts:
        try:
            pose = estimate_camera_from_table(detect_tags(gray, attempt.detection, attempt.window), board, camera, options)
        except PoseSkip as exc:
            skip = exc
            continue
        if attempt.window is None or not _cut_off(pose, attempt.window, board, camera):
            return pose
    assert skip is not None  # the last attempt searches the whole image, so it returned or skipped
    raise skip


def _cut_off(pose: FramePose, window: PixelWindow, board: Board, camera: Camera) -> bool:
    """Whether a tag the pose puts inside the image lies (with the edge refinement's reach round
    it) beyond the window."""
    corners = np.stack(list(board.corners_table().values()))  # (T, 4, 3)
    in_camera = corners @ pose.camera_from_table[:3, :3].T + pose.camera_from_table[:3, 3]
    in_front = np.all(in_camera[..., 2] > 0, axis=1)
    pixels = camera.project(in_camera[in_front].reshape(-1, 3)).reshape(-1, 4, 2)
    seen = np.all(_in_image(pixels, camera), axis=1)
    side_px = np.linalg.norm(pixels - np.roll(pixels, 1, axis=1), axis=-1).max(axis=1)
    margin = np.maximum(2.0, 0.2 * side_px)[:, None]  # the edge refinement samples a tenth of a side beyond it
    return bool(np.any(seen & ~np.all(window.holds(pixels, margin), axis=1)))


def _in_image(pixels: np.ndarray, camera: Camera) -> np.ndarray:
    x, y = pixels[..., 0], pixels[..., 1]
    return (x >= 0) & (x <= camera.width - 1) & (y >= 0) & (y <= camera.height - 1)
