"""The one frame-source interface: colour and depth frames paired in time, as a live camera
delivers them or a recording plays them back. The importer (`turntable.recordings.importer`)
and the live capture (`turntable.capture_live`) both read through it."""

from __future__ import annotations

import abc
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from homemodel.geometry.camera import Camera
from turntable.board import Board


@dataclass(kw_only=True)
class StreamSetup:
    """What a source knows about its two streams once opened."""

    format: str  # realsense-bag, realsense-live, ros1, ros2, tum, open3d
    color_camera: Camera  # intrinsics and distortion of the colour images, with depth_scale_m of the depth
    # None when the depth comes registered to colour (same pixels); else the depth stream's
    # own camera, its images to be reprojected into colour's with `color_from_depth`.
    depth_camera: Camera | None = None
    color_from_depth: np.ndarray | None = None  # 4x4; None: not in the recording (identity assumed)
    # color_from_depth is --camera's (a user's, perhaps a datasheet's baseline): its tilt and
    # height are taken from the board's table where the frames show it.
    depth_pose_given: bool = False
    # (h*w, 3) rays (z = 1) through the depth camera's pixels, NaN: none. A reader sets them by
    # the recorded lens model when `depth_camera` only approximates it (an Azure Kinect's wide
    # rational one); else `depth_pixel_rays` fills them from `depth_camera` at the first frame.
    depth_rays: np.ndarray | None = None
    intrinsics_from: str = "recording"  # or "--camera"
    # False: the frames carry no times (numbered files paired by order; `RgbdPair.time_s` is
    # only their place at 30 a second). None reach recording.json, so no turn rate is fitted
    # to them: a gap in the numbering would put the frames it poses at wrong angles.
    timed: bool = True
    notes: list[str] = field(default_factory=list)  # what the reader had to assume or approximate

    def depth_pixel_rays(self) -> np.ndarray:
        """`depth_rays`, else the depth camera's own, computed once: they are the same every
        frame (0.02 CPU-s at 848x480, 0.1 through a distorting lens)."""
        if self.depth_rays is None:
            assert self.depth_camera is not None, "rays of a depth registered to colour"
            self.depth_rays = self.depth_camera.pixel_rays()
        return self.depth_rays


@dataclass(kw_only=True)
class RgbdPair:
    """One colour image and the depth image associated with it in time."""

    time_s: float  # the colour frame's, from the recording's start
    color: np.ndarray  # (H, W, 3) uint8 RGB
    depth: np.ndarray  # (h, w) uint16 in units of depth_scale_m, or float32 metres (NaN or 0: none)
    depth_offset_s: float  # depth's time minus colour's


def frame_size_problem(pair: RgbdPair, setup: StreamSetup) -> str | None:
    """Why the pair's images do not fit the cameras `setup` gives them (their sizes), or None:
    a reader's intrinsics of another size than its images misplace every pixel."""
    color, depth = pair.color.shape[:2], pair.depth.shape[:2]
    camera = setup.color_camera
    if color != (camera.height, camera.width):
        return f"a colour frame is {color[1]}x{color[0]}, its intrinsics say {camera.width}x{camera.height}"
    if setup.depth_camera is None and depth != color:
        return f"depth {depth[1]}x{depth[0]} is said to be registered to the {color[1]}x{color[0]} colour but has another size"
    own = setup.depth_camera
    if own is not None and depth != (own.height, own.width):
        return f"a depth frame is {depth[1]}x{depth[0]}, its intrinsics say {own.width}x{own.height}"
    return None


@dataclass(kw_only=True)
class StreamCounts:
    color_frames: int = 0
    depth_frames: int = 0
    pairs: int = 0  # colour frames that found a depth partner
    dropped_color: int = 0  # colour frames without one (or a gap in the frame numbers)
    dropped_depth: int = 0
    max_offset_s: float = 0.0  # the largest |depth - colour| time of a pair


class FrameSource(abc.ABC):
    """Open with `with`; `setup` is known after entering; `pairs()` yields the pairs in time
    order; `counts` is final once `pairs()` is exhausted (or the caller stops)."""

    setup: StreamSetup
    counts: StreamCounts
    # The turntable's board, when the caller has it: a depth camera placed by its edges is
    # checked against the table the board's tags give.
    board: Board | None = None

    def __enter__(self) -> FrameSource:
        self.counts = StreamCounts()
        self.setup = self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @abc.abstractmethod
    def open(self) -> StreamSetup:
        """Read the streams' description; raises InputError naming what is missing."""

    @abc.abstractmethod
    def pairs(self, *, start_s: float = 0.0, end_s: float | None = None) -> Iterator[RgbdPair]:
        """The associated pairs whose colour frame lies in [start_s, end_s] from the start."""

    def close(self) -> None:  # noqa: B027 (most sources hold nothing open)
        """Release the device or file."""
