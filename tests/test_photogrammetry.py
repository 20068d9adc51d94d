"""photogrammetry: the stages on generated inputs with known answers, and bad input."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
import trimesh

from homemodel.core.errors import InputError
from homemodel.core.transforms import world_from_camera_looking_at
from homemodel.geometry.camera import Camera
from photogrammetry.cleaning import CleaningOptions, face_the_cameras, mesh_object, segment_object
from photogrammetry.markers import aruco_dictionary, detect_markers, triangulate_markers
from photogrammetry.metric_frame import metric_frame
from photogrammetry.photos import list_photos
from photogrammetry.support_plane import find_support_plane, focus_point

CAMERA = Camera(width=800, height=600, fx=800.0, fy=800.0, cx=399.5, cy=299.5)


def _ring_cameras(n: int, radius: float, height: float, target=(0.0, 0.0, 0.0)) -> list[np.ndarray]:
    angles = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return [np.linalg.inv(world_from_camera_looking_at((radius * np.cos(a), radius * np.sin(a), height), target)) for a in angles]


# ---------------------------------------------------------------- photos


def test_list_photos_ignores_other_files_and_sorts(tmp_path: Path) -> None:
    for name in ("b.png", "a.JPG"):
        cv2.imwrite(str(tmp_path / name), np.full((80, 100, 3), 128, np.uint8))
    (tmp_path / "notes.txt").write_text("not a photo")
    (tmp_path / "._a.JPG").write_bytes(b"\x00\x05\x16\x07" + bytes(80))  # macOS's AppleDouble metadata
    assert [p.name for p in list_photos(tmp_path)] == ["a.JPG", "b.png"]


def test_list_photos_names_the_corrupt_file(tmp_path: Path) -> None:
    cv2.imwrite(str(tmp_path / "good.png"), np.zeros((100, 100, 3), np.uint8))
    (tmp_path / "broken.jpg").write_bytes(b"\xff\xd8\xff\xe0 this is not really a jpeg")
    with pytest.raises(InputError, match="broken.jpg: not a readable image"):
        list_photos(tmp_path)


@pytest.mark.parametrize("case", ["missing", "empty", "tiny"])
def test_list_photos_refuses_unusable_folders(tmp_path: Path, case: str) -> None:
    folder = tmp_path / "photos"
    if case != "missing":
        folder.mkdir()
    if case == "tiny":
        cv2.imwrite(str(folder / "tiny.png"), np.zeros((20, 20, 3), np.uint8))
    expected = {"missing": "not a folder", "empty": "holds no photos", "tiny": "tiny.png: 20x20 px is too small"}[case]
    with pytest.raises(InputError, match=expected):
        list_photos(folder)


# ---------------------------------------------------------------- markers and the metric frame


def _marker_photo(camera_from_world: np.ndarray, markers: dict[int, np.ndarray], dictionary: str) -> np.ndarray:
    """A photo of flat markers (world corners, OpenCV order) on a white table, drawn by homography."""
    d = aruco_dictionary(dictionary)
    photo = np.full((600, 800), 255, np.uint8)
    side_px = (d.markerSize + 2) * 20
    for marker_id, corners in markers.items():
        tag = cv2.aruco.generateImageMarker(d, marker_id, side_px)
        camera = corners @ camera_from_world[:3, :3].T + camera_from_world[:3, 3]
        px = CAMERA.project(camera).astype(np.float32)
        # Tag image corners in OpenCV's order: the outer corners of its pixel grid.
        src = np.array([[0, 0], [side_px, 0], [side_px, side_px], [0, side_px]], np.float32) - 0.5
        warp = cv2.getPerspectiveTransform(src, px)
        drawn = cv2.warpPerspective(tag, warp, (800, 600), flags=cv2.INTER_AREA, borderValue=255)
        mask = cv2.warpPerspective(np.ones_like(tag), warp, (800, 600), flags=cv2.INTER_NEAREST) > 0
        photo[mask] = drawn[mask]
    return photo


def _square(centre_xy, size: float, yaw: float) -> np.ndarray:
    h = size / 2
    c, s = np.cos(yaw), np.sin(yaw)
    local = np.array([[-h, h], [h, h], [h, -h], [-h, -h]])  # top-left, top-right, bottom-right, bottom-left
    xy = local @ np.array([[c, s], [-s, c]]) + centre_xy
    return np.column_stack([xy, np.zeros(4)])


def test_markers_give_scale_origin_and_axes() -> None:
    """Markers of 5 cm seen by a ring of cameras in a frame scaled by 1/7.3, rotated and shifted:
    the metric frame recovers the scale, puts marker 3's centre at the origin and its top edge on x."""
    size_m = 0.05
    markers = {
        3: _square((0.1, 0.05), size_m, 0.3),
        7: _square((-0.12, 0.02), size_m, 1.1),
        9: _square((0.0, -0.14), size_m, -0.5),
    }
    cameras = _ring_cameras(8, 0.45, 0.35)
    sightings = []
    for i, camera_from_world in enumerate(cameras):
        photo = _marker_photo(camera_from_world, markers, "4x4_50")
        sightings += detect_markers(photo, f"v{i}", "4x4_50")
    assert {s.marker_id for s in sightings} == {3, 7, 9}
    # The SfM frame: world scaled down, rotated about a tilted axis, moved.
    sfm_from_world = np.eye(4)
    rotation = trimesh.transformations.rotation_matrix(0.7, [0.3, -0.5, 0.8])[:3, :3]
    sfm_from_world[:3, :3] = rotation / 7.3
    sfm_from_world[:3, 3] = [0.4, -1.2, 2.0]
    world_from_sfm = np.linalg.inv(sfm_from_world)
    projections = {}
    for i, camera_from_world in enumerate(cameras):
        camera_from_sfm = camera_from_world @ world_from_sfm
        camera_from_sfm[:3, :] /= 7.3  # SfM cameras live in SfM units too
        projections[f"v{i}"] = CAMERA.matrix @ camera_from_sfm[:3, :]
    triangulated = triangulate_markers(sightings, projections)
    assert [m.marker_id for m in triangulated] == [3, 7, 9]
    frame = metric_frame(
        plane=None,
        markers=triangulated,
        marker_size_m=size_m,
        object_centre_sfm=np.zeros(3),
        x_hint_sfm=np.array([1.0, 0, 0]),
    )
    assert frame.scaled and frame.levelled
    assert frame.scale == pytest.approx(7.3, rel=0.003)
    # The expected model frame: marker 3's frame in the world.
    c, s = np.cos(0.3), np.sin(0.3)
    model_from_world = np.linalg.inv(np.array([[c, -s, 0, 0.1], [s, c, 0, 0.05], [0, 0, 1, 0], [0, 0, 0, 1.0]]))
    test_points = np.array([[0.1, 0.05, 0.0], [0.0, 0.0, 0.1], [-0.2, 0.1, 0.05]])
    expected = test_points @ model_from_world[:3, :3].T + model_from_world[:3, 3]
    in_sfm = test_points @ sfm_from_world[:3, :3].T + sfm_from_world[:3, 3]
    assert np.abs(frame.apply(in_sfm) - expected).max() < 0.5e-3  # half a millimetre


def test_no_markers_keeps_sfm_units_and_says_so() -> None:
    frame = metric_frame(
        plane=None, markers=[], marker_size_m=None, object_centre_sfm=np.ones(3), x_hint_sfm=np.array([1.0, 0, 0])
    )
    assert not frame.scaled and frame.scale == 1.0
    assert np.allclose(frame.apply(np.ones((1, 3))), 0)


def test_focus_point_is_where_the_cameras_look() -> None:
    target = np.array([0.3, -0.2, 0.1])
    cameras = _ring_cameras(10, 1.0, 0.6, target)
    centres = np.array([np.linalg.inv(c)[:3, 3] for c in cameras])
    axes = np.array([c[2, :3] for c in cameras])
    assert np.allclose(focus_point(centres, axes), target, atol=1e-9)


# ---------------------------------------------------------------- support plane and cleaning


def _table_scene(rng: np.random.Generator):
    """A 0.1 m radius, 0.15 m tall cylinder standing on a noisy 1 m table, plus a far-off clutter
    blob and random outliers; the table tilted and shifted as SfM would leave it."""
    table = np.column_stack([rng.uniform(-0.5, 0.5, (60000, 2)), rng.normal(0, 0.0008, 60000)])
    angle = rng.uniform(0, 2 * np.pi, 30000)
    height = rng.uniform(0, 0.15, 30000)
    side = np.column_stack([0.1 * np.cos(angle), 0.1 * np.sin(angle), height])
    r = 0.1 * np.sqrt(rng.uniform(0, 1, 8000))
    a = rng.uniform(0, 2 * np.pi, 8000)
    top = np.column_stack([r * np.cos(a), r * np.sin(a), np.full(8000, 0.15)])
    obj = np.vstack([side, top])
    clutter = rng.normal([0.4, 0.35, 0.05], 0.02, (3000, 3))
    outliers = rng.uniform([-0.5, -0.5, 0.0], [0.5, 0.5, 0.3], (300, 3))
    points = np.vstack([table, obj, clutter, outliers])
    normals_out = np.vstack(
        [np.tile([0, 0, 1.0], (len(table), 1)), np.column_stack([np.cos(angle), np.sin(angle), np.zeros_like(angle)]),
         np.tile([0, 0, 1.0], (8000, 1)), np.tile([0, 0, 1.0], (3300, 1))]
    )  # fmt: skip
    return points, normals_out, len(table)


def test_support_plane_found_and_removed_object_kept(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    points, to_camera, n_table = _table_scene(rng)
    world_from_sfm = trimesh.transformations.rotation_matrix(0.4, [1.0, 0.2, 0.0])
    world_from_sfm[:3, 3] = [0.2, 0.1, -0.3]
    sfm_points = points @ np.linalg.inv(world_from_sfm)[:3, :3].T + np.linalg.inv(world_from_sfm)[:3, 3]
    cameras = _ring_cameras(12, 0.6, 0.45, (0, 0, 0.07))
    camera_from_sfm = np.array([c @ world_from_sfm for c in cameras])
    focus = sfm_points[n_table : n_table + 38000].mean(axis=0)
    plane = find_support_plane(sfm_points, sfm_points[n_table:], camera_from_sfm, focus, threshold=0.003)
    assert plane is not None
    true_normal = np.linalg.inv(world_from_sfm)[:3, :3] @ [0, 0, 1.0]
    assert np.degrees(np.arccos(min(1.0, plane.normal @ true_normal))) < 0.5
    assert np.abs(plane.height(sfm_points[:n_table])).mean() < 0.002

    scene_scale = 0.6
    frame = metric_frame(plane=plane, markers=[], marker_size_m=None, object_centre_sfm=sfm_points[n_table:].mean(axis=0),
                         x_hint_sfm=np.array([1.0, 0, 0]))  # fmt: skip
    model_points = frame.apply(sfm_points)
    obj = segment_object(model_points, np.zeros_like(points), to_camera @ world_from_sfm[:3, :3] @ frame.model_from_sfm[:3, :3].T,
                         model_points[n_table:n_table + 38000].mean(axis=0), scene_scale, CleaningOptions())  # fmt: skip
    heights = obj.points[:, 2]
    assert heights.min() > 0.002  # the table is gone
    radial = np.linalg.norm(obj.points[:, :2] - obj.points[:, :2].mean(axis=0), axis=1)
    assert radial.max() < 0.11  # the clutter and the outliers around are gone
    assert len(obj.points) > 0.9 * 38000 * (1 - 0.006 * scene_scale / 0.15)

    mesh = mesh_object(obj, scene_scale, CleaningOptions())
    truth = trimesh.creation.cylinder(radius=0.1, height=0.15, sections=128)
    truth.apply_translation([0, 0, 0.075])
    centred = mesh.copy()
    centred.apply_translation([*-obj.points[:, :2].mean(axis=0), 0])
    from homemodel.evaluation import mean_surface_distance_m

    assert mesh.bounds[0, 2] == pytest.approx(0.0, abs=1e-6)  # cut at the support plane ...
    assert mean_surface_distance_m(centred, truth) < 0.0025  # ... with the bottom closed like the truth's
    assert abs(mesh.extents[2] - 0.15) < 0.003


def _front_of_an_arrangement(width: float, rng: np.random.Generator):
    """Points of a bumpy sheet standing on z = 0, seen from one side only (normals towards -y):
    what the Kermit photos see of the arrangement on the chair."""
    from photogrammetry.cleaning import ObjectPoints

    x, z = rng.uniform(-width / 2, width / 2, 60_000), rng.uniform(0.05, 0.7 * width, 60_000)
    points = np.column_stack([x, 0.05 * width * np.sin(6 * x / width) * np.cos(5 * z / width), z])
    normals = np.tile([0.0, -1.0, 0.0], (len(points), 1))
    return ObjectPoints(points=points, normals=normals, colours=np.zeros_like(points), removed_plane_points=0,
                        dropped_pieces=0)  # fmt: skip


@pytest.mark.parametrize("width", [4.7, 5.0])
def test_a_scan_seen_from_one_side_meshes_to_its_own_size(width: float) -> None:
    """Poisson's surface of a one-sided scan runs on to the faces of its octree's cube, which
    doubles in size between these two widths (finest cells 0.042 wide: 128 or 256 of them).
    The mesh keeps to where the points are (it measured 5.43 wide for 4.7 and 10.86 for 5.0
    before the cut)."""
    scene_scale = 7.07  # Kermit's: the cells are 3 voxels of 0.2 % of it
    options = CleaningOptions()
    mesh = mesh_object(_front_of_an_arrangement(width, np.random.default_rng(0)), scene_scale, options)
    reach = options.max_fill_fraction * scene_scale
    assert mesh.extents[0] < width + 2 * reach and mesh.extents[2] < 0.7 * width + 2 * reach
    assert mesh.extents[1] < 0.1 * width + 2 * reach
    assert mesh.extents[0] > width - reach  # the sheet itself is all there


@pytest.mark.parametrize("apart", [0.9, 1.1])
def test_pieces_join_across_gaps_shorter_than_the_gap_only(apart: float) -> None:
    """Two sheets `apart` gaps from each other (and a lone stray point far off): one piece
    when nearer than the gap, two when further, the stray in none."""
    from photogrammetry.cleaning import piece_labels

    rng = np.random.default_rng(1)
    gap = 0.05
    sheet = np.column_stack([rng.uniform(0, 1, 20_000), rng.uniform(0, 1, 20_000), np.zeros(20_000)])
    points = np.vstack([sheet, sheet + [1 + apart * gap, 0, 0], [[5.0, 5.0, 5.0]]])
    labels = piece_labels(points, gap)
    assert labels[-1] == -1
    assert len(np.unique(labels[:-1])) == (1 if apart < 1 else 2)
    assert len(np.unique(labels[:20_000])) == 1 and len(np.unique(labels[20_000:-1])) == 1


@pytest.mark.parametrize("pairs", [1, 2, 3, 4, 5])
def test_agreeing_depth_is_the_mean_of_the_depths_near_their_median(pairs: int) -> None:
    from photogrammetry.stereo import DenseOptions, _agreeing_depth

    rng = np.random.default_rng(pairs)
    candidates = rng.uniform(1.0, 1.03, (pairs, 30, 40)).astype(np.float32)
    candidates[rng.random(candidates.shape) < 0.3] = 0  # no match in that pair
    options = DenseOptions()
    expected = np.zeros((30, 40), np.float32)
    for row, col in np.ndindex(30, 40):
        found = candidates[:, row, col][candidates[:, row, col] > 0]
        if len(found):
            agree = found[np.abs(found - np.median(found)) <= options.depth_tolerance * np.median(found)]
            expected[row, col] = agree.mean() if len(agree) >= options.min_agreeing_pairs else 0
    assert np.allclose(_agreeing_depth(candidates, options), expected, rtol=1e-6, atol=0)
    assert (expected > 0).any() == (pairs >= options.min_agreeing_pairs)


def test_sparse_points_drop_a_wrong_pair_and_let_one_confirmed_pair_stand_alone() -> None:
    from photogrammetry.stereo import DenseOptions, checked_depth, sparse_verdict

    options = DenseOptions()
    rng = np.random.default_rng(0)
    truth = rng.uniform(2.0, 3.0, (30, 40)).astype(np.float32)
    pixels = np.column_stack([rng.integers(0, 40, 50), rng.integers(0, 30, 50)])
    sparse_depths = truth[pixels[:, 1], pixels[:, 0]]
    good, other_good, wrong = truth * 1.002, truth * 0.998, truth * 1.3  # wrong: a mismatched pair
    unseen = np.where(np.arange(40) < 20, good, 0).astype(np.float32)
    unseen[pixels[:, 1], pixels[:, 0]] = 0  # covers no sparse point: no verdict
    assert [sparse_verdict(d, pixels, sparse_depths, options) for d in (good, wrong, unseen)] == [True, False, None]
    # One confirmed pair beside a refuted one: its own depth, where the two never agreed.
    assert np.array_equal(checked_depth([good, wrong], [True, False], options), good)
    # Two confirmed pairs: their agreeing mean, the refuted pair out of the vote.
    both = checked_depth([good, other_good, wrong], [True, True, False], options)
    assert np.allclose(both, truth, rtol=1e-5)
    # Nothing confirmed: the pairs must agree as before (one pair alone gives nothing).
    assert not checked_depth([unseen, wrong], [None, False], options).any()


# The relative pose of one of Kermit's strongly converging pairs (21.6 deg about y, 10 deg of
# roll): OpenCV's rectification that keeps every pixel gives it a negative focal length.
KERMIT_PAIR_ROTATION_DEG = (-4.1, 21.6, 10.0)
KERMIT_PAIR_TRANSLATION = (-2.309, -0.595, 1.369)


@pytest.mark.parametrize("pose", ["kermit", "kermit reversed", "gentle"])
def test_a_pair_depth_matches_a_textured_plane_even_where_opencv_rectifies_it_with_a_negative_focal(pose: str) -> None:
    from photogrammetry.stereo import DenseOptions, _pair_depth

    w, h, f, plane_z = 640, 473, 674.5, 7.0
    camera = Camera(width=w, height=h, fx=f, fy=f, cx=(w - 1) / 2, cy=(h - 1) / 2)
    src_from_ref = np.eye(4)
    if pose == "gentle":  # a plain pair, rectified as OpenCV does it
        src_from_ref[:3, 3] = (-1.0, 0.0, 0.0)
    else:
        src_from_ref[:3, :3] = cv2.Rodrigues(np.radians(KERMIT_PAIR_ROTATION_DEG))[0]
        src_from_ref[:3, 3] = KERMIT_PAIR_TRANSLATION
        if pose == "kermit reversed":
            src_from_ref = np.linalg.inv(src_from_ref)
    size = (round(w * 1.2), round(h * 1.2))
    p1 = cv2.stereoRectify(camera.matrix, None, camera.matrix, None, (w, h), src_from_ref[:3, :3], src_from_ref[:3, 3],
                           flags=cv2.CALIB_ZERO_DISPARITY, alpha=1, newImageSize=size)[2]  # fmt: skip
    assert (p1[0, 0] < 0) == (pose != "gentle")
    # A fronto-parallel plane at z = 7 in the reference's frame, covered by a blurred noise
    # texture of 2 cm texels; each view is that texture through the plane's homography.
    texture = cv2.GaussianBlur(np.random.default_rng(0).integers(0, 256, (1600, 1600, 3), dtype=np.uint8), (0, 0), 1.5)
    texel_m, corner = 0.02, np.array([-16.0, -16.0, plane_z])

    def view(camera_from_ref: np.ndarray) -> np.ndarray:
        r, t = camera_from_ref[:3, :3], camera_from_ref[:3, 3]
        texture_to_image = camera.matrix @ np.column_stack([r[:, 0] * texel_m, r[:, 1] * texel_m, r @ corner + t])
        return cv2.warpPerspective(texture, texture_to_image, (w, h), flags=cv2.INTER_LINEAR)

    depth = _pair_depth(view(np.eye(4)), view(src_from_ref), camera, camera, src_from_ref, (4.2, 14.0), DenseOptions())
    found = depth[depth > 0]
    assert len(found) > 0.2 * w * h, len(found) / (w * h)
    assert abs(np.median(found) - plane_z) < 0.005 * plane_z and np.mean(np.abs(found - plane_z) < 0.02 * plane_z) > 0.95


def test_an_open_surface_is_wound_to_face_the_cameras_and_a_closed_one_is_left_outward() -> None:
    """A surface seen from one side has no inside: wound away from the cameras (as the repair
    left Kermit with two broken-EXIF photos), it is inverted; wound towards them, or closed, it
    is returned as it is."""
    patch = trimesh.creation.box(extents=(1.0, 1.0, 0.2))
    patch.update_faces(patch.face_normals[:, 2] > 0.5)  # the top only: an open square facing +z
    above = np.array([[0.0, -2.0, 2.0], [2.0, 0.0, 2.0], [0.0, 0.0, 3.0]])
    assert face_the_cameras(patch, above) is patch
    away = patch.copy()
    away.invert()
    facing = face_the_cameras(away, above)
    assert np.allclose(facing.face_normals[:, 2], 1.0)
    box = trimesh.creation.box()
    assert face_the_cameras(box, np.zeros((1, 3))) is box  # closed: outward, wherever the cameras are
    flat = trimesh.Trimesh(vertices=[[0, 0, 0], [1, 0, 0], [2, 0, 0]], faces=[[0, 1, 2]], process=False)
    assert face_the_cameras(flat, above) is flat  # no area: nothing to aim a ray at (was a bare ValueError)


def test_an_open_tube_seen_from_all_round_is_wound_outward() -> None:
    """Cameras all round a tube open at both ends (Buddha's lowest band gave a head open at the
    crown): any one face has most of them behind it, yet what each camera sees first faces it.
    Wound outward the tube is left; wound inward it is inverted (the vote of the cameras on each
    face's front side inverted the outward one and kept the inward one)."""
    tube = trimesh.creation.cylinder(radius=0.3, height=1.0, sections=48)
    tube.update_faces(np.abs(tube.face_normals[:, 2]) < 0.5)
    tube.remove_unreferenced_vertices()
    angles = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    around = np.column_stack([np.cos(angles), np.sin(angles), np.full(12, 0.1)])
    assert face_the_cameras(tube, around) is tube
    inward = tube.copy()
    inward.invert()
    outward = face_the_cameras(inward, around)
    assert np.all(np.einsum("ij,ij->i", outward.face_normals, outward.triangles_center * [1, 1, 0]) > 0)


def test_an_unseen_bottom_is_closed_and_a_high_opening_left_open() -> None:
    """`close_bottom_holes`: a tube standing on the plane, open at both ends: the hole whose border
    stays below `top` (its bottom, no photo sees it) is closed by a fan, the one at its top is not."""
    from photogrammetry.cleaning import close_bottom_holes

    tube = trimesh.creation.cylinder(radius=0.05, height=0.2, sections=32)
    tube.apply_translation([0.0, 0.0, 0.1])
    height = tube.triangles_center[:, 2]
    tube = trimesh.Trimesh(tube.vertices, tube.faces[(height > 1e-6) & (height < 0.2 - 1e-6)], process=False)
    tube.remove_unreferenced_vertices()
    closed = close_bottom_holes(tube, top=0.1)
    edges, uses = np.unique(np.sort(closed.edges, axis=1), axis=0, return_counts=True)
    border = edges[uses == 1]
    assert len(border) == 32 and np.allclose(closed.vertices[border.ravel(), 2], 0.2)  # the top only
    assert close_bottom_holes(tube, top=0.25).is_watertight  # both borders below: both closed
