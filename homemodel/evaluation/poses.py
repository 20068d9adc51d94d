"""Camera pose error against the true poses."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np


def camera_pose_errors(
    estimated: Mapping[str, np.ndarray], truth: Mapping[str, np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """Per estimated frame, the camera-centre error (m) and the rotation error (degrees) of
    `camera_from_world` poses against the true ones of the same name."""
    centres, angles = [], []
    for name, camera_from_world in estimated.items():
        true = truth[name]
        centres.append(np.linalg.norm(np.linalg.inv(camera_from_world)[:3, 3] - np.linalg.inv(true)[:3, 3]))
        relative = camera_from_world[:3, :3] @ true[:3, :3].T
        angles.append(np.degrees(np.arccos(np.clip((np.trace(relative) - 1) / 2, -1.0, 1.0))))
    return np.array(centres), np.array(angles)
