"""Whether a recording's depth is in the units it was read in: the depth read at the board's tag
corners against how far the tags' own pose puts them. A TUM-layout folder written in mm (the
format says 1/5000 m), a wrong Open3D depth_scale or --camera depth_scale_m read every depth 5x
or 10x off: reconstructed anyway, the check's box came out a 0.5 m slab 95 mm from its truth."""

from __future__ import annotations

import numpy as np

from homemodel.core.errors import InputError
from homemodel.geometry.camera import Camera
from turntable.board import Board
from turntable.pose import PoseSkip, estimate_camera_from_table
from turntable.tags import DetectionOptions, detect_tags

TOLERANCE = 0.1  # the depth within 10 % of the tags' distance (sensor noise and a sensor's own bias are a few %)
# Units recordings come in, for the hint: TUM's 1/5000 m, 1 mm, 0.1 mm (D405).
_UNITS_M = {1 / 5000: "1/5000 m", 0.001: "1 mm", 0.0001: "0.1 mm"}
_MIN_CORNERS = 12


def depth_to_tags_ratio(rgb: np.ndarray, depth_m: np.ndarray, board: Board, camera: Camera) -> float | None:
    """The median of depth read / depth the tags' pose gives, at the tag corners with depth; None
    when the frame has no pose or too few such corners to say."""
    import cv2

    try:
        pose = estimate_camera_from_table(detect_tags(cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY), DetectionOptions()), board, camera)
    except PoseSkip:
        return None
    expected = (pose.table_points @ pose.camera_from_table[:3, :3].T + pose.camera_from_table[:3, 3])[:, 2]
    pixels = np.round(pose.image_points).astype(np.int64)
    inside = (pixels[:, 0] >= 0) & (pixels[:, 0] < depth_m.shape[1]) & (pixels[:, 1] >= 0) & (pixels[:, 1] < depth_m.shape[0])
    read = np.full(len(pixels), np.nan)
    read[inside] = depth_m[pixels[inside, 1], pixels[inside, 0]]
    seen = np.isfinite(read) & (read > 0) & (expected > 0)
    if np.count_nonzero(seen) < _MIN_CORNERS:
        return None
    return float(np.median(read[seen] / expected[seen]))


def check_depth_units(ratio: float | None, depth_scale_m: float, where: str) -> None:
    """Refuses, in one line naming `where`, depth that reads the board `ratio` times as far as
    its tags put it, past the tolerance; says which known units would fit, else that the units
    or the intrinsics are off."""
    if ratio is None or abs(ratio - 1.0) <= TOLERANCE:
        return
    fitting = [name for units, name in _UNITS_M.items() if abs(depth_scale_m / units / ratio - 1.0) <= TOLERANCE]
    said = f"{where}: the depth reads the board's tags {ratio:.2f}x as far as they are"
    if fitting:
        raise InputError(f"{said}: its units are not {depth_scale_m:g} m; in {fitting[0]} units it would fit")
    # The tags' distance goes with the focal length: a camera.yaml of another camera reads them off too.
    raise InputError(f"{said}: its units ({depth_scale_m:g} m) or the colour camera's intrinsics are wrong")
