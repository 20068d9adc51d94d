"""How a capture's frames are searched for tags. The camera is fixed and the board turns in
the table's plane, so every frame shows the tags at about the same sizes and inside the same
part of the image: one frame's pose sets AprilTag's decimation and a window of the image to
search. A frame whose pose shows a tag the window cut off, or which gives no pose, is searched
again over the whole image, and then at full resolution, so the window and the decimation
only save time (on the 640 x 480 bench mug: the window is 35 % of the image)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from homemodel.geometry.camera import Camera
from turntable.board import Board
from turntable.pose import FramePose, PoseOptions, PoseSkip, estimate_camera_from_table
from turntable.tags import DetectionOptions, PixelWindow, detect_tags

_COARSE_DECIMATION = 1.5
_COARSE_TAG_PX = 18.0  # the tags' tenth-percentile size (square root of the area) it needs
# The window holds the board turned about any axis this far from its origin (a fraction of the
# board's radius: 1.9 cm on the bench's 40 cm table): the axis is not known before the poses are.
_AXIS_OFFSET_FRACTION = 0.1
_WINDOW_MARGIN_PX = 4  # round the board's outline in the image
_WHOLE_IMAGE_FRACTION = 0.8  # a window larger than this part of the image saves too little: none


@dataclass(frozen=True, kw_only=True)
class TagSearch:
    detection: DetectionOptions
    window: PixelWindow | None = None  # None: the whole image


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


def capture_search(board: Board, camera: Camera, camera_from_table: np.ndarray, detection: DetectionOptions) -> TagSearch:
    """The search for a capture's frames from one frame's pose: the decimation, unless the
    options fix it, and the window."""
    if detection.decimate is None:
        detection = replace(detection, decimate=tag_decimation(board, camera, camera_from_table))
    return TagSearch(detection=detection, window=tag_window(board, camera, camera_from_table))


def frame_pose(gray: np.ndarray, search: TagSearch, board: Board, camera: Camera, options: PoseOptions) -> FramePose:
    """`camera_from_table` of one frame from its tags, searched in the window first, then over
    the whole image if the window gave no pose or cut off a tag the pose shows in the image,
    then at full resolution if the coarse search gave no pose; raises PoseSkip."""
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
