"""Whether a recording's depth is in the units it was read in: the depth read at the board's tag
corners against how far the tags' own pose puts them. A TUM-layout folder written in mm (the
format says 1/5000 m), a wrong Open3D depth_scale or --camera depth_scale_m read every depth 5x
or 10x off: reconstructed anyway, the check's box came out a 0.5 m slab 95 mm from its truth.
`--depth-units-m` says what they are, where the recording's own are wrong."""

from __future__ import annotations

import numpy as np

from homemodel.core.errors import InputError
from homemodel.geometry.camera import Camera
from turntable.board import Board
from turntable.pose import FramePose, PoseSkip, estimate_camera_from_table
from turntable.recordings.source import StreamSetup
from turntable.tags import DetectionOptions, detect_tags

TOLERANCE = 0.1  # the depth within 10 % of the tags' distance (sensor noise and a sensor's own bias are a few %)
# Units recordings come in, for the hint: TUM's 1/5000 m, 1 mm, 0.1 mm (D405).
_UNITS_M = {1 / 5000: "1/5000 m", 0.001: "1 mm", 0.0001: "0.1 mm"}
_MIN_CORNERS = 12
# The verdict is the median of this many posed frames' ratios, taken this many frames apart: a
# RealSense's first frames (auto-exposure settling, the projector warming) may read the board
# off where later ones do not. Frames without a pose are tried one after another, up to a limit.
_POSED_FRAMES, _SPACING, _UNPOSED_TRIES = 3, 10, 6
FLAG = "--depth-units-m"


def take_depth_units(setup: StreamSetup, units_m: float) -> None:
    """`--depth-units-m`: the recording's 16-bit depth read in `units_m` metres a unit, not in
    the recording's own; said in a note, in place of the reader's on the units it took."""
    own = setup.color_camera.depth_scale_m
    setup.color_camera = Camera(**{**setup.color_camera.model_dump(), "depth_scale_m": units_m})
    setup.notes[:] = [note for note in setup.notes if not note.startswith("depth units")]
    setup.notes.append(f"depth units {units_m:g} m ({FLAG}), not the recording's {own:g} m")


def board_pose(rgb: np.ndarray, board: Board, camera: Camera) -> FramePose | None:
    """The colour camera's pose of the board by its tags in `rgb`; None when they give none."""
    import cv2

    try:
        return estimate_camera_from_table(detect_tags(cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY), DetectionOptions()), board, camera)
    except PoseSkip:
        return None


def depth_to_tags_ratio(rgb: np.ndarray, depth_m: np.ndarray, board: Board, camera: Camera) -> float | None:
    """The median of depth read / depth the tags' pose gives, at the tag corners with depth; None
    when the frame has no pose or too few such corners to say."""
    pose = board_pose(rgb, board, camera)
    if pose is None:
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
    fitting = [units for units in _UNITS_M if abs(depth_scale_m / units / ratio - 1.0) <= TOLERANCE]
    said = f"{where}: the depth reads the board's tags {ratio:.2f}x as far as they are"
    if fitting:
        units = fitting[0]
        raise InputError(
            f"{said}: its units are not {depth_scale_m:g} m; in {_UNITS_M[units]} units it would fit ({FLAG} {units:g})"
        )
    # The tags' distance goes with the focal length: a camera.yaml of another camera reads them off too.
    raise InputError(
        f"{said}: its units ({depth_scale_m:g} m) or the colour camera's intrinsics are wrong (units of "
        f"{depth_scale_m / ratio:.3g} m would fit the tags: {FLAG})"
    )


class DepthUnitsCheck:
    """`check_depth_units` on a recording's frames as they are imported: the median ratio of
    the first few posed frames, spaced apart; `add` each frame, then `finish`."""

    def __init__(self, board: Board, camera: Camera, where: str) -> None:
        self.board, self.camera, self.where = board, camera, where
        self.ratios: list[float] = []
        self.next_frame = 0  # the next frame to read the tags of
        self.unposed = 0
        self.decided = False

    def add(self, index: int, rgb: np.ndarray, depth_m: np.ndarray) -> None:
        """Reads frame `index` (0, 1, ... in order) when due; refuses once enough frames say
        the units are wrong."""
        if self.decided or index < self.next_frame:
            return
        ratio = depth_to_tags_ratio(rgb, depth_m, self.board, self.camera)
        if ratio is None:
            self.unposed += 1
            self.next_frame = index + 1
        else:
            self.ratios.append(ratio)
            self.next_frame = index + _SPACING
        if len(self.ratios) >= _POSED_FRAMES or self.unposed >= _UNPOSED_TRIES:
            self.finish()

    def finish(self) -> None:
        """The verdict on the frames read so far, once (none posed: unchecked)."""
        if not self.decided and self.ratios:
            check_depth_units(float(np.median(self.ratios)), self.camera.depth_scale_m, self.where)
        self.decided = True
