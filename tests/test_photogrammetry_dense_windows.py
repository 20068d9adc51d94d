"""The dense stage searches only what a pair can match: the depths and pixels of the sparse points
both views see within the region of interest, and drops depth beside depth steps."""

from __future__ import annotations

import time
from pathlib import Path

import cv2
import numpy as np

from homemodel.geometry.camera import Camera
from photogrammetry.sfm import SparseModel, View
from photogrammetry.stereo import DenseOptions, _pair_depth, pair_windows, without_depth_edges

W, H, F, PLANE_Z = 640, 480, 640.0, 7.0
CAMERA = Camera(width=W, height=H, fx=F, fy=F, cx=(W - 1) / 2, cy=(H - 1) / 2)


def _view(name: str, centre_x: float) -> View:
    camera_from_world = np.eye(4)
    camera_from_world[0, 3] = -centre_x
    return View(name=name, image_path=Path("unused.png"), camera=CAMERA, camera_from_world=camera_from_world)


def test_pair_windows_hold_the_shared_points_depths_and_pixels_within_the_region_of_interest() -> None:
    """Three cameras side by side; points at depth 4-6 seen by views 0 and 1, points at 20 seen
    by 0 and 2, and far points outside the region of interest seen by all."""
    rng = np.random.default_rng(0)
    near = np.column_stack([rng.uniform(-1, 0, 200), rng.uniform(-0.5, 0.5, 200), rng.uniform(4, 6, 200)])
    far = np.column_stack([rng.uniform(-2, 2, 200), rng.uniform(-2, 2, 200), np.full(200, 20.0)])
    outside = np.column_stack([rng.uniform(-3, 3, 50), rng.uniform(-3, 3, 50), np.full(50, 60.0)])
    model = SparseModel(
        views=[_view("a", 0.0), _view("b", 0.5), _view("c", -0.5)],
        points_world=np.vstack([near, far, outside]),
        point_views=[np.array([0, 1])] * 200 + [np.array([0, 2])] * 200 + [np.array([0, 1, 2])] * 50,
        mean_reprojection_error_px=0.0,
        unregistered=[],
    )
    options = DenseOptions(range_margin=1.25, region_margin=0.05)
    windows = pair_windows(model, [[1, 2], [0], [0]], options, roi=(np.array([0.0, 0.0, 10.0]), 15.0))
    ab, ac = windows[0, 1], windows[0, 2]
    assert 4.0 / 1.25 - 0.05 < ab.near <= 4.0 / 1.25 + 0.05 and 6.0 * 1.25 - 0.05 <= ab.far < 6.0 * 1.25 + 0.05
    assert abs(ac.near - 20.0 / 1.25) < 1e-6 and abs(ac.far - 20.0 * 1.25) < 1e-6  # the far points only
    # The near points span x in [-1, 0] at depth 4-6: pixels from 160 - 32 to 320 + 32 (the margin).
    pixels = CAMERA.project(near)
    margin = 0.05 * W
    assert np.allclose(ab.region, (*(pixels.min(axis=0) - margin), *(pixels.max(axis=0) + margin)))
    assert ab.region[0] > 100 and ab.region[2] < W / 2 + margin + 1


def _plane_view(camera_from_ref: np.ndarray, texture: np.ndarray) -> np.ndarray:
    """A fronto-parallel plane at PLANE_Z covered by `texture` (2 cm texels), seen from the camera."""
    r, t = camera_from_ref[:3, :3], camera_from_ref[:3, 3]
    corner, texel_m = np.array([-16.0, -16.0, PLANE_Z]), 0.02
    texture_to_image = CAMERA.matrix @ np.column_stack([r[:, 0] * texel_m, r[:, 1] * texel_m, r @ corner + t])
    return cv2.warpPerspective(texture, texture_to_image, (W, H), flags=cv2.INTER_LINEAR)


def test_a_pair_matched_in_a_region_gives_the_plane_there_only_and_costs_less() -> None:
    """A textured plane seen by a pair: matched in the middle quarter of the reference, the depth
    there is the plane's (as matched whole), nothing is found outside it, and it takes under
    0.6 of the whole image's CPU time (the window is about a quarter of the canvas: 0.28-0.43
    measured)."""
    texture = cv2.GaussianBlur(np.random.default_rng(1).integers(0, 256, (1600, 1600, 3), dtype=np.uint8), (0, 0), 1.5)
    src_from_ref = np.eye(4)
    src_from_ref[0, 3] = -0.6
    ref, src = _plane_view(np.eye(4), texture), _plane_view(src_from_ref, texture)
    options = DenseOptions()
    region = (W / 4, H / 4, 3 * W / 4, 3 * H / 4)

    def timed(**region_kw) -> tuple[np.ndarray, float]:
        """The depth and the least CPU time of three runs (the machine is shared)."""
        times = []
        for _ in range(3):
            start = time.process_time()
            depth = _pair_depth(ref, src, CAMERA, CAMERA, src_from_ref, (5.0, 10.0), options, **region_kw)
            times.append(time.process_time() - start)
        return depth, min(times)

    whole, whole_s = timed()
    part, part_s = timed(region=region)
    inside = np.zeros((H, W), bool)
    inside[H // 4 + 4 : 3 * H // 4 - 4, W // 4 + 4 : 3 * W // 4 - 4] = True
    found = part[inside] > 0
    assert found.mean() > 0.95
    assert np.abs(part[inside][found] - PLANE_Z).max() < 0.01 * PLANE_Z
    both = inside & (part > 0) & (whole > 0)
    assert np.mean(np.abs(part[both] - whole[both]) < 1e-3 * PLANE_Z) > 0.99
    outside = np.ones((H, W), bool)
    outside[H // 4 - 2 : 3 * H // 4 + 3, W // 4 - 2 : 3 * W // 4 + 3] = False
    assert not (part[outside] > 0).any()
    assert part_s < 0.6 * whole_s, (part_s, whole_s)


def test_depth_beside_a_step_is_dropped_and_a_flat_map_or_a_hole_keeps_its_depth() -> None:
    depth = np.full((40, 60), 5.0, np.float32)
    depth[:, 30:] = 4.0  # a nearer surface from column 30
    depth[5:10, 5:10] = 0.0  # a hole in the far surface
    out = without_depth_edges(depth, 2, DenseOptions(depth_tolerance=0.01))
    assert (out[:, 28:32] == 0).all()  # two pixels either side of the step
    assert (out[:, 32:] == 4.0).all() and (out[:, 10:28] == 5.0).all()
    assert (out[:, :5] == 5.0).all() and (out[5:10, 5:10] == 0).all() and (out[12:, 5:10] == 5.0).all()
    ramp = np.tile(np.linspace(5.0, 5.02, 60, dtype=np.float32), (40, 1))  # a gentle slope is no step
    assert (without_depth_edges(ramp, 2, DenseOptions(depth_tolerance=0.01)) == ramp).all()
