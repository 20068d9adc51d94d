"""How much of the table's turn a capture's frames saw: reconstruct's `turn` figures and its
warning when a part of the object was never in view (a recording of less than a turn, or a run
of frames lost)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from turntable.real_frames import table_turn_rad

# The widest gap between two consecutive frames' turn angles the merge bridges. The simulated
# captures' 12 frames a turn (30 degrees apart) reconstruct within 1.5 mm of the truth
# (tests/test_turntable_accuracy.py), so 30 is bridged; a 36-frame turn (10 degrees apart)
# passes with three frames in a row blurred or dropped (40). Beyond, a face is seen only at a
# slant from its neighbours and a concave part (a mug's inside, behind a handle) not at all:
# 0.8 of a turn leaves a gap of 72 degrees plus a step.
GAP_WARNING_DEG = 45.0


@dataclass(frozen=True)
class TurnCoverage:
    seen_fraction: float  # of the turn: all but the wide gaps, each less one usual step between frames
    largest_gap_deg: float  # between consecutive frames' turn angles

    @property
    def gap_warning(self) -> bool:
        return self.largest_gap_deg > GAP_WARNING_DEG

    def figures(self) -> dict:
        return {
            "seen_fraction": round(self.seen_fraction, 4),
            "largest_gap_deg": round(self.largest_gap_deg, 2),
            "gap_warning": self.gap_warning,
        }

    def warning(self) -> str | None:
        """One line saying what is missing and what to do, or None."""
        if not self.gap_warning:
            return None
        return (
            f"{100 * (1 - self.seen_fraction):.0f} % of the turn never seen ({self.largest_gap_deg:.0f} degrees "
            f"without a frame, over {GAP_WARNING_DEG:.0f}): that side of the object is guessed; record a full turn"
        )


def turn_coverage(angles_rad: Sequence[float]) -> TurnCoverage:
    """The frames' table angles (one or more, any order, any number of turns) as a coverage: the turn is
    seen between frames closer than `GAP_WARNING_DEG`; of a wider gap, all but one usual step."""
    angles = np.sort(np.mod(np.degrees(np.asarray(angles_rad, dtype=float)), 360.0))
    gaps = np.diff(angles, append=angles[0] + 360.0)  # the last gap wraps round to the first frame
    # A frame stands for the capture's usual step about it (at most the bar, when every gap is
    # wider); what a wider gap holds beyond that is unseen.
    bridged = gaps[gaps <= GAP_WARNING_DEG]
    step = float(np.median(bridged)) if len(bridged) else GAP_WARNING_DEG
    unseen = float((gaps[gaps > GAP_WARNING_DEG] - step).sum())
    return TurnCoverage(seen_fraction=max(0.0, 1 - unseen / 360.0), largest_gap_deg=float(gaps.max()))


def turn_angles_rad(camera_from_tables: Sequence[np.ndarray]) -> list[float]:
    """Each pose's table angle from the first's (the camera is fixed, the table turns); one pose or more."""
    return [table_turn_rad(camera_from_tables[0], c) for c in camera_from_tables]
