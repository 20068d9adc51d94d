"""Real cameras' recordings: each format written from one simulated capture with real sensor
faults (tests/recording_sim.py), imported, reconstructed, and compared with the truth against
the same capture without the faults (registered pinhole depth, same noise). The capture
command's loop runs end to end on a RealSense .bag played back through the frame source a
live camera uses. No public real RGB-D recording installs from a package registry here
(pyrealsense2 and open3d ship none; Open3D's datasets download at run time), so none is tested.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import trimesh
from fixture_cache import cached_folder, content_key
from typer.testing import CliRunner

import recording_sim as rsim
from homemodel.cli import app
from homemodel.evaluation import mean_surface_distance_m
from homemodel.geometry.camera import Camera, load_camera, save_camera
from homemodel.core.transforms import world_from_camera_looking_at
from homemodel.geometry.raycast import RayCaster
from turntable.board import load_board
from turntable.capture import load_capture
from turntable.capture_live import LiveCaptureOptions, capture_turn
from turntable.color_encoding import capture_encoding
from turntable.recordings import import_recording, ImportOptions
from turntable.recordings.associate import StreamAssociation, associate
from turntable.recordings.realsense import RealSenseSource
from turntable.recordings.register import expected_edge_offset_px, register_depth
from turntable.reconstruct import reconstruct_capture
from turntable.reconstruction import ReconstructOptions
from turntable.simulate import SimulationOptions, render_depth, simulate_capture
from turntable.tags import DetectionOptions

CAPTURE = dict(
    frames=24, width_px=320, height_px=180, horizontal_fov_deg=69.0, renderer="raycast",
    camera_distance_m=0.3, camera_height_m=0.55, tag_size_m=0.04,
)
PERIOD_S = 1.5  # a turn in 36 s, as the README asks (20 ms of jitter: 0.2 degrees of turn)
BROWN_CONRADY = dict(distortion=(0.04, -0.01, 0.001, -0.001, 0.0))
KANNALA_BRANDT = dict(distortion=(0.05, -0.01, 0.002, 0.0), distortion_model="kannala_brandt")
BLURRED = (4, 15)
# The issue asks 1.5x the fault-free capture. Measured at 2b222dd's pipeline (the mesh on the
# box's own footprint again), against the baseline's 0.186 mm: 1.07x (Open3D, registered),
# 1.20x (ROS 2), 1.23x (RealSense), 1.25x (TUM), 1.46x (ROS 1, fisheye lens and a depth camera
# of its own: the closest to the bound). From 3d99766 to 4b37193 the baseline's mesh bulged
# round its base (0.80 mm) and the ratios read 0.62-1.02x; before it, 1.04-1.42x against 0.205 mm.
ACCURACY_RATIO = 1.5


def _reconstruct(folder: Path):  # noqa: ANN202
    return reconstruct_capture(load_capture(folder), ReconstructOptions(texture_size_px=0))


def _write_capture(recorded: rsim.Recorded, board_yaml: Path, folder: Path) -> None:
    """A capture folder straight from registered streams (the baseline, no importer)."""
    import cv2

    (folder / "color").mkdir(parents=True)
    (folder / "depth").mkdir()
    for k, ((_, rgb), (_, depth)) in enumerate(zip(recorded.colors, recorded.depths)):
        cv2.imwrite(str(folder / "color" / f"{k:06d}.png"), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
        cv2.imwrite(str(folder / "depth" / f"{k:06d}.png"), depth)
    camera = Camera(**{**recorded.rig.color_camera.model_dump(), "depth_scale_m": recorded.rig.depth_scale_m})
    save_camera(camera, folder / "camera.yaml")
    shutil.copy(board_yaml, folder / "board.yaml")


def _rig(clean: Path, *, lens: dict, separate_depth: bool, depth_scale_m: float) -> rsim.Rig:
    camera = load_camera(clean / "camera.yaml")
    # A depth camera of its own: 4:3, wider, 15 mm beside colour and turned 0.6 degrees.
    depth_camera = rsim.depth_camera_for(camera, width=256, height=192, hfov_deg=80.0) if separate_depth else None
    return rsim.Rig(
        color_camera=rsim.distorted(camera, **lens),
        depth_camera=depth_camera,
        color_from_depth=rsim.baseline(),
        depth_scale_m=depth_scale_m,
        period_s=PERIOD_S,
    )


FORMATS = {
    # format: (lens, depth in its own camera, depth units, writer)
    "ros1": (KANNALA_BRANDT, True, 0.001, lambda rec, path: rsim.write_rosbag(rec, path / "scan.bag", ros_version=1)),
    "ros2": (BROWN_CONRADY, True, 0.001, lambda rec, path: rsim.write_rosbag(rec, path / "scan", ros_version=2)),
    "realsense-bag": (BROWN_CONRADY, True, 0.0001, lambda rec, path: rsim.write_realsense_bag(rec, path / "scan.bag")),
    "tum": (BROWN_CONRADY, False, 1 / 5000, lambda rec, path: rsim.write_tum(rec, path / "scan")),
    "open3d": ({}, False, 0.001, lambda rec, path: rsim.write_open3d(rec, path / "scan")),
}


# What makes the clean capture and the recordings: a change to any of it (or to this module)
# makes them again (tests/fixture_cache.py).
RECORDING_CODE = ("turntable", "homemodel.geometry", "homemodel.core", "homemodel.exchange")


@pytest.fixture(scope="module")
def made() -> Path:
    """The clean capture (ray cast colour), the baseline's capture folder and each format's
    recording, made once per content; tests only read them."""

    def make(root: Path) -> None:
        mesh = trimesh.creation.box((0.1, 0.07, 0.12))
        mesh = trimesh.Trimesh(*trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, 0.012))
        mesh.visual.vertex_colors = np.column_stack(
            [(0.5 + 2 * mesh.vertices[:, :3]) .clip(0, 1) * 255, np.full(len(mesh.vertices), 255)]
        ).astype(np.uint8)
        mesh.export(root / "box.ply")
        clean = simulate_capture(root / "box.ply", root / "clean", SimulationOptions(**CAPTURE)).out_dir
        # The baseline: the same capture with the same depth noise, but none of the other faults.
        camera = load_camera(clean / "camera.yaml")
        recorded = rsim.record(clean, rsim.Rig(color_camera=camera, period_s=PERIOD_S), drop_fraction=0, jitter_s=0)
        _write_capture(recorded, clean / "board.yaml", root / "baseline")
        for seed, (name, (lens, separate, scale, write)) in enumerate(FORMATS.items()):
            rig = _rig(clean, lens=lens, separate_depth=separate, depth_scale_m=scale)
            folder = root / "recordings" / name
            folder.mkdir(parents=True)
            write(rsim.record(clean, rig, blurred=BLURRED, seed=seed), folder)

    key = content_key(
        inputs=[Path(__file__), Path(rsim.__file__)],
        packages=RECORDING_CODE,
        settings=repr(CAPTURE),
    )
    return cached_folder("turntable_recordings", key, make)


@pytest.fixture(scope="module")
def clean(made: Path) -> Path:
    return made / "clean"


@pytest.fixture(scope="module")
def baseline_mm(made: Path, clean: Path) -> float:
    result = _reconstruct(made / "baseline")
    return 1000 * mean_surface_distance_m(result.mesh, trimesh.load(clean / "ground_truth.ply", force="mesh"))


@pytest.fixture(scope="module")
def recordings(made: Path, clean: Path) -> dict[str, tuple[Path, rsim.Rig]]:
    out = {}
    for name, (lens, separate, scale, _) in FORMATS.items():
        rig = _rig(clean, lens=lens, separate_depth=separate, depth_scale_m=scale)
        out[name] = (next((made / "recordings" / name).iterdir()), rig)
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name", list(FORMATS))
def test_import_and_reconstruct_each_format(
    name: str, clean: Path, baseline_mm: float, recordings: dict, tmp_path: Path
) -> None:
    path, rig = recordings[name]
    camera_yaml = None
    if name == "tum":  # TUM carries no intrinsics
        camera_yaml = tmp_path / "camera.yaml"
        save_camera(rig.color_camera, camera_yaml)
    result = CliRunner().invoke(
        app,
        ["turntable", "import", str(path), "--board", str(clean / "board.yaml"), "--out", str(tmp_path / "capture")]
        + (["--camera", str(camera_yaml)] if camera_yaml else []),
    )
    assert result.exit_code == 0, result.output
    report = json.loads((tmp_path / "capture" / "recording.json").read_text())
    assert report["format"] == name  # told from the layout alone
    camera = load_camera(tmp_path / "capture" / "camera.yaml")
    assert camera.depth_scale_m == pytest.approx(rig.depth_scale_m, rel=1e-6)
    assert camera.distortion_model == rig.color_camera.distortion_model
    if rig.color_camera.has_distortion:
        assert np.allclose(camera.distortion_coefficients, rig.color_camera.distortion_coefficients, atol=1e-6)
    # 3 % dropped (one frame of each stream here): 22 of 24 pairs survive, jitter within 20 ms.
    # The RealSense reader pairs the sensors' frames itself: the SDK's syncer had lost 1-4 more
    # pairs on a loaded machine.
    if name != "open3d":  # Open3D folders hold only whole pairs
        assert report["pairs_associated"] == CAPTURE["frames"] - 2
        assert report["max_time_offset_ms"] <= 20.5
    reconstruction = _reconstruct(tmp_path / "capture")
    summary = reconstruction.figures()
    assert summary["real_frames"]["blurred_frames"] >= 1  # found, whether or not they also lost their tags
    assert summary["recording"]["format"] == name
    assert not summary["real_frames"]["misregistration_warning"], summary["real_frames"]
    # A depth camera of its own: read from half a depth pixel along the cameras' offset.
    assert summary["real_frames"]["registration_edge_offset_px"] == list(report["registration_edge_offset_px"])
    separate_depth = FORMATS[name][1]
    assert (report["registration_edge_offset_px"] != [0.0, 0.0]) is separate_depth
    distance_mm = 1000 * mean_surface_distance_m(
        reconstruction.mesh, trimesh.load(clean / "ground_truth.ply", force="mesh")
    )
    assert distance_mm <= ACCURACY_RATIO * baseline_mm, f"{name}: {distance_mm:.3f} mm against the baseline's {baseline_mm:.3f} mm"


@pytest.mark.slow
def test_capture_by_playback_stops_after_one_turn(clean: Path, baseline_mm: float, recordings: dict, tmp_path: Path) -> None:
    path, _ = recordings["realsense-bag"]
    seen = []
    # 24 frames a turn here (a live camera gives 30 a second), two of them dropped by the recording
    # and two blurred; 8 sectors of 45 degrees: each holds three frames (at sectors=12 a
    # 30-degree sector went empty when the SDK's syncer, no longer used, lost one more pair).
    options = LiveCaptureOptions(sectors=8)
    source = RealSenseSource(bag=path)
    result = capture_turn(source, load_board(clean / "board.yaml"), tmp_path / "capture", options, on_status=seen.append)
    assert result.complete and result.coverage == 1.0
    record = json.loads((tmp_path / "capture" / "recording.json").read_text())
    assert record["notes"] == source.setup.notes and record["live_capture"]["frames_kept"] == result.frames_kept
    assert 315 <= abs(result.turned_deg) <= 375  # every 45-degree sector seen: more than 315 turned
    assert result.warnings["blur"] >= 1  # the blurred frames were warned about, live
    assert any(s.warning and s.warning.startswith("blur") for s in seen)
    assert all(len(s.tag_ids) >= 3 for s in seen if s.warning is None)
    reconstruction = _reconstruct(tmp_path / "capture")
    distance_mm = 1000 * mean_surface_distance_m(
        reconstruction.mesh, trimesh.load(clean / "ground_truth.ply", force="mesh")
    )
    assert distance_mm <= ACCURACY_RATIO * baseline_mm


def test_the_colour_encoding_is_measured_from_the_tags(made: Path, clean: Path, baseline_mm: float, tmp_path: Path) -> None:
    """A camera delivers sRGB-encoded colour, the simulator's recordings are linear: read with
    the wrong curve, the tag edges are refined off the edge (the baseline read as sRGB: 0.30 mm
    against 0.18; its sRGB copy read as linear, the old default: 0.22). `reconstruct` tells
    the two apart by itself, from where the tags' inner cell edges lie, and reports it; a
    given encoding wins."""
    import cv2

    encoded = shutil.copytree(made / "baseline", tmp_path / "srgb")
    for path in (encoded / "color").iterdir():
        cv2.imwrite(str(path), rsim.srgb_encoded(cv2.imread(str(path))))
    linear = capture_encoding(load_capture(made / "baseline"), "auto", DetectionOptions())
    assert linear.encoding == "linear" and linear.decided_by == "measured: the tags' cell edges"
    # Cells of 2 px here: off by 0.03-0.05 px with the right curve, 0.12-0.15 with the wrong one.
    assert abs(linear.cell_edge_offset_px["linear"]) < 0.06 < linear.cell_edge_offset_px["srgb"]
    assert capture_encoding(load_capture(encoded), "linear", DetectionOptions()).encoding == "linear"
    reconstruction = _reconstruct(encoded)
    decided = reconstruction.figures()["color_encoding"]
    assert decided["color_encoding"] == "srgb", decided
    assert abs(decided["cell_edge_offset_px"]["srgb"]) < 0.06 < -decided["cell_edge_offset_px"]["linear"]
    distance_mm = 1000 * mean_surface_distance_m(reconstruction.mesh, trimesh.load(clean / "ground_truth.ply", force="mesh"))
    assert distance_mm <= 1.1 * baseline_mm, f"{distance_mm:.3f} mm against the linear capture's {baseline_mm:.3f} mm"


def test_registration_of_a_640x480_depth_into_a_1280x720_colour() -> None:
    """The full-size geometry: depth from its own camera beside colour, reprojected, against
    depth ray-cast from the colour camera itself."""
    scene = trimesh.util.concatenate(
        [trimesh.creation.box((0.2, 0.15, 0.25)), trimesh.creation.box((2.0, 2.0, 0.01))]
    )
    color = Camera(width=1280, height=720, fx=910.0, fy=910.0, cx=639.5, cy=359.5, **BROWN_CONRADY)
    depth_camera = rsim.depth_camera_for(color, width=640, height=480, hfov_deg=80.0)
    color_from_depth = rsim.baseline()
    from homemodel.core.transforms import world_from_camera_looking_at

    color_from_scene = np.linalg.inv(world_from_camera_looking_at(np.array([0.0, -0.6, 0.45]), np.array([0, 0, 0.05])))
    caster = RayCaster(scene)
    truth, _ = render_depth(caster, color, color_from_scene)
    depth, _ = render_depth(caster, depth_camera, np.linalg.inv(color_from_depth) @ color_from_scene)
    registered = register_depth(depth, depth_camera, color, color_from_depth)
    both = np.isfinite(truth) & np.isfinite(registered)
    assert both.sum() >= 0.97 * np.isfinite(truth).sum()  # no holes from the upsampling, but at edges
    error = np.abs(registered - truth)[both]
    assert np.median(error) < 1e-4 and np.mean(error < 0.001) > 0.99, (np.median(error), np.mean(error < 0.001))


def _between_the_two_planes(registered: np.ndarray, color: Camera, color_from_depth: np.ndarray, near: float, far: float) -> int:
    """Registered colour pixels whose point, in the depth camera's frame, lies more than 3 mm
    from both frontal planes z = near and z = far: a surface drawn across the step."""
    drawn = np.flatnonzero(np.isfinite(registered).ravel())
    points = color.pixel_rays()[drawn] * registered.ravel()[drawn, None]
    z = ((points - color_from_depth[:3, 3]) @ color_from_depth[:3, :3])[:, 2]
    return int(np.sum((np.abs(z - near) > 0.003) & (np.abs(z - far) > 0.003)))


def test_registration_draws_no_surface_across_a_step_or_its_flying_pixels() -> None:
    """A depth camera of its own (320x240, f = 191 px, the D435-beside-colour case) sees a plane
    0.60 m away in front of another: across a 13 mm step (2.2 % of depth, a bottle's silhouette
    against the table near its base) and across a 32 mm step whose edge pixels read between
    the two (flying pixels, splitting it into two 2.7 % jumps), the 3 % rule drew triangles
    (a flared skirt round the bottle's base in the mesh); a plane seen up to 65 degrees off
    its normal keeps its triangles."""
    color = Camera(width=640, height=360, fx=465.6, fy=465.6, cx=319.5, cy=179.5)
    depth_camera = rsim.depth_camera_for(color, width=320, height=240, hfov_deg=80.0)
    color_from_depth = rsim.baseline()
    near, in_front = 0.6, np.s_[60:180, 100:220]
    for far, flying in ((0.613, None), (0.632, 0.616)):
        depth = np.full((240, 320), far)
        depth[in_front] = near
        if flying is not None:  # the step's left and right edge pixels read between the two planes
            depth[60:180, 99], depth[60:180, 220] = flying, flying
        registered = register_depth(depth, depth_camera, color, color_from_depth)
        assert _between_the_two_planes(registered, color, color_from_depth, near, far) == 0, (far, flying)
        assert np.isfinite(registered).mean() > 0.9  # both planes drawn but for the step
    # A plane turned 65 degrees about the vertical: z = 0.6 / (1 - tan(65) x) on the depth rays.
    x = (np.arange(320) - depth_camera.cx) / depth_camera.fx
    tilted = np.tile(0.6 / (1 - np.tan(np.radians(65.0)) * x), (240, 1))
    tilted[:, x >= 0] = np.nan  # only where its rays meet it 65 degrees or less off its normal
    registered = register_depth(tilted, depth_camera, color, color_from_depth)
    seen = (color.pixel_rays()[:, 0] / color.pixel_rays()[:, 2]).reshape(360, 640) < -0.05
    assert np.isfinite(registered[seen]).mean() > 0.99


def test_registration_keeps_a_noisy_wall_whole_at_a_fine_depth_resolution() -> None:
    """A depth of a 1280x720's focal length (674 px: the angle's edge rule is 0.55 % of depth a
    pixel; the middle 320x240 of it) of a wall 0.5 m away, facing the camera and turned 45
    degrees, with the simulated sensor's noise (1.2 mm): the noise is no edge. By the angle's
    rule alone 24 % and 34 % of the wall were left out; the noise read off the frame keeps all
    but 1 %."""
    color = Camera(width=320, height=240, fx=674.0, fy=674.0, cx=159.5, cy=119.5)
    depth_camera = Camera(width=320, height=240, fx=674.0, fy=674.0, cx=159.5, cy=119.5)
    rays = depth_camera.pixel_rays().reshape(240, 320, 3)
    rng = np.random.default_rng(0)
    for turn in (0.0, np.radians(45.0)):
        normal = np.array([np.sin(turn), 0.0, -np.cos(turn)])
        depth = rays[..., 2] * (0.5 * normal[2]) / (rays @ normal)
        depth += rng.normal(size=depth.shape) * (0.0012 + 0.0019 * (depth - 0.4) ** 2)
        registered = register_depth(depth, depth_camera, color, rsim.baseline())
        assert np.isfinite(registered[20:-20, 30:-30]).mean() > 0.98, turn


def test_registration_of_a_depth_frame_without_depth_is_empty() -> None:
    """A frame with no valid depth (lens covered, a dropped frame's zeros) registers to an empty
    image: it used to raise an IndexError in the rasteriser and stop the whole import."""
    color = Camera(width=320, height=180, fx=227.5, fy=227.5, cx=159.5, cy=89.5)
    depth_camera = rsim.depth_camera_for(color, width=160, height=120, hfov_deg=80.0)
    for empty in (np.full((120, 160), np.nan), np.zeros((120, 160))):
        registered = register_depth(empty, depth_camera, color, rsim.baseline())
        assert registered.shape == (180, 320) and np.isnan(registered).all()


def test_association_pairs_nearest_frames_once() -> None:
    rng = np.random.default_rng(3)
    color = np.arange(100) / 30
    depth = np.delete(color + rng.uniform(-0.012, 0.012, 100), [10, 11, 50])
    pairs = associate(np.delete(color, [70]), depth, 1 / 60, where="test")
    assert len(pairs) == 96 and len({j for _, j in pairs}) == 96


@pytest.mark.parametrize(("jitter_s", "color_late_s", "depth_late_s"), [(0.012, 0.02, 0.0), (0.03, 0.0, 0.05)])
def test_frames_paired_as_they_arrive_as_the_whole_streams_are(
    jitter_s: float, color_late_s: float, depth_late_s: float
) -> None:
    """The live and playback pairing, fed frame by frame in arrival order (each stream in time
    order, one of the two delivered later), gives associate's pairs at the sources' tolerance
    of half a frame interval; with 30 ms of jitter frames contend for partners, closest first."""
    rng = np.random.default_rng(4)
    color = np.delete(np.arange(300) / 30 + rng.uniform(-jitter_s, jitter_s, 300), [5, 6, 120])
    color.sort()
    depth = np.sort(np.delete(np.arange(300) / 30 + 0.004 + rng.uniform(-jitter_s, jitter_s, 300), [40, 200, 201]))
    expected = associate(color, depth, 1 / 60, where="test")
    stream = StreamAssociation(1 / 60)
    arrivals = sorted(
        [(t + color_late_s, "color", i) for i, t in enumerate(color)]
        + [(t + depth_late_s, "depth", j) for j, t in enumerate(depth)]
    )
    found, most_held = [], 0
    for _, kind, k in arrivals:
        found += stream.add(kind, (color if kind == "color" else depth)[k], k)
        most_held = max(most_held, len(stream.held["color"]) + len(stream.held["depth"]))
    assert most_held <= 20  # given out as they come (a third of a second held at most), not at the end
    found += stream.finish()
    assert [(i, j) for i, j, _ in found] == expected and stream.late == 0
    assert all(offset == pytest.approx(depth[j] - color[i]) for i, j, offset in found)


def test_refusals_name_the_recording(tmp_path: Path, clean_board: Path) -> None:
    runner = CliRunner()
    (tmp_path / "tum").mkdir()
    (tmp_path / "tum" / "rgb.txt").write_text("1.0 rgb/1.png\n")
    (tmp_path / "tum" / "depth.txt").write_text("5.0 depth/5.png\n")
    result = runner.invoke(app, ["turntable", "import", str(tmp_path / "tum"), "--board", str(clean_board), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "no intrinsics" in result.output and "tum" in result.output
    camera = tmp_path / "camera.yaml"
    save_camera(Camera(width=4, height=4, fx=5, fy=5, cx=1.5, cy=1.5), camera)
    args = ["turntable", "import", str(tmp_path / "tum"), "--board", str(clean_board), "--camera", str(camera), "--out", str(tmp_path / "o")]
    result = runner.invoke(app, args)
    assert result.exit_code == 2 and "never overlap" in result.output
    (tmp_path / "tum" / "depth.txt").write_text("# none\n")
    result = runner.invoke(app, args)
    assert result.exit_code == 2 and "no depth" in result.output
    assert not (tmp_path / "o").exists()


@pytest.fixture
def clean_board(tmp_path: Path) -> Path:
    from turntable.board import grid_board, save_board

    save_board(grid_board(table_diameter_m=0.4, tag_size_m=0.04), tmp_path / "board.yaml")
    return tmp_path / "board.yaml"


def _tiny_frames(folder: Path, n: int, *, scale_per_m: float) -> None:
    import cv2

    rng = np.random.default_rng(0)
    (folder / "color").mkdir(parents=True)
    (folder / "depth").mkdir()
    for k in range(n):
        cv2.imwrite(str(folder / "color" / f"{k:06d}.png"), rng.integers(0, 255, (12, 16, 3), dtype=np.uint8))
        cv2.imwrite(str(folder / "depth" / f"{k:06d}.png"), np.full((12, 16), round(0.6 * scale_per_m), np.uint16))


def test_open3d_folder_thinned_and_its_intrinsics_win(tmp_path: Path, clean_board: Path) -> None:
    recording = tmp_path / "o3d"
    _tiny_frames(recording, 30, scale_per_m=10000)  # 0.1 mm units, said by depth_scale
    intrinsic = {"width": 16, "height": 12, "intrinsic_matrix": [20, 0, 0, 0, 20, 0, 7.5, 5.5, 1], "depth_scale": 10000.0}
    (recording / "intrinsic.json").write_text(json.dumps(intrinsic))
    given = tmp_path / "camera.yaml"
    save_camera(Camera(width=16, height=12, fx=25, fy=20, cx=7.5, cy=5.5), given)
    options = ImportOptions(camera_path=given, every=3, start_s=0.2, end_s=0.6)
    report = import_recording(recording, clean_board, tmp_path / "capture", options)
    # Frames 1/30 s apart: 0.2-0.6 s holds frames 6-18 (13), every third of them: 5.
    assert report.format == "open3d" and report.frames_written == 5
    assert report.intrinsics_disagreement == ["--camera: fx 25.00 vs the recording's 20.00 (the recording's kept)"]
    camera = load_camera(tmp_path / "capture" / "camera.yaml")
    assert camera.fx == 20 and camera.depth_scale_m == pytest.approx(1e-4)
    depth = load_capture(tmp_path / "capture").frames[0].depth
    from homemodel.geometry.depth_io import read_depth_m

    assert np.allclose(read_depth_m(depth, depth_scale_m=camera.depth_scale_m), 0.6)


def test_a_bag_without_depth_is_refused(tmp_path: Path, clean_board: Path) -> None:
    camera = Camera(width=16, height=12, fx=20, fy=20, cx=7.5, cy=5.5)
    rig = rsim.Rig(color_camera=camera, depth_camera=camera, period_s=0.1)
    recorded = rsim.Recorded(rig=rig, colors=[(0.1 * k, np.zeros((12, 16, 3), np.uint8)) for k in range(3)], depths=[])
    rsim.write_rosbag(recorded, tmp_path / "colour_only.bag", ros_version=1)
    result = CliRunner().invoke(
        app, ["turntable", "import", str(tmp_path / "colour_only.bag"), "--board", str(clean_board), "--out", str(tmp_path / "o")]
    )
    assert result.exit_code == 2 and "no depth image topic" in result.output and "colour_only.bag" in result.output
    assert not (tmp_path / "o").exists()


def test_kannala_brandt_round_trip_matches_opencv_fisheye() -> None:
    import cv2

    camera = Camera(width=640, height=480, fx=300, fy=300, cx=319.5, cy=239.5, **KANNALA_BRANDT)
    rng = np.random.default_rng(1)
    points = np.column_stack([rng.uniform(-0.8, 0.8, (500, 2)), np.ones(500)]) * rng.uniform(0.3, 2, (500, 1))
    pixels = camera.project(points)
    expected, _ = cv2.fisheye.projectPoints(
        points.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), camera.matrix, camera.distortion_coefficients
    )
    assert np.abs(pixels - expected.reshape(-1, 2)).max() < 1e-9
    assert np.abs(camera.rays(pixels) * points[:, 2:] - points).max() < 1e-9


def test_misregistration_is_measured_from_edges() -> None:
    from turntable.real_frames import depth_color_offset_px

    depth = np.full((120, 160), 1.0, np.float32)
    depth[40:80, 50:110] = 0.6
    gray = np.full((120, 160), 40, np.uint8)
    gray[42:82, 53:113] = 200  # the colour's square sits 3 px right and 2 px down
    offset = depth_color_offset_px(depth, gray)
    assert np.allclose(offset, [3, 2], atol=0.3), offset
    gray_registered = np.full((120, 160), 40, np.uint8)
    gray_registered[40:80, 50:110] = 200
    assert np.hypot(*depth_color_offset_px(depth, gray_registered)) < 0.3


def test_misregistration_is_measured_on_the_near_edges_only() -> None:
    """A far floor's depth noise passes 1 cm between neighbours everywhere and has no colour edge:
    s13's D455 box at 1.0 m had its estimate pinned at the 6-px reach by it (misregistration
    warned with an exact extrinsic). Jumps whose near side is beyond 1.5x the nearest ones' are
    left out."""
    from turntable.real_frames import depth_color_offset_px

    rng = np.random.default_rng(0)
    depth = np.full((120, 160), 1.0, np.float32)
    depth[:50] = 3.0 + rng.normal(0.0, 0.03, (50, 160))  # the far floor, 3 cm of noise
    depth[60:100, 50:110] = 0.6
    gray = np.full((120, 160), 40, np.uint8)
    gray[:50] = rng.integers(20, 120, (50, 160))  # the floor's own texture
    gray[62:102, 53:113] = 200  # the colour's square sits 3 px right and 2 px down
    assert np.allclose(depth_color_offset_px(depth, gray), [3, 2], atol=0.3)


def test_misregistration_is_read_against_what_an_exact_reprojection_shows() -> None:
    """A depth camera of its own, reprojected: with an exact extrinsic the estimate reads half a
    depth pixel along the cameras' offset (the registered silhouette ends at the depth pixels'
    centres, and only its side towards the offset has depth on both sides of the jump): 1.39 px
    here (readme_check's bottle recordings 1.4-1.8), against the warning's 1.5. Read from that,
    an exact extrinsic is 0.40 px off and one told 2 px off 2.59; read from 0, the 2 px error
    read 1.06 and went unwarned."""
    import math

    from turntable.real_frames import depth_color_offset_px

    bottle = trimesh.creation.cylinder(radius=0.035, height=0.16)
    bottle.apply_translation([0, 0, 0.08])
    table = trimesh.creation.box((1.0, 1.0, 0.01), transform=trimesh.transformations.translation_matrix([0, 0, -0.005]))
    f = 320 / math.tan(math.radians(34.5))
    color = Camera(width=640, height=360, fx=f, fy=f, cx=319.5, cy=179.5)
    camera_from_table = np.linalg.inv(world_from_camera_looking_at(np.array([0.0, -0.4, 0.55]), np.array([0, 0, 0.05])))
    # Colour: the bottle bright on a dark table, one ray a pixel (4 x 4 read the same to 0.1 px).
    caster = RayCaster(trimesh.util.concatenate([bottle, table]))
    seen, _ = render_depth(caster, color, camera_from_table)
    near, _ = render_depth(RayCaster(bottle), color, camera_from_table)
    gray = np.where(np.isfinite(near) & (near <= seen + 1e-6), 230, 30).astype(np.uint8)
    depth_camera = rsim.depth_camera_for(color, width=256, height=192, hfov_deg=80.0)
    color_from_depth = rsim.baseline()  # 15 mm to colour's left
    depth, _ = render_depth(caster, depth_camera, np.linalg.inv(color_from_depth) @ camera_from_table)
    expected = expected_edge_offset_px(depth_camera, color, color_from_depth)
    told = color_from_depth.copy()
    told[0, 3] -= 2 * 0.68 / f  # 2 px at the bottle
    warning_px = ReconstructOptions().misregistration_warning_px
    exact = depth_color_offset_px(register_depth(depth, depth_camera, color, color_from_depth), gray)
    off = depth_color_offset_px(register_depth(depth, depth_camera, color, told), gray)
    assert np.hypot(*(exact - expected)) < warning_px / 2, (exact, expected)
    assert np.hypot(*(off - expected)) > warning_px, (off, expected)


@pytest.mark.parametrize("value", [[-1.21, 0.12], "x", [1, 2, 3], [1.0, float("nan")], None])
def test_the_registration_edge_offset_is_read_only_as_two_numbers(value: object, tmp_path: Path) -> None:
    from turntable.board import grid_board
    from turntable.capture import Capture

    camera = Camera(width=64, height=48, fx=50, fy=50, cx=31.5, cy=23.5)
    board = grid_board(table_diameter_m=0.3, tag_size_m=0.04)
    capture = Capture(folder=tmp_path, camera=camera, board=board, frames=[], unpaired=[], recording={"registration_edge_offset_px": value})
    expected = [-1.21, 0.12] if value == [-1.21, 0.12] else [0.0, 0.0]  # a hand-edited value is no offset
    assert capture.registration_edge_offset_px().tolist() == expected


def test_a_late_depth_frame_is_turned_back() -> None:
    """turned_table follows the turntable's motion: camera_from_table one step later is
    camera_from_table @ turned_table(axis, step); the turn rate comes from the poses."""
    from turntable.real_frames import turn_rate_rad_s, turned_table
    from turntable.simulate import turntable_motion

    options = SimulationOptions(frames=36)
    camera_from_world, world_from_tables = turntable_motion(options, 0.1)
    poses = [camera_from_world @ w for w in world_from_tables]
    step = 2 * np.pi / 36
    assert np.allclose(poses[0] @ turned_table(np.array(options.axis_offset_m), step), poses[1], atol=1e-12)
    assert turn_rate_rad_s(poses[:10], [0.5 * k for k in range(10)]) == pytest.approx(step / 0.5)
