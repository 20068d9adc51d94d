"""The model's frame: metric scale from markers of known size, z up from the support plane.

With markers, the origin is the centre of the marker with the lowest id, x runs along its top
edge (corner 0 to corner 1) and z is the support plane's normal: the frame D3.1's turntable
board gives, and the frame a marker pose estimate (OpenCV's `x right, y up, z out of the
marker`) gives. Without markers the SfM units are kept (the model is marked unscaled) and the
origin is the object's footprint centre on the support plane.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from photogrammetry.markers import TriangulatedMarker
from photogrammetry.sfm import View
from photogrammetry.support_plane import Plane


@dataclass(kw_only=True)
class ModelFrame:
    """`model_from_sfm` is a similarity: `scale` times a rotation, plus a translation."""

    model_from_sfm: np.ndarray
    scale: float  # model units (metres when `scaled`) per SfM unit
    scaled: bool
    levelled: bool
    markers: list[int] = field(default_factory=list)
    marker_edge_spread: float = 0.0  # relative std of the triangulated marker edge lengths

    def apply(self, points: np.ndarray) -> np.ndarray:
        return points @ self.model_from_sfm[:3, :3].T + self.model_from_sfm[:3, 3]

    def view(self, view: View) -> View:
        """The view with its pose in the model frame (its camera frame scaled to model units too)."""
        sfm_from_model = np.linalg.inv(self.model_from_sfm)
        camera_from_model = view.camera_from_world @ sfm_from_model
        camera_from_model[:3, :] *= self.scale  # undo the 1/scale that sfm_from_model put in the rotation
        return dataclasses.replace(view, camera_from_world=camera_from_model)


def _rotation_rows(z_axis: np.ndarray, x_hint: np.ndarray) -> np.ndarray:
    """A rotation whose rows are the frame's axes (x from the hint, projected into the plane)."""
    z = z_axis / np.linalg.norm(z_axis)
    x = x_hint - (x_hint @ z) * z
    if np.linalg.norm(x) < 1e-9:  # the hint is along z: any x in the plane will do
        x = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    return np.vstack([x, np.cross(z, x), z])


def _similarity(scale: float, rotation_rows: np.ndarray, origin_sfm: np.ndarray) -> np.ndarray:
    model_from_sfm = np.eye(4)
    model_from_sfm[:3, :3] = scale * rotation_rows
    model_from_sfm[:3, 3] = -scale * rotation_rows @ origin_sfm
    return model_from_sfm


def marker_scale(markers: list[TriangulatedMarker], marker_size_m: float) -> tuple[float, float]:
    """Metres per SfM unit from every triangulated marker edge, and the edges' relative spread."""
    edges = np.concatenate([m.edge_lengths for m in markers])
    return marker_size_m / float(np.median(edges)), float(np.std(edges) / np.mean(edges))


def metric_frame(
    *,
    plane: Plane | None,
    markers: list[TriangulatedMarker],
    marker_size_m: float | None,
    object_centre_sfm: np.ndarray,
    x_hint_sfm: np.ndarray,
    up_hint_sfm: np.ndarray | None = None,
) -> ModelFrame:
    """The frame of the model from what was found: markers (scale, origin, x) and the plane (z)."""
    if markers and marker_size_m is not None:
        scale, spread = marker_scale(markers, marker_size_m)
        first = markers[0]  # the lowest id: triangulate_markers sorts by id
        corners = first.corners
        top_edge = (corners[1] - corners[0]) + (corners[2] - corners[3])
        if plane is None:
            # No plane in the dense points: the markers' own plane, facing where the cameras' y is up.
            all_corners = np.vstack([m.corners for m in markers])
            normal = np.cross(corners[1] - corners[0], corners[0] - corners[3])
            if len(markers) >= 2:
                fitted = np.linalg.svd(all_corners - all_corners.mean(axis=0))[2][-1]
                normal = fitted if fitted @ normal > 0 else -fitted
            plane = Plane(normal=normal / np.linalg.norm(normal), offset=0.0, inlier_share=0.0)
        rows = _rotation_rows(plane.normal, top_edge)
        centre = corners.mean(axis=0)
        origin = centre - (plane.height(centre[None])[0] if plane.inlier_share > 0 else 0.0) * plane.normal
        return ModelFrame(
            model_from_sfm=_similarity(scale, rows, origin),
            scale=scale,
            scaled=True,
            levelled=True,
            markers=[m.marker_id for m in markers],
            marker_edge_spread=spread,
        )
    if plane is None:
        # Nothing to level by: z is the cameras' mean up (photos are taken upright), or SfM's z.
        rows = _rotation_rows(np.array([0.0, 0.0, 1.0]) if up_hint_sfm is None else up_hint_sfm, x_hint_sfm)
        return ModelFrame(
            model_from_sfm=_similarity(1.0, rows, object_centre_sfm), scale=1.0, scaled=False, levelled=False
        )
    rows = _rotation_rows(plane.normal, x_hint_sfm)
    origin = object_centre_sfm - plane.height(object_centre_sfm[None])[0] * plane.normal
    return ModelFrame(model_from_sfm=_similarity(1.0, rows, origin), scale=1.0, scaled=False, levelled=True)
