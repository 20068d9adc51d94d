"""Where the cameras converge: the object is what every photo keeps in its frame.

Without markers or a table to go by, the object is told from the scene by the photographer's
aim: walking round an object, one keeps it in the frame, while the wall behind it, the books
beside it and the floor leave the frame as the camera moves on. A point that (nearly) every
registered view has in its frame is in the region the views converge on.
"""

from __future__ import annotations

import numpy as np

from photogrammetry.sfm import View
from photogrammetry.support_plane import focus_point


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


# The pairs of axes tried are those of at most this many views, spread evenly in name order:
# each pair's point is looked for in every view, and all pairs of all views grew as the cube of
# the photos (120: 0.08 CPU-s, 300: 2.2, 600: 20).
_CANDIDATE_VIEWS = 100


def _closest_points_of_axes(centres: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """(K, 3) for every pair of optical axes that are not parallel, the midpoint of where they
    pass closest."""
    i, j = np.triu_indices(len(centres), 1)
    d1, d2, w = axes[i], axes[j], centres[i] - centres[j]
    b = np.einsum("ij,ij->i", d1, d2)
    denominator = 1 - b**2  # unit axes
    ok = denominator > 1e-6
    d, e = np.einsum("ij,ij->i", d1, w), np.einsum("ij,ij->i", d2, w)
    s = (b * e - d)[ok] / denominator[ok]
    t = (e - b * d)[ok] / denominator[ok]
    return (centres[i][ok] + s[:, None] * d1[ok] + centres[j][ok] + t[:, None] * d2[ok]) / 2


def aimed_focus(views: list[View]) -> tuple[np.ndarray, np.ndarray]:
    """The point the views look at, and which views have it in their frame.

    Normally the point nearest (least squares) every optical axis, which every view has in
    frame. A photo that a fallback join set in the wrong place, looking past the object, pulls
    that point away from it (on Buddha's 13 colour frames, one photo four camera distances off
    and 87 degrees past the others' aim: no dense point lay near the point, and the run failed).
    Then the point is the one most views have in frame among those where two axes pass
    closest, refined on those views; the views without it in frame are returned as False
    when they are fewer than half (else all are kept: there is no one aim to go by)."""
    centres = np.array([v.centre_world for v in views])
    axes = np.array([v.optical_axis_world for v in views])
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    focus = focus_point(centres, axes)
    sees = np.array([in_frame_share(focus[None], [v], margin=0.0)[0] == 1 for v in views])
    if sees.all() or len(views) < 3:
        return focus, np.ones(len(views), bool)
    pick = np.unique(np.linspace(0, len(views) - 1, min(len(views), _CANDIDATE_VIEWS)).round().astype(int))
    candidates = _closest_points_of_axes(centres[pick], axes[pick])
    best = candidates[np.argmax(in_frame_share(candidates, views, margin=0.0))]
    aimed = np.array([in_frame_share(best[None], [v], margin=0.0)[0] == 1 for v in views])
    refined = focus_point(centres[aimed], axes[aimed])
    aimed = np.array([in_frame_share(refined[None], [v], margin=0.0)[0] == 1 for v in views])
    if 2 * aimed.sum() <= len(views):
        return focus, np.ones(len(views), bool)
    return focus_point(centres[aimed], axes[aimed]), aimed
