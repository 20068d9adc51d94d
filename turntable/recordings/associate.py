"""Colour and depth streams associated by time: each colour frame takes the nearest depth
frame within a tolerance, each depth frame used once (TUM's `associate.py`, one-to-one)."""

from __future__ import annotations

import numpy as np

from homemodel.core.errors import InputError

MAX_TOLERANCE_S = 0.05


def default_tolerance_s(color_times_s: np.ndarray, depth_times_s: np.ndarray) -> float:
    """Half the slower stream's median frame interval (nearest frames never swap), at most 50 ms."""
    periods = [np.median(np.diff(np.sort(t))) for t in (color_times_s, depth_times_s) if len(t) > 1]
    return float(min(0.5 * max(periods), MAX_TOLERANCE_S)) if periods else MAX_TOLERANCE_S


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
    for _, i, j in sorted(candidates):  # closest first, each frame once
        if i not in taken_color and j not in taken_depth:
            taken_color.add(i)
            taken_depth.add(j)
            pairs.append((i, j))
    if not pairs:
        raise InputError(f"{where}: no colour frame has a depth frame within {tolerance_s * 1000:.0f} ms")
    return sorted(pairs)
