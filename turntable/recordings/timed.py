"""The recordings whose colour and depth are two separately timed streams (TUM folders, ROS
bags, Open3D folders): read the times, associate them, then load only the paired images."""

from __future__ import annotations

import abc
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from homemodel.core.errors import InputError
from homemodel.core.transforms import rotation_angle_rad
from turntable.recordings.associate import associate, default_tolerance_s
from turntable.recordings.source import FrameSource, RgbdPair, frame_size_problem

# What a user with a recording that lacks the depth camera's pose can do about it.
GIVE_POSE = "give its pose as color_from_depth in --camera camera.yaml"


class TimedStreamsSource(FrameSource):
    def __init__(self, path: Path, *, tolerance_s: float | None = None, every: int = 1) -> None:
        self.path = Path(path)
        self.tolerance_s = tolerance_s
        self.every = every

    @abc.abstractmethod
    def stream_times(self) -> tuple[np.ndarray, np.ndarray]:
        """Colour and depth frame times in seconds (any common origin)."""

    @abc.abstractmethod
    def stream_images(self, chosen: list[tuple[int, int]]) -> Iterator[tuple[str, int, np.ndarray]]:
        """("color" | "depth", index, image) for the frames of the chosen (colour, depth) pairs,
        in any order (a file reader goes pair by pair, a bag in its own time order); colour RGB
        uint8, depth uint16 in the setup's units or float32 metres."""

    def _place_depth_camera(self, chosen: list[tuple[int, int]]) -> None:
        """An unregistered depth whose pose the recording does not give: placed by a few frames'
        edges (`edge_placement`), else taken as seen from colour's own point, said either way."""
        from turntable.recordings.edge_placement import MIN_AGREEMENT, place_depth_camera

        placement = place_depth_camera(self._samples(chosen), self.setup, self.board)
        at_one_point = "depth reprojected as if the two cameras sat at one point"
        if placement is None:
            self.setup.notes.append(f"{at_one_point} (too few depth edges to place it: {GIVE_POSE})")
            return
        if placement.agreement < MIN_AGREEMENT:
            self.setup.notes.append(
                f"{at_one_point} (placed by their edges, depth and colour edges agreed only {placement.agreement:.2f}x "
                f"as well as there, under {MIN_AGREEMENT}x: chance's; {GIVE_POSE})"
            )
            return
        self.setup.color_from_depth = placement.color_from_depth
        x_mm, y_mm, z_mm = 1000 * placement.color_from_depth[:3, 3]
        turn_deg = np.degrees(rotation_angle_rad(placement.color_from_depth[:3, :3]))
        by = "the board's table and " if placement.by_table else ""
        self.setup.notes.append(
            f"the depth camera placed at ({x_mm:+.1f}, {y_mm:+.1f}, {z_mm:+.1f}) mm from colour's, turned {turn_deg:.2f} deg, "
            f"by {by}where depth and colour edges fall in {placement.frames} frames (edges {placement.agreement:.1f}x as "
            f"aligned as at colour's own point; {GIVE_POSE} where you know it)"
        )

    def _samples(self, chosen: list[tuple[int, int]]) -> list[RgbdPair]:
        """A few of the chosen pairs spread over the recording (the placement's), their sizes checked."""
        from turntable.recordings.edge_placement import SAMPLE_FRAMES

        picked = sorted({chosen[round(k)] for k in np.linspace(0, len(chosen) - 1, min(SAMPLE_FRAMES, len(chosen)))})
        images = {(kind, index): image for kind, index, image in self.stream_images(picked)}
        samples = [
            RgbdPair(time_s=0.0, color=images[("color", i)], depth=images[("depth", j)], depth_offset_s=0.0) for i, j in picked
        ]
        for sample in samples:  # before the edges are read at the intrinsics' sizes
            if (problem := frame_size_problem(sample, self.setup)) is not None:
                raise InputError(f"{self.path}: {problem}")
        return samples

    def _lay_given_pose_on_the_table(self, chosen: list[tuple[int, int]]) -> None:
        """--camera's color_from_depth with its tilt and height from the board's table: a
        datasheet's baseline given unturned (readme_check's bottle: 0.6 deg off) made the table a
        slab 30 mm from the truth; a calibrated pose moves by the tags' noise (~0.02 deg)."""
        from turntable.recordings.edge_placement import laid_on_table

        given = self.setup.color_from_depth
        laid = None if self.board is None or given is None else laid_on_table(self._samples(chosen), self.setup, self.board, given)
        if laid is None:
            return
        self.setup.color_from_depth = laid
        turn_deg = np.degrees(rotation_angle_rad(laid[:3, :3] @ given[:3, :3].T))
        self.setup.notes.append(
            f"--camera's color_from_depth laid on the board's table: turned {turn_deg:.2f} deg, moved "
            f"{1000 * np.linalg.norm(laid[:3, 3] - given[:3, 3]):.1f} mm"
        )

    def pairs(self, *, start_s: float = 0.0, end_s: float | None = None) -> Iterator[RgbdPair]:
        color_t, depth_t = self.stream_times()
        tolerance = self.tolerance_s if self.tolerance_s is not None else default_tolerance_s(color_t, depth_t)
        matched = associate(color_t, depth_t, tolerance, where=str(self.path))
        origin = min(color_t.min(), depth_t.min())
        counts = self.counts
        counts.color_frames, counts.depth_frames, counts.pairs = len(color_t), len(depth_t), len(matched)
        counts.dropped_color, counts.dropped_depth = len(color_t) - len(matched), len(depth_t) - len(matched)
        counts.max_offset_s = max(abs(depth_t[j] - color_t[i]) for i, j in matched)
        in_span = [
            (i, j) for i, j in matched if color_t[i] - origin >= start_s and (end_s is None or color_t[i] - origin <= end_s)
        ]
        chosen = in_span[:: self.every]
        if self.setup.depth_camera is not None and self.setup.color_from_depth is None and chosen:
            self._place_depth_camera(chosen)
        elif self.setup.depth_camera is not None and self.setup.depth_pose_given and chosen:
            self._lay_given_pose_on_the_table(chosen)
        depth_of = dict(chosen)
        color_of = {j: i for i, j in chosen}
        held: dict[tuple[str, int], np.ndarray] = {}
        for kind, index, image in self.stream_images(chosen):
            held[(kind, index)] = image
            i = index if kind == "color" else color_of[index]
            j = depth_of[i]
            if ("color", i) in held and ("depth", j) in held:
                yield RgbdPair(
                    time_s=float(color_t[i] - origin),
                    color=held.pop(("color", i)),
                    depth=held.pop(("depth", j)),
                    depth_offset_s=float(depth_t[j] - color_t[i]),
                )
