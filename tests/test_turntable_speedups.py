"""The turntable's faster paths against what they replace, on synthetic inputs (no rendering,
a few seconds): the object's pixels kept from one reading give the points a whole-image
back-projection gives; the tag search's decimation follows the tags' size in the image; the
mesh snapped onto the merged points lands on the surface they sample; the outlier filter drops
strays and small clumps off a surface and keeps its rim; the texture's gutter takes each empty
texel's colour from a nearest painted texel (OpenCV's transform); the texture carrier's
decimation keeps a closed mesh closed and on the surface; the poses stage's runs of frames,
read apart on threads, hand every reading over and stop together; one AprilTag detector serves
every decimation, and detectors built ahead are the ones the searches take; a reconstruction
runs without NumPy's huge pages and gives the setting back; the signed distance's dilation is
SciPy's; the misregistration probes stop at half when those settle the warning."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from homemodel.core.transforms import world_from_camera_looking_at
from homemodel.geometry.camera import Camera
from homemodel.geometry.uv_atlas import Texels
from turntable import tags
from turntable.board import grid_board, tag_bits
from turntable.fusion import Cylinder, MergedCloud, object_pixels, pixel_points
from turntable.meshing import MeshingOptions, remove_outliers, snap_to_points
from turntable.real_frames import drop_flying_pixels, focal_px_of_rays
from turntable.tag_search import tag_decimation
from turntable.tags import DetectionOptions, detect_tags, prepare_detectors
from turntable.texture import carrier

CAMERA = Camera(width=320, height=240, fx=280.0, fy=280.0, cx=159.5, cy=119.5)


def _camera_from_table(distance_m: float = 0.4, height_m: float = 0.5) -> np.ndarray:
    return np.linalg.inv(world_from_camera_looking_at([0.0, -distance_m, height_m], [0.0, 0.0, 0.03]))


def _depth_of_a_box(camera_from_table: np.ndarray) -> np.ndarray:
    """Ray-cast depth of a 6 cm box on a table top, with a column of flying pixels at its edge."""
    from homemodel.geometry.raycast import RayCaster

    box = trimesh.creation.box((0.06, 0.06, 0.06))
    box.apply_translation([0.0, 0.0, 0.03])
    table = trimesh.creation.box((0.6, 0.6, 0.01))
    table.apply_translation([0.0, 0.0, -0.005])
    depth = RayCaster(trimesh.util.concatenate([box, table])).depth(CAMERA, camera_from_table)
    row = depth[CAMERA.height // 2]
    edge = int(np.flatnonzero(np.abs(np.diff(row)) > 0.02)[0])
    depth[CAMERA.height // 2 - 5 : CAMERA.height // 2 + 5, edge] = 0.5 * (row[edge - 1] + row[edge + 2])
    return depth


@pytest.mark.parametrize("ray_type", [np.float64, np.float32])  # the pipeline's rays are float32
def test_object_pixels_give_the_whole_image_points_inside_the_cylinder(ray_type: type) -> None:
    camera_from_table = _camera_from_table()
    depth = _depth_of_a_box(camera_from_table)
    rgb = np.random.default_rng(0).integers(0, 255, (CAMERA.height, CAMERA.width, 3), dtype=np.uint8)
    rays = CAMERA.pixel_rays().astype(ray_type)
    table_from_camera = np.linalg.inv(camera_from_table)
    cylinder = Cylinder(axis_xy_m=np.array([0.004, -0.002]), radius_m=0.08, z_min_m=0.004, z_max_m=1.0)
    wide = Cylinder(axis_xy_m=np.zeros(2), radius_m=0.2, z_min_m=0.001, z_max_m=1.03)
    pixels, flying = object_pixels(depth, rgb, rays, table_from_camera, wide, drop_flying=True)
    points, colors, to_camera = pixel_points(pixels, rays, table_from_camera, cylinder)
    # The reference: flying pixels dropped over the whole image, every pixel back-projected.
    cleaned, flying_whole = drop_flying_pixels(depth, focal_px_of_rays(rays, CAMERA.width))
    everything = (rays * cleaned.reshape(-1, 1)) @ table_from_camera[:3, :3].T + table_from_camera[:3, 3]
    radial = np.hypot(*(everything[:, :2] - cylinder.axis_xy_m).T)
    inside = (everything[:, 2] > 0.004) & (everything[:, 2] < 1.0) & (radial < 0.08)
    assert 0 < flying <= flying_whole  # at the box's edge; the table's own edges are not looked at
    assert len(points) == int(inside.sum()) > 1000
    assert np.allclose(np.sort(points, axis=0), np.sort(everything[inside], axis=0), atol=1e-6)
    assert np.allclose(np.sort(colors, axis=0), np.sort(rgb.reshape(-1, 3)[inside] / 255.0, axis=0))
    assert np.allclose(np.linalg.norm(to_camera, axis=1), 1.0)
    assert len(pixels.index) < 0.2 * depth.size  # the table top and the room are not kept


@pytest.mark.parametrize(("tag_size_m", "expected"), [(0.06, 1.5), (0.015, 1.0)])
def test_tag_decimation_follows_the_tags_size_in_the_image(tag_size_m: float, expected: float) -> None:
    board = grid_board(table_diameter_m=0.4, tag_size_m=tag_size_m)
    assert tag_decimation(board, CAMERA, _camera_from_table()) == expected
    behind = np.diag([1.0, 1.0, -1.0, 1.0]) @ _camera_from_table()  # the board behind the camera: no coarse search
    assert tag_decimation(board, CAMERA, behind) == 1.0


def test_snapping_moves_a_smoothed_surface_onto_the_points_and_leaves_unseen_parts() -> None:
    rng = np.random.default_rng(1)
    radius = 0.05
    directions = rng.normal(size=(40_000, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    directions = directions[directions[:, 2] > 0]  # points on the upper half only
    points = 0.1 * np.array([0, 0, 1.0]) + radius * directions
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=radius + 0.0008)  # 0.8 mm too big
    sphere.apply_translation([0, 0, 0.1])
    snapped = snap_to_points(sphere, points, directions, voxel_size_m=0.0015)
    error = np.linalg.norm(snapped.vertices - [0, 0, 0.1], axis=1) - radius
    upper = sphere.vertices[:, 2] > 0.1 + 0.1 * radius
    lower = sphere.vertices[:, 2] < 0.1 - 0.1 * radius
    assert np.abs(error[upper]).mean() < 0.00005, f"{np.abs(error[upper]).mean() * 1000:.3f} mm"
    assert np.allclose(snapped.vertices[lower], sphere.vertices[lower])  # no points there: unchanged
    assert snapped.is_watertight


def test_the_outlier_filter_drops_strays_and_clumps_off_a_cup_wall_and_keeps_its_rim() -> None:
    """A cup's wall (radius 40 mm, 30 mm tall, open at the top) sampled about once a 1.5 mm
    voxel, as the merge's centroids lie: every wall point stays, its top rim included (fewer
    neighbours there); a lone point, a pair and a clump of four, 6 mm outside the wall, go. The
    clump passes the strays' rule (each has three others within 2 voxels) and goes by the
    clumps' (fewer than 5 within 3)."""
    voxel = 0.0015
    rng = np.random.default_rng(3)
    angles = np.arange(0.0, 2 * np.pi, voxel / 0.04)
    heights = np.arange(0.0, 0.03, voxel)
    angle, height = (grid.ravel() for grid in np.meshgrid(angles, heights))
    wall = np.column_stack([0.04 * np.cos(angle), 0.04 * np.sin(angle), height])
    wall += rng.uniform(-0.2, 0.2, wall.shape) * voxel
    rim = height == heights[-1]
    off = np.array([0.046, 0.0, 0.015])  # 6 mm outside the wall
    clump = off + np.array([[0.0, 0.0, 0.0], [0.0, 0.0012, 0.0], [0.0, 0.0, 0.0012], [0.0, 0.0012, 0.0012]])
    pair = off + np.array([[0.0, 0.01, 0.0], [0.0, 0.0112, 0.0]])
    lone = off + np.array([[0.0, -0.01, 0.0]])
    points = np.concatenate([wall, clump, pair, lone])
    cloud = MergedCloud(
        points=points,
        colors=np.column_stack([np.arange(len(points)), np.zeros((len(points), 2))]),  # which point each is
        view_dirs=np.tile([1.0, 0.0, 0.0], (len(points), 1)),
        counts=np.ones(len(points), dtype=np.int64),
    )
    kept = remove_outliers(cloud, MeshingOptions(), voxel).colors[:, 0].astype(int)
    assert np.array_equal(kept, np.arange(len(wall)))  # the wall whole, rim included, nothing else
    assert rim.sum() > 150 and np.all(np.isin(np.flatnonzero(rim), kept))
    without_clumps = remove_outliers(cloud, MeshingOptions(clump_neighbours=0), voxel).colors[:, 0].astype(int)
    assert np.array_equal(without_clumps, np.arange(len(wall) + len(clump)))  # the clump stays, the pair and lone go


def test_the_gutter_takes_each_empty_texels_colour_from_a_nearest_painted_texel() -> None:
    """Every painted texel a colour of its own, so a texel's colour names its source: each empty
    texel's lies at the least chessboard distance, and gutter_px stops the fill at that distance."""
    size = 48
    rng = np.random.default_rng(3)
    flat = np.sort(rng.choice(size * size, 300, replace=False))  # scattered: distances up to several texels
    rows, cols = np.divmod(flat, size)
    texels = Texels(
        size_px=size, rows=rows, cols=cols, corners=np.zeros((300, 3), int), weights=np.zeros((300, 3)), vertices=np.zeros((1, 3))
    )
    colours = np.stack([flat // 256 + 1, flat % 256, np.full(300, 7)], axis=1).astype(np.uint8)  # no painted texel is black
    image = texels.paint(colours)
    source = (image[..., 0].astype(int) - 1) * 256 + image[..., 1]  # the flat index each texel copied
    assert np.isin(source, flat).all() and (image[..., 2] == 7).all()
    grid_rows, grid_cols = np.divmod(np.arange(size * size), size)
    to_all = np.maximum(np.abs(grid_rows[:, None] - rows), np.abs(grid_cols[:, None] - cols))  # (texels, painted)
    source_rows, source_cols = np.divmod(source.ravel(), size)
    chosen = np.maximum(np.abs(grid_rows - source_rows), np.abs(grid_cols - source_cols))
    assert np.array_equal(chosen, to_all.min(axis=1)) and to_all.min(axis=1).max() >= 3
    gutter = texels.paint(colours, gutter_px=1)
    filled = (gutter != 0).any(axis=2).ravel()
    assert np.array_equal(filled, to_all.min(axis=1) <= 1)
    assert np.array_equal(gutter.reshape(-1, 3)[filled], image.reshape(-1, 3)[filled])


def test_the_texture_carrier_stays_closed_and_on_the_surface() -> None:
    sphere = trimesh.creation.icosphere(subdivisions=6, radius=0.05)  # 81,920 faces
    colors = (sphere.vertices - sphere.vertices.min(axis=0)) / np.ptp(sphere.vertices, axis=0)
    small, nearest = carrier(sphere, 12_000)
    assert 11_000 <= len(small.faces) <= 12_000 and small.is_watertight
    assert np.abs(np.linalg.norm(small.vertices, axis=1) - 0.05).max() < 0.0005
    # Each vertex's colour comes from its nearest original vertex (checked by brute force on a
    # hundred of them), so it follows the position.
    some = np.arange(0, len(small.vertices), len(small.vertices) // 100)
    squared = np.sum((small.vertices[some, None] - sphere.vertices[None]) ** 2, axis=2)
    assert np.array_equal(np.sum((small.vertices[some] - sphere.vertices[nearest[some]]) ** 2, axis=1), squared.min(axis=1))
    expected = (small.vertices - sphere.vertices.min(axis=0)) / np.ptp(sphere.vertices, axis=0)
    assert np.abs(colors[nearest] - expected).max() < 0.05
    kept, every = carrier(sphere, 100_000)
    assert kept is sphere and np.array_equal(every, np.arange(len(sphere.vertices)))


def test_runs_read_apart_hand_over_every_reading_in_order_and_a_failing_run_stops_the_others() -> None:
    """The poses stage's runs, each on a thread of its own: every reading reaches the caller's
    thread, each run's in its order; a run that fails raises its error there and the other
    runs end at their next frame instead of reading to their end."""
    import threading
    import time

    from turntable.reconstruct import _read_runs

    runs = [[f"a{i}" for i in range(40)], [f"b{i}" for i in range(40)]]
    kept: list[str] = []
    callers: set[int] = set()

    def keep(item: str) -> None:
        kept.append(item)
        callers.add(threading.get_ident())

    _read_runs(runs, lambda k, run, hand_over: [hand_over(frame) for frame in run], keep)
    assert sorted(kept) == sorted(runs[0] + runs[1])
    assert [f for f in kept if f[0] == "a"] == runs[0] and [f for f in kept if f[0] == "b"] == runs[1]
    assert callers == {threading.get_ident()}

    failed = threading.Event()

    def read_run(k: int, run: list[str], hand_over) -> None:  # noqa: ANN001
        for i, frame in enumerate(run):
            if k == 1 and i == 3:
                failed.set()
                raise ValueError(f"{frame}: unreadable")
            if k == 0 and i == 2:
                failed.wait(10)
                time.sleep(0.5)  # the failing run's thread has told the runs to stop by now
            hand_over(frame)

    kept.clear()
    with pytest.raises(ValueError, match="b3: unreadable"):
        _read_runs(runs, read_run, keep)
    assert [f for f in kept if f[0] == "a"] == ["a0", "a1"] and [f for f in kept if f[0] == "b"] == ["b0", "b1", "b2"]


def _tags_image() -> np.ndarray:
    """Tags 4 to 7 on white, 60, 40, 14 and 12 px wide (AprilTag's 2x decimation misses the small ones)."""
    image = np.full((120, 320), 255, np.uint8)
    for tag_id, (left, side) in zip(range(4, 8), [(10, 60), (90, 40), (150, 14), (180, 12)]):
        cells = np.ones((10, 10), bool)
        cells[1:-1, 1:-1] = tag_bits(tag_id)
        image[30 : 30 + side, left : left + side] = np.kron(cells, np.ones((side, side), np.uint8))[:: 10, :: 10][:side, :side] * 255
    return image


def test_one_detector_serves_each_decimation_as_a_new_one_would(monkeypatch: pytest.MonkeyPatch) -> None:
    """The tag search's detectors are kept and reused at any decimation (its field set before
    each search): a reused one finds what a new one at that decimation finds."""
    image = _tags_image()
    coarse, fine = DetectionOptions(decimate=2.0, edge_refinement=False), DetectionOptions(decimate=1.0, edge_refinement=False)
    found = {}
    for options in (coarse, fine):  # each by a detector of its own
        monkeypatch.setattr(tags, "_idle_detectors", {})
        found[options.decimate] = detect_tags(image, options)
    assert set(found[1.0]) == {4, 5, 6, 7} and set(found[2.0]) < set(found[1.0])  # the decimation matters here
    monkeypatch.setattr(tags, "_idle_detectors", {})
    monkeypatch.setattr(tags, "_detectors_built", {})
    for options in (fine, coarse, fine, coarse):  # one detector, turned from one to the other
        reused = detect_tags(image, options)
        assert reused.keys() == found[options.decimate].keys()
        assert all(np.array_equal(reused[i], found[options.decimate][i]) for i in reused)
    assert len(tags._idle_detectors[1]) == 1 and tags._detectors_built == {1: 1}
    # Built ahead up to a count: the searches then build none.
    prepare_detectors(fine, 2)
    assert len(tags._idle_detectors[1]) == 2 and tags._detectors_built == {1: 2}
    prepare_detectors(fine, 2)
    assert len(tags._idle_detectors[1]) == 2
    # Another table (for 2 bit errors) is a detector of its own.
    detect_tags(image, DetectionOptions(max_hamming=2))
    assert len(tags._idle_detectors[1]) == 2 and len(tags._idle_detectors[2]) == 1


def test_a_reconstruction_runs_without_numpys_huge_pages_and_gives_the_setting_back() -> None:
    """`_small_pages` turns NumPy's madvise(MADV_HUGEPAGE) off for the stages and restores the
    caller's setting, whichever it was, also when a stage raises; of reconstructions running at
    once (overlapping on threads), the last to end restores it."""
    from numpy._core.multiarray import _get_madvise_hugepage, _set_madvise_hugepage

    from turntable.reconstruct import _small_pages

    caller = _get_madvise_hugepage()
    try:
        for setting in (True, False):
            _set_madvise_hugepage(setting)
            with pytest.raises(RuntimeError, match="a stage failed"), _small_pages():
                assert _get_madvise_hugepage() is False
                raise RuntimeError("a stage failed")
            assert _get_madvise_hugepage() is setting
        _set_madvise_hugepage(True)
        first, second = _small_pages(), _small_pages()
        first.__enter__()
        second.__enter__()
        first.__exit__(None, None, None)  # the first ends while the second still runs
        assert _get_madvise_hugepage() is False
        second.__exit__(None, None, None)
        assert _get_madvise_hugepage() is True
    finally:
        _set_madvise_hugepage(caller)


def test_the_signed_distances_dilation_is_scipys_with_its_cross_up_to_the_border() -> None:
    """`meshing._dilated` (six shifted ORs a round) against SciPy's `binary_dilation` with its
    default cross: sparse and dense masks, True voxels on every face of the grid, 1 to 3 rounds."""
    from scipy import ndimage

    from turntable.meshing import _dilated

    rng = np.random.default_rng(3)
    for density in (0.002, 0.05, 0.4):
        mask = rng.random((9, 7, 11)) < density
        mask[0, 3, 4] = mask[-1, 2, 2] = mask[4, 0, 5] = mask[2, -1, 1] = mask[5, 5, 0] = mask[3, 1, -1] = True
        for iterations in (1, 2, 3):
            assert np.array_equal(_dilated(mask, iterations), ndimage.binary_dilation(mask, iterations=iterations))
    assert np.array_equal(_dilated(mask, 0), mask)


def _probe(shift_px: int) -> tuple[np.ndarray, np.ndarray]:
    """A probe's depth and grey images: a near square on a far wall, its colour `shift_px` right."""
    depth = np.full((120, 160), 1.0, np.float32)
    depth[40:80, 50:110] = 0.6
    gray = np.full((120, 160), 40, np.uint8)
    gray[40:80, 50 + shift_px : 110 + shift_px] = 200
    return depth, gray


@pytest.mark.parametrize(("first_half_px", "probed"), [(0, 4), (1, 8), (3, 4)])
def test_misregistration_probes_stop_at_half_when_those_settle_the_warning(first_half_px: int, probed: int) -> None:
    """The first half read 0 px (1.5 from the warning) or 3 px (1.5 beyond it): settled; 1 px
    (0.5 from it, not more): the rest are probed too. The other half read 2 px either way."""
    from turntable.reconstruct import FrameReading, misregistration_offsets

    readings = {
        f"{k:06d}": FrameReading(stem=f"{k:06d}", pose="", sharpness=1.0, probe_images=_probe(2 if k % 2 else first_half_px))
        for k in range(8)
    }
    offsets = misregistration_offsets(readings, np.zeros(2), 1.5)
    assert len(offsets) == probed
    assert all(np.allclose(offset, [2 if int(stem) % 2 else first_half_px, 0], atol=0.3) for stem, offset in offsets.items())
