"""Colour and depth streams associated by time: each colour frame takes the nearest depth
frame within a tolerance, each depth frame used once (TUM's `associate.py`, one-to-one).
`associate` pairs two whole streams; `StreamAssociation` the same pairs for frames arriving one
by one (a camera, or a recording played back), given out once no later frame can change them."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from homemodel.core.errors import InputError

MAX_TOLERANCE_S = 0.05


def default_tolerance_s(color_times_s: np.ndarray, depth_times_s: np.ndarray) -> float:
    """Half the slower stream's median frame interval (nearest frames never swap), at most 50 ms."""
    periods = [np.median(np.diff(np.sort(t))) for t in (color_times_s, depth_times_s) if len(t) > 1]
    return float(min(0.5 * max(periods), MAX_TOLERANCE_S)) if periods else MAX_TOLERANCE_S


def closest_first(color: np.ndarray, depth: np.ndarray, tolerance_s: float) -> list[tuple[int, int]]:
    """(colour index, depth index) pairs within `tolerance_s`, the closest taken first, each
    frame once; by colour index."""
    order = np.argsort(depth, kind="stable")
    sorted_depth = depth[order]
    candidates = []
    for i, t in enumerate(color):  # the two depth frames either side of each colour frame
        k = int(np.searchsorted(sorted_depth, t))
        for j in (k - 1, k):
            if 0 <= j < len(sorted_depth) and abs(sorted_depth[j] - t) <= tolerance_s:
                candidates.append((abs(sorted_depth[j] - t), i, int(order[j])))
    taken_color: set[int] = set()
    taken_depth: set[int] = set()
    pairs = []
    for _, i, j in sorted(candidates):
        if i not in taken_color and j not in taken_depth:
            taken_color.add(i)
            taken_depth.add(j)
            pairs.append((i, j))
    return sorted(pairs)


def associate(
    color_times_s: np.ndarray, depth_times_s: np.ndarray, tolerance_s: float, *, where: str
) -> list[tuple[int, int]]:
    """(colour index, depth index) pairs, by increasing colour time. Refuses streams whose
    time spans never overlap, naming `where`."""
    color = np.asarray(color_times_s, dtype=np.float64)
    depth = np.asarray(depth_times_s, dtype=np.float64)
    if len(color) == 0 or len(depth) == 0:
        raise InputError(f"{where}: {len(color)} colour and {len(depth)} depth frames; both streams are needed")
    if color.max() < depth.min() - tolerance_s or depth.max() < color.min() - tolerance_s:
        raise InputError(
            f"{where}: the colour ({color.min():.3f}-{color.max():.3f} s) and depth "
            f"({depth.min():.3f}-{depth.max():.3f} s) streams never overlap in time"
        )
    pairs = closest_first(color, depth, tolerance_s)
    if not pairs:
        raise InputError(f"{where}: no colour frame has a depth frame within {tolerance_s * 1000:.0f} ms")
    return pairs


@dataclass
class _Held:
    time_s: float
    item: object


@dataclass
class StreamAssociation:
    """`associate`'s pairs for frames given one at a time, each stream in its own time order.
    A frame is settled once both streams have passed it by more than the tolerance (no later
    frame can be its partner), or once the other stream lags `max_lag_s` behind (stalled: its
    late frames find only what is still held). Settled frames are paired as `associate` pairs
    them, in time order, when no pairing edge joins them to a frame still unsettled."""

    tolerance_s: float
    max_lag_s: float = 0.5
    held: dict[str, list[_Held]] = field(default_factory=lambda: {"color": [], "depth": []})
    latest_s: dict[str, float] = field(default_factory=lambda: {"color": -np.inf, "depth": -np.inf})
    settled_before_s: float = -np.inf  # every frame earlier than this has been given out
    late: int = 0  # frames that came after their time had been settled: never paired

    def add(self, kind: str, time_s: float, item: object) -> list[tuple[object, object, float]]:
        """Hold a frame; the (colour item, depth item, depth minus colour seconds) pairs now settled."""
        if time_s < self.settled_before_s:
            self.late += 1
            return []
        self.held[kind].append(_Held(time_s, item))
        self.latest_s[kind] = max(self.latest_s[kind], time_s)
        both = min(self.latest_s.values())
        horizon = max(both, max(self.latest_s.values()) - self.max_lag_s)
        return self._give_out(horizon - self.tolerance_s)

    def finish(self) -> list[tuple[object, object, float]]:
        """The pairs among the frames still held (the streams have ended)."""
        return self._give_out(np.inf)

    def _give_out(self, settled_s: float) -> list[tuple[object, object, float]]:
        color, depth = self.held["color"], self.held["depth"]
        frames = sorted([(h.time_s, 0, k) for k, h in enumerate(color)] + [(h.time_s, 1, k) for k, h in enumerate(depth)])
        # The longest run of settled frames, in time, that no pairing edge leaves.
        cut_s, reach_s = -np.inf, -np.inf
        for n, (t, kind, _) in enumerate(frames):
            if t >= settled_s:
                break
            others = depth if kind == 0 else color
            partners = [h.time_s for h in others if t < h.time_s <= t + self.tolerance_s]
            reach_s = max(reach_s, t, *partners)
            if reach_s >= settled_s:
                break
            if n + 1 == len(frames) or frames[n + 1][0] > reach_s:
                cut_s = frames[n + 1][0] if n + 1 < len(frames) else np.inf
        if cut_s == -np.inf:
            return []
        given_color = [h for h in color if h.time_s < cut_s]
        given_depth = [h for h in depth if h.time_s < cut_s]
        self.held = {"color": [h for h in color if h.time_s >= cut_s], "depth": [h for h in depth if h.time_s >= cut_s]}
        self.settled_before_s = max(self.settled_before_s, min(cut_s, settled_s))
        if not given_color or not given_depth:
            return []
        pairs = closest_first(
            np.array([h.time_s for h in given_color]), np.array([h.time_s for h in given_depth]), self.tolerance_s
        )
        return [(given_color[i].item, given_depth[j].item, given_depth[j].time_s - given_color[i].time_s) for i, j in pairs]
