"""A recording whose table stands still before it turns (the recorder started, then the table):
the turn rate reconstruct poses blurred frames and late depth frames by is the turning
frames', not a line through the still ones too."""

from __future__ import annotations

import numpy as np
import pytest

from turntable.real_frames import turn_rate_rad_s, turned_table
from turntable.simulate import SimulationOptions, turntable_motion


def _poses(angles_deg: np.ndarray, noise_deg: float, seed: int) -> list[np.ndarray]:
    """The camera's pose of the table turned by each of `angles_deg` from the simulation's
    first pose, with noise on the angle as the tags' poses carry it."""
    options = SimulationOptions(frames=36)
    camera_from_world, world_from_tables = turntable_motion(options, 0.1)
    first, axis = camera_from_world @ world_from_tables[0], np.array(options.axis_offset_m)
    noisy = angles_deg + np.random.default_rng(seed).normal(0, noise_deg, len(angles_deg))
    return [first @ turned_table(axis, a) for a in np.radians(noisy)]


@pytest.mark.parametrize("still_s", [(8.0, 0.0), (0.0, 4.0), (8.0, 4.0), (0.0, 0.0)])
def test_the_turn_rate_leaves_a_still_start_and_end_out(still_s: tuple[float, float]) -> None:
    """check29's recording: 8 s still (16 frames at 2 a second), then 20 deg/s: read 15.05
    deg/s (a line through all the frames); a still end alike; a table turning throughout, and
    at 30 frames a second a slow turn (12 deg/s, 0.4 deg a frame), read as before."""
    before, after = still_s
    for fps, rate_deg_s in ((2.0, 20.0), (30.0, 12.0)):
        turning_s = 9.0
        times = np.arange(0, before + turning_s + after, 1 / fps)
        angles = rate_deg_s * np.clip(times - before, 0, turning_s)
        read = np.degrees(turn_rate_rad_s(_poses(angles, 0.05, seed=int(fps)), list(times)))
        assert read == pytest.approx(rate_deg_s, rel=0.01), (fps, still_s, read)


@pytest.mark.parametrize("pause_s", [4.0, 1.5])
def test_a_pause_in_mid_turn_is_left_out_of_the_turn_rate(pause_s: float) -> None:
    """The table stopped for a while in mid-turn (a hand on it, a motor's hiccup): a line
    through all the frames read 11.1 deg/s for a 4 s pause in a turn at 20 deg/s (15.7 for 1.5 s), and the
    blurred and late-depth frames after it were posed by that rate. The turning stretches
    share one slope, each its own start."""
    for fps, rate_deg_s in ((2.0, 20.0), (30.0, 12.0)):
        times = np.arange(0, 4.5 + pause_s + 4.5, 1 / fps)
        turning_s = np.clip(times, 0, 4.5) + np.clip(times - 4.5 - pause_s, 0, None)
        read = np.degrees(turn_rate_rad_s(_poses(rate_deg_s * turning_s, 0.05, seed=int(fps)), list(times)))
        assert read == pytest.approx(rate_deg_s, rel=0.01), (fps, pause_s, read)
