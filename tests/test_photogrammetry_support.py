"""The support surface under a photographed object: the cameras' common up, the level plane
under the object (synthetic scenes with known truth), and the cut on real sets (Kermit on his
chair, one side of the Buddha on its table): no surface left on or under the plane, and the
object above it as the reconstruction without the cut has it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import photo_runs
import pytest
import trimesh

from photogrammetry.support_plane import camera_up, find_support_plane, scene_up

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "photogrammetry"


def _look_at(centre: np.ndarray, target: np.ndarray, up: np.ndarray, roll_deg: float = 0.0) -> np.ndarray:
    """camera_from_world (OpenCV axes) of a camera at `centre` looking at `target`, turned by `roll_deg`."""
    z = target - centre
    z /= np.linalg.norm(z)
    x = np.cross(z, up)  # OpenCV: x right, y down
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    roll = np.radians(roll_deg)
    x, y = np.cos(roll) * x + np.sin(roll) * y, -np.sin(roll) * x + np.cos(roll) * y
    pose = np.eye(4)
    pose[:3, :3] = np.vstack([x, y, z])
    pose[:3, 3] = -pose[:3, :3] @ centre
    return pose


def _ring(up: np.ndarray, *, count: int = 12, height: float = 1.0, rolls: tuple[float, ...] = (0.0,)) -> np.ndarray:
    """Cameras round the origin at `height` along `up`, looking at the origin."""
    a = np.cross(up, [1.0, 0.0, 0.0] if abs(up[0]) < 0.9 else [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(up, a)
    poses = []
    for i, angle in enumerate(np.linspace(0, 2 * np.pi, count, endpoint=False)):
        centre = 1.5 * (np.cos(angle) * a + np.sin(angle) * b) + height * up
        poses.append(_look_at(centre, np.zeros(3), up, rolls[i % len(rolls)]))
    return np.array(poses)


def test_camera_up_is_level_with_upright_and_quarter_turned_photos() -> None:
    """Cameras looking down at 34 degrees: the mean of -y leans back by that, the level axes
    give up within a degree; a third of the photos turned a quarter (portrait, no EXIF turn)
    change nothing; and the sign says the cameras look down."""
    up = np.array([0.3, -0.2, 0.93])
    up /= np.linalg.norm(up)
    for rolls in ((0.0,), (0.0, 90.0, 0.0), (0.0, -90.0, 2.0)):
        found = camera_up(_ring(up, rolls=rolls)[:, :3, :3])
        assert np.degrees(np.arccos(np.clip(found @ up, -1, 1))) < 1.0, (rolls, found)
    with pytest.raises(ValueError, match="expected"):
        camera_up(np.zeros((3, 4, 4)))


def test_camera_up_of_upright_photos_looking_up_at_a_tall_object_points_up() -> None:
    """Upright photos taken below the middle of a tall object look up at it: their -y gives the
    sign (the cameras' look alone put such a model upside down); with most photos turned a
    quarter, -y cannot tell, and the cameras' look decides as before."""
    up = np.array([0.0, 0.0, 1.0])
    assert camera_up(_ring(up, height=-0.3)[:, :3, :3]) @ up > 0.99
    assert camera_up(_ring(up, height=1.0, rolls=(90.0, -90.0, 0.0))[:, :3, :3]) @ up > 0.99


def _head_on_a_stand(rng: np.random.Generator, *, stand: bool) -> np.ndarray:
    """Points (1 mm noise) of a 0.1 m radius cylinder from z = -0.2 to 0.2 under a dome to
    0.3, standing on a ring of table out to 0.2 m (`stand`); without it, the cylinder's flat
    foot is a dome too."""
    angle = rng.uniform(0, 2 * np.pi, 4000)
    side = np.column_stack([0.1 * np.cos(angle), 0.1 * np.sin(angle), rng.uniform(-0.2, 0.2, 4000)])
    dome = rng.normal(size=(1500, 3))
    dome = 0.1 * dome / np.linalg.norm(dome, axis=1, keepdims=True)
    dome[:, 2] = np.abs(dome[:, 2])
    parts = [side, dome + [0, 0, 0.2]]
    if stand:
        radius, angle = np.sqrt(rng.uniform(0.1**2, 0.2**2, 1500)), rng.uniform(0, 2 * np.pi, 1500)
        parts.append(np.column_stack([radius * np.cos(angle), radius * np.sin(angle), np.full(1500, -0.2)]))
    else:
        parts.append(dome * [1, 1, -1] - [0, 0, 0.2])
    points = np.vstack(parts)
    return points + rng.normal(0, 0.001, points.shape)


def test_scene_up_from_the_side_the_support_is_on_when_photos_turned_a_quarter_look_level() -> None:
    """Photos mostly turned a quarter (no EXIF turn) taken round a tall object from below its
    middle look up at it (Buddha's lowest band): the look-down rule turns it upside down, the
    side its stand is on does not; with no support in the points (a dome at either end), the
    points give no word and the cameras' look decides, as before."""
    rng = np.random.default_rng(5)
    up = np.array([0.0, 0.0, 1.0])
    poses = _ring(up, height=-0.08, rolls=(90.0, 90.0, 90.0, 90.0, 90.0, 0.0))  # two of 12 upright
    assert camera_up(poses[:, :3, :3]) @ up < -0.99  # the old rule's sign
    points = _head_on_a_stand(rng, stand=True)
    assert scene_up(points, points, poses, np.zeros(3), threshold=0.006) @ up > 0.99
    plane = find_support_plane(points, points, poses, np.zeros(3), threshold=0.006)
    assert plane is None  # the cameras do not look down on the stand: up only
    points = _head_on_a_stand(rng, stand=False)
    assert scene_up(points, points, poses, np.zeros(3), threshold=0.006) @ up < -0.99


def _scene(rng: np.random.Generator, *, table: bool) -> tuple[np.ndarray, np.ndarray]:
    """A 0.3 m box on a table (z = 0, 1 m square, 1 mm noise) with a wall behind (x = -0.45);
    all points, and the box's (what stays in every frame)."""
    box = []
    for axis in range(3):  # the box's five visible faces, 0.2 x 0.2 x 0.3 m
        for side in (0, 1) if axis < 2 else (1,):
            face = rng.uniform(0, 1, (1500, 3)) * [0.2, 0.2, 0.3] - [0.1, 0.1, 0.0]
            face[:, axis] = side * [0.2, 0.2, 0.3][axis] - [0.1, 0.1, 0.0][axis]
            box.append(face)
    box = np.vstack(box) + rng.normal(0, 0.001, (len(np.vstack(box)), 3))
    wall = np.column_stack([np.full(6000, -0.45), rng.uniform(-0.5, 0.5, 6000), rng.uniform(0, 0.8, 6000)])
    parts = [box, wall]
    if table:
        top = np.column_stack([rng.uniform(-0.45, 0.5, (8000, 2)), rng.normal(0, 0.001, 8000)])
        parts.append(top[np.abs(top[:, :2]).max(axis=1) > 0.1])  # none under the box
    return np.vstack(parts), box


def test_support_plane_is_the_table_under_the_object_not_the_wall_or_the_box_top() -> None:
    """Known truth: the table (z = 0) is found within a degree and a millimetre, though the wall
    behind holds more points and the box's top is a level plane too; without a table there is
    no support plane (the wall is not one, nor the box's top, which has the box below it)."""
    rng = np.random.default_rng(3)
    poses = _ring(np.array([0.0, 0.0, 1.0]), count=9, height=0.9, rolls=(0.0, 90.0, 3.0))
    points, box = _scene(rng, table=True)
    plane = find_support_plane(points, box, poses, np.array([0.0, 0.0, 0.15]), threshold=0.006)
    assert plane is not None
    assert np.degrees(np.arccos(min(plane.normal[2], 1.0))) < 1.0 and abs(plane.offset) < 0.001, plane.figures()
    points, box = _scene(rng, table=False)
    assert find_support_plane(points, box, poses, np.array([0.0, 0.0, 0.15]), threshold=0.006) is None


@pytest.fixture(scope="module")
def kermit_run() -> Path:
    """Kermit's default command, the run test_photogrammetry_pipeline checks (tests/photo_runs.py)."""
    return photo_runs.kermit_run(DATA)


@pytest.fixture(scope="module")
def buddha_side(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, np.ndarray]:
    """The 14 side photos' run (the one test_photogrammetry_registration checks), and the
    object's points of the same photos reconstructed without the cut, in the cut model's frame
    (the two runs share one SfM, and so its frame). From one side, what lies behind the head
    stays in every frame: the scene's fused points hold more than the object, so the object as
    the pipeline finds it without the cut is what the cut must keep."""
    scratch = tmp_path_factory.mktemp("buddha_side")
    run = photo_runs.buddha_side_runs(DATA, scratch)
    uncut = run / "uncut"
    cut_from_uncut = np.load(run / "model_from_sfm.npy") @ np.linalg.inv(np.load(uncut / "model_from_sfm.npy"))
    points = np.load(uncut / "object_points.npy")
    return run, points @ cut_from_uncut[:3, :3].T + cut_from_uncut[:3, 3]


def _check_cut(run: Path, kept: np.ndarray) -> dict:
    """The cut mesh leaves nothing of the support (no face below the plane beyond 0.3 % of the
    scene, no upward-facing surface lying on it beyond 1 % of the mesh's area) and keeps the
    object: the `kept` points (model frame) above the plane (plus a margin) lie on the cut mesh
    (95 % within 1 % of the object's size)."""
    figures = json.loads((run / "figures.json").read_text())
    assert figures["support_plane_found"] is True and figures["support_plane"]["inlier_share"] > 0.03
    mesh = trimesh.load(run / "mesh.ply", force="mesh")
    size = float(np.linalg.norm(mesh.extents))
    scene = size  # the model frame's unit: SfM units (no markers), z up from the plane
    heights = mesh.vertices[:, 2]
    assert heights.min() > -0.003 * scene
    # A skirt of the table: faces near z = 0 facing up (the flat bottom faces down).
    low = mesh.triangles[:, :, 2].max(axis=1) < 0.01 * size
    skirt = low & (mesh.face_normals[:, 2] > 0.7)
    assert mesh.area_faces[skirt].sum() < 0.01 * mesh.area, mesh.area_faces[skirt].sum() / mesh.area
    above = kept[kept[:, 2] > 0.03 * size]
    assert len(above) > 0.3 * len(kept), (len(above), len(kept))
    distance = np.abs(trimesh.proximity.signed_distance(mesh, above[:: max(1, len(above) // 5000)]))
    assert np.percentile(distance, 95) < 0.01 * size, np.percentile(distance, [50, 95]) / size
    return figures


@pytest.mark.shared_data
@pytest.mark.timeout(1200)  # the run, when the cache is cold and the cores are shared
def test_kermit_chair_seat_is_found_and_cut_with_kermit_intact(kermit_run: Path) -> None:
    """The plane is the seat, not a slab through the board and his legs lying on it: of the
    scene's fused points the photos keep in frame, 2.6 % lie below it (the seat's front edge and
    the chair's frame), where a plane through the board had 7.7 % (of a reconstruction without
    the cut); 95 % of the points above it lie within 0.70 % of the size of the cut mesh."""
    figures = _check_cut(kermit_run, np.load(kermit_run / "scene_points.npy"))
    assert figures["support_plane"]["tilt_from_camera_up_deg"] < 25
    size = float(np.linalg.norm(figures["extents"]))
    assert np.mean(np.load(kermit_run / "scene_points.npy")[:, 2] < -0.006 * size) < 0.04


@pytest.mark.shared_data
@pytest.mark.timeout(1800)  # two reconstructions when the cache is cold and the cores are shared
def test_buddha_table_is_found_and_cut_with_the_head_intact(buddha_side: tuple[Path, np.ndarray]) -> None:
    _check_cut(*buddha_side)


def _board_leaning_by_a_toy(rng: np.random.Generator, *, table_points: int) -> tuple[np.ndarray, np.ndarray]:
    """All points and the object's: the box of `_scene` with a toy's leg (a half cylinder,
    0.03 m radius) lying on the table beside it, a wall behind, `table_points` of the table
    (z = 0, 1 mm noise) and a board leaning 8 degrees on it behind the box (x < -0.15), whose
    plane runs on through the box's foot and over the leg: a near-level plane that cuts the
    object's base (Kermit's lap under the plane through the board)."""
    box = _scene(rng, table=False)[1]
    angle, along = rng.uniform(0, np.pi, 2000), rng.uniform(-0.15, 0.15, 2000)
    leg = np.column_stack([0.25 + 0.03 * np.cos(angle), along, 0.03 * np.sin(angle)])
    wall = np.column_stack([np.full(8000, -0.5), rng.uniform(-0.5, 0.5, 8000), rng.uniform(0, 0.8, 8000)])
    table = np.column_stack([rng.uniform(-0.5, 0.5, (4 * table_points, 2)), np.zeros(4 * table_points)])
    table = table[(np.abs(table[:, :2]).max(axis=1) > 0.1) & ((np.abs(table[:, 0] - 0.25) > 0.03) | (np.abs(table[:, 1]) > 0.15))]
    table = table[(table[:, 0] > -0.15)][:table_points]
    board = np.column_stack([rng.uniform(-0.45, -0.15, 700), rng.uniform(-0.3, 0.3, 700), np.zeros(700)])
    board[:, 2] = np.tan(np.radians(8.0)) * (board[:, 0] + 0.45)
    obj = np.vstack([box, leg])
    points = np.vstack([obj, wall, table, board])
    return points + rng.normal(0, 0.001, points.shape), obj


def test_a_level_table_at_the_share_bar_wins_over_a_leaning_board_through_the_object_base() -> None:
    """The table holds 2.9 % of the points, under the 3 % a support needs alone; a board leaning
    8 degrees on it holds 3.8 %, and its plane has the box's foot and the leg beside it below
    it. The table is the support (level within a degree, within half the threshold) and the
    whole leg stays above it. The old rule, with the table under the bar, took a plane 3.8
    degrees tilted through the board that had the leg 3.4 cm and 13 % of the object under it."""
    rng = np.random.default_rng(7)
    poses = _ring(np.array([0.0, 0.0, 1.0]), count=9, height=0.9)
    points, obj = _board_leaning_by_a_toy(rng, table_points=400)
    plane = find_support_plane(points, obj, poses, np.array([0.0, 0.0, 0.15]), threshold=0.006)
    assert plane is not None
    assert np.degrees(np.arccos(min(plane.normal[2], 1.0))) < 1.0 and abs(plane.offset) < 0.003, plane.figures()
    leg = obj[7500:]
    assert plane.height(leg).min() > -0.006, plane.figures()
