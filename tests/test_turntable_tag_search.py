"""The tag search's window (turntable.tag_search) on a ray-traced view of a tag board (no
Blender, about a second): it holds every tag of the board however the table turns about an
axis near the board's origin, a pose searched in it is the whole image's, and a window that
cuts tags off falls back to the whole image; a frame's tags predicted from the two frames before
give its true pose without the tags an object hides, and a wrong prediction falls back to the search;
every frame's sharpness is measured in the window, the frames read before it was known too."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from homemodel.core.transforms import world_from_camera_looking_at
from homemodel.geometry.camera import Camera
from turntable.board import TAG_CELLS, Board, grid_board, tag_bits
from turntable.pose import PoseOptions, estimate_camera_from_table
from turntable.real_frames import turned_table
from turntable.tag_search import TagSearch, board_codes, capture_search, frame_pose, predicted_pose, tracked_pose
from turntable.tags import DetectionOptions, PixelWindow, detect_tags

CAMERA = Camera(width=480, height=360, fx=430.0, fy=430.0, cx=239.5, cy=179.5)
BOARD = grid_board(table_diameter_m=0.3, tag_size_m=0.024)


def _camera_from_table(turn_rad: float = 0.0) -> np.ndarray:
    camera_from_table = np.linalg.inv(world_from_camera_looking_at([0.0, -0.32, 0.36], [0.0, 0.0, 0.0]))
    return camera_from_table @ turned_table(np.array([0.008, -0.006]), turn_rad)


def _view(board: Board, camera_from_table: np.ndarray, samples: int = 3) -> np.ndarray:
    """The board on a light table top as the camera sees it: each pixel the mean of
    `samples` x `samples` rays meeting the plane z = 0, black or white by the tags' cells."""
    offsets = (np.arange(samples) + 0.5) / samples - 0.5
    u, v = np.meshgrid(np.arange(CAMERA.width), np.arange(CAMERA.height))
    du, dv = np.meshgrid(offsets, offsets)
    pixels = np.stack([(u[..., None] + du.ravel()).ravel(), (v[..., None] + dv.ravel()).ravel()], axis=1)
    rays = CAMERA.rays(pixels) @ np.linalg.inv(camera_from_table)[:3, :3].T
    eye = np.linalg.inv(camera_from_table)[:3, 3]
    xy = eye[:2] + rays[:, :2] * (-eye[2] / rays[:, 2])[:, None]
    centers = np.array([tag.center_m for tag in board.tags])
    nearest = cKDTree(centers).query(xy)[1]
    cell = board.tag_size_m / TAG_CELLS
    col = np.floor((xy[:, 0] - centers[nearest, 0]) / cell + TAG_CELLS / 2).astype(int)
    row = np.floor((centers[nearest, 1] - xy[:, 1]) / cell + TAG_CELLS / 2).astype(int)  # the top row towards +y
    bits = np.stack([tag_bits(tag.id) for tag in board.tags])
    inside = (col >= 0) & (col < TAG_CELLS) & (row >= 0) & (row < TAG_CELLS)
    white = np.ones(len(xy), dtype=bool)
    white[inside] = bits[nearest[inside], row[inside], col[inside]]
    level = np.where(white, 220.0, 20.0).reshape(CAMERA.height, CAMERA.width, samples * samples).mean(axis=2)
    return np.round(level).astype(np.uint8)


def test_the_window_holds_the_board_however_the_table_turns() -> None:
    search = capture_search(BOARD, CAMERA, _camera_from_table(), DetectionOptions())
    window = search.window
    assert window is not None
    area = (window.bottom - window.top) * (window.right - window.left)
    assert area < 0.8 * CAMERA.width * CAMERA.height
    corners = np.concatenate(list(BOARD.corners_table().values()))
    for turn in np.linspace(0.0, 2 * np.pi, 36, endpoint=False):  # about an axis a centimetre off the origin
        camera_from_table = _camera_from_table(turn)
        pixels = CAMERA.project(corners @ camera_from_table[:3, :3].T + camera_from_table[:3, 3])
        assert np.all(window.holds(pixels)), turn


def test_a_windowed_search_gives_the_whole_image_pose_and_a_cut_window_falls_back() -> None:
    camera_from_table = _camera_from_table(2.0)
    gray = _view(BOARD, camera_from_table)
    detection = DetectionOptions(decimate=1.0)
    whole = frame_pose(gray, TagSearch(detection=detection), BOARD, CAMERA, PoseOptions())
    # Against the truth: the ray-traced view is exact, so PnP lands within a tenth of a millimetre.
    assert np.abs(whole.camera_from_table[:3, 3] - camera_from_table[:3, 3]).max() < 1e-4
    search = capture_search(BOARD, CAMERA, _camera_from_table(), detection)
    windowed = frame_pose(gray, search, BOARD, CAMERA, PoseOptions())
    assert windowed.tags == whole.tags
    assert np.abs(windowed.camera_from_table - whole.camera_from_table).max() < 1e-5
    # A window over the left half cuts tags off: the pose is searched again over the whole image.
    left = TagSearch(detection=detection, window=PixelWindow(top=0, bottom=CAMERA.height, left=0, right=CAMERA.width // 2))
    fallback = frame_pose(gray, left, BOARD, CAMERA, PoseOptions())
    assert fallback.tags == whole.tags
    assert np.allclose(fallback.camera_from_table, whole.camera_from_table, atol=1e-9)


def test_a_frame_s_tags_predicted_from_the_two_before_give_its_pose_and_hidden_tags_are_not_used() -> None:
    detection, options = DetectionOptions(decimate=1.0), PoseOptions()
    search = capture_search(BOARD, CAMERA, _camera_from_table(), detection)
    before, last = (frame_pose(_view(BOARD, _camera_from_table(t)), search, BOARD, CAMERA, options) for t in (1.8, 1.9))
    predicted = predicted_pose(before.camera_from_table, last.camera_from_table)
    camera_from_table = _camera_from_table(2.0)
    assert np.abs(predicted[:3, 3] - camera_from_table[:3, 3]).max() < 1e-3  # the detected poses' errors, doubled
    gray = _view(BOARD, camera_from_table)
    # An object hides the middle of the board: a flat grey disc.
    u, v = np.meshgrid(np.arange(CAMERA.width), np.arange(CAMERA.height))
    gray[np.hypot(u - 240, v - 170) < 45] = 128
    searched = frame_pose(gray, TagSearch(detection=detection), BOARD, CAMERA, options)
    tracked = tracked_pose(gray, predicted, board_codes(BOARD), CAMERA, detection, options)
    assert tracked is not None
    # The tags the disc hides (the search cannot decode them either) are refused by their codes.
    assert tracked.tags == searched.tags
    assert tracked.inlier_corners == 4 * tracked.tags
    assert np.abs(tracked.camera_from_table[:3, 3] - camera_from_table[:3, 3]).max() < 1e-4
    # Refined from the prediction instead of RANSAC and a global solve: the same pose.
    found = detect_tags(gray, detection)
    near = estimate_camera_from_table(found, BOARD, CAMERA, options, near=predicted)
    assert np.abs(near.camera_from_table - searched.camera_from_table).max() < 1e-9
    assert near.inlier_corners == searched.inlier_corners
    # A prediction off by a tenth of a turn (more than a tag) finds no tags: the frame is searched.
    wrong = predicted @ turned_table(np.zeros(2), 0.6)
    assert tracked_pose(gray, wrong, board_codes(BOARD), CAMERA, detection, options) is None
    fallback = frame_pose(gray, search, BOARD, CAMERA, options, predicted=wrong)
    assert fallback.tags == searched.tags
    assert np.abs(fallback.camera_from_table[:3, 3] - camera_from_table[:3, 3]).max() < 1e-4


def test_the_edge_refinement_s_sampling_is_bilinear_interpolation() -> None:
    """`bilinear_levels` (OpenCV's remap) against SciPy's order-1 interpolation with the border
    repeated: equal to float32 precision on remap's 1/32-pixel grid, where the refinement
    samples, within a 1/64 px shift elsewhere; beyond the image and in maps of more rows than
    remap takes at once (40,000), for linear and sRGB levels."""
    from scipy.ndimage import map_coordinates

    from turntable.tags import LINEAR_LEVELS, bilinear_levels

    rng = np.random.default_rng(3)
    gray = rng.integers(0, 256, (60, 80), dtype=np.uint8)
    on_grid = np.round(rng.uniform(-4.0, 84.0, (2, 40_000, 3)) * 32) / 32
    off_grid = rng.uniform(-4.0, 84.0, (2, 1000, 3))
    for linear in LINEAR_LEVELS.values():
        levels = linear[gray]
        for (x, y), tolerance in ((on_grid, 1e-6), (off_grid, np.abs(np.diff(levels)).max() / 32)):
            expected = map_coordinates(levels, [y.ravel(), x.ravel()], order=1, mode="nearest").reshape(x.shape)
            assert np.abs(bilinear_levels(gray, linear, x, y) - expected).max() <= tolerance


def test_every_frame_s_sharpness_is_measured_in_the_search_window_the_first_ones_too(tmp_path) -> None:
    """The blur check compares each frame's sharpness with the median, so all are measured on
    the same part of the image: the tag search's window, which the first posed frame sets. The
    frames read before it (one without tags here, and that frame itself) are measured on it too."""
    import cv2

    from homemodel.geometry.camera import save_camera
    from turntable.board import save_board
    from turntable.capture import load_capture
    from turntable.real_frames import sharpness
    from turntable.reconstruct import read_frames
    from turntable.reconstruction import ReconstructOptions

    camera = CAMERA.model_copy(update={"depth_scale_m": 0.001})
    save_camera(camera, tmp_path / "camera.yaml")
    save_board(BOARD, tmp_path / "board.yaml")
    (tmp_path / "color").mkdir()
    (tmp_path / "depth").mkdir()
    rng = np.random.default_rng(0)
    grays = [rng.integers(100, 140, (CAMERA.height, CAMERA.width)).astype(np.uint8)]  # no tags: no pose
    grays += [_view(BOARD, _camera_from_table(turn), samples=1) for turn in (0.0, 0.05, 0.1, 0.15)]
    for k, gray in enumerate(grays):
        cv2.imwrite(str(tmp_path / "color" / f"{k:06d}.png"), cv2.cvtColor(gray, cv2.COLOR_GRAY2BGR))
        cv2.imwrite(str(tmp_path / "depth" / f"{k:06d}.png"), np.full(gray.shape, 500, np.uint16))
    frames = read_frames(load_capture(tmp_path), ReconstructOptions(detection=DetectionOptions(decimate=1.0)), lambda *a: None)
    assert sorted(frames.poses) == ["000001", "000002", "000003", "000004"]
    window = capture_search(BOARD, CAMERA, frames.poses["000001"].camera_from_table, DetectionOptions(decimate=1.0)).window
    assert window is not None
    for k, gray in enumerate(grays):
        part = gray[window.top : window.bottom, window.left : window.right]
        assert frames.readings[f"{k:06d}"].sharpness == sharpness(part), k
