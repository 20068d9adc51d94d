"""Where the cameras converge: the object is what every photo keeps in its frame.

Without markers or a table to go by, the object is told from the scene by the photographer's
aim: walking round an object, one keeps it in the frame, while the wall behind it, the books
beside it and the floor leave the frame as the camera moves on. A point that (nearly) every
registered view has in its frame is in the region the views converge on.
"""

from __future__ import annotations

import numpy as np

from photogrammetry.sfm import View


def in_frame_share(points: np.ndarray, views: list[View], *, margin: float = 0.02) -> np.ndarray:
    """Per point, the share of `views` that have it in front and inside their frame (less a
    `margin`, a share of the image size, at each border); points and views share a frame."""
    points = np.asarray(points, np.float64)
    if points.ndim != 2 or points.shape[1] != 3:
        raise ValueError(f"{points.shape=} but expected (N, 3)")
    count = np.zeros(len(points), np.int32)
    for view in views:
        camera_points = points @ view.camera_from_world[:3, :3].T + view.camera_from_world[:3, 3]
        front = camera_points[:, 2] > 0
        pixels = np.full((len(points), 2), -np.inf)
        pixels[front] = view.camera.project(camera_points[front])
        width, height = view.camera.width, view.camera.height
        inside = (
            (pixels[:, 0] >= margin * width)
            & (pixels[:, 0] <= (1 - margin) * width)
            & (pixels[:, 1] >= margin * height)
            & (pixels[:, 1] <= (1 - margin) * height)
        )
        count += front & inside
    return count / max(len(views), 1)
