"""RealSense .bag files as the RealSense Viewer records each camera, written by pyrealsense2's
software device and recorder (the Viewer's own recorder), played back and imported (no
reconstruction), read back against the frames written: colour in each of the Viewer's formats,
D405's colour on its stereo module with 0.1 mm depth, the infrared streams recorded beside,
the D435's inverse Brown-Conrady colour, the recorder's LZ4 compression."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import recording_sim as rsim
from homemodel.geometry.camera import Camera, load_camera
from turntable.board import grid_board, save_board
from turntable.recordings import ImportOptions, detect_format, import_recording

FRAMES = rsim.tiny_frames(4)
LAYOUTS = {
    # name: (layout, depth units m, colour tolerance: YUYV's 4:2:2 rounding)
    "d435-bgr8-infrared-inverse-brown-conrady": (
        rsim.RealSenseLayout(color_format="bgr8", infrared=True, color_model="inverse_brown_conrady", device_name="Intel RealSense D435"),
        0.001, 0,
    ),
    "d405-colour-on-the-stereo-module": (
        rsim.RealSenseLayout(color_on_depth_sensor=True, device_name="Intel RealSense D405"), 0.0001, 0
    ),
    "yuyv-compressed": (rsim.RealSenseLayout(color_format="yuyv", compressed=True), 0.001, 3),
    "rgba8": (rsim.RealSenseLayout(color_format="rgba8"), 0.001, 0),
    "bgra8": (rsim.RealSenseLayout(color_format="bgra8"), 0.001, 0),
    "no-depth-units-option": (rsim.RealSenseLayout(depth_units_option=False), 0.001, 0),
    "frames-unnumbered": (rsim.RealSenseLayout(frame_numbers=False), 0.001, 0),
    "no-extrinsics": (rsim.RealSenseLayout(extrinsics=False), 0.001, 0),
}


@pytest.fixture(scope="module")
def board(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("board") / "board.yaml"
    save_board(grid_board(table_diameter_m=0.4, tag_size_m=0.04), path)
    return path


@pytest.mark.parametrize("name", list(LAYOUTS))
def test_each_camera_s_bag_imports_its_frames(name: str, board: Path, tmp_path: Path) -> None:
    layout, units_m, color_tolerance = LAYOUTS[name]
    # Depth in the same camera and frame as colour: taken as registered, no pixel moved.
    rig = rsim.Rig(color_camera=FRAMES.camera, depth_camera=FRAMES.camera, depth_scale_m=units_m, period_s=1 / 30)
    depths = [(t + 0.002, np.round(d / units_m).astype(np.uint16)) for t, d in zip(FRAMES.times_s, FRAMES.depths_m)]
    rsim.write_realsense_streams(tmp_path / "scan.bag", rig, list(zip(FRAMES.times_s, FRAMES.colors)), depths, layout)
    assert detect_format(tmp_path / "scan.bag") == "realsense-bag"
    report = import_recording(tmp_path / "scan.bag", board, tmp_path / "capture", ImportOptions())
    assert report.format == "realsense-bag" and report.frames_written == len(FRAMES.times_s), report
    assert any("no depth units" in note for note in report.notes) == (not layout.depth_units_option)
    camera = load_camera(tmp_path / "capture" / "camera.yaml")
    assert camera.depth_scale_m == pytest.approx(units_m) and (camera.fx, camera.cx) == (FRAMES.camera.fx, FRAMES.camera.cx)
    colors, read_depths = rsim.read_back(tmp_path / "capture")
    for k, (color, depth) in enumerate(zip(colors, read_depths, strict=True)):
        assert np.abs(color.astype(int) - FRAMES.colors[k].astype(int)).max() <= color_tolerance, (name, k)
        truth = FRAMES.depths_m[k]
        assert np.array_equal(depth > 0, truth > 0) and np.abs(depth - truth).max() < 1e-6, (name, k)


def _plane_depth(camera: Camera, camera_from_world: np.ndarray) -> np.ndarray:
    """Depth (m) seen by `camera` of the plane z = 0.25 y + 0.6 (world = the colour camera's
    frame): receding upward as a table top does."""
    normal, offset = np.array([0.0, -0.25, 1.0]), 0.6
    world_from_camera = np.linalg.inv(camera_from_world)
    rays = camera.pixel_rays() @ world_from_camera[:3, :3].T  # z = 1 in the camera's frame
    t = (offset - normal @ world_from_camera[:3, 3]) / (rays @ normal)
    return t.reshape(camera.height, camera.width)


def test_a_d435_s_depth_lands_on_colour_without_bias(board: Path, tmp_path: Path) -> None:
    """A D435-like .bag (848x480-like depth at 87 degrees beside a narrower, finer colour, with
    the Motion Module's accel and gyro streams recorded too): the imported depth of a receding
    plane against its ray-cast truth. The SDK's rs.align, used before, paints each depth pixel
    over a block of colour pixels, later over earlier: its depth came out 1.4 mm short here
    (median; 0.02 mm now, within the 1 mm units)."""
    color = Camera(width=160, height=90, fx=116.0, fy=116.0, cx=79.5, cy=44.5)
    depth_camera = rsim.depth_camera_for(color, width=106, height=60, hfov_deg=87.0)
    color_from_depth = rsim.baseline(-0.015)
    truth = _plane_depth(color, np.eye(4))
    depth_units = np.round(_plane_depth(depth_camera, np.linalg.inv(color_from_depth)) / 0.001).astype(np.uint16)
    rig = rsim.Rig(color_camera=color, depth_camera=depth_camera, color_from_depth=color_from_depth, period_s=1 / 30)
    rgb = np.full((color.height, color.width, 3), 128, np.uint8)
    layout = rsim.RealSenseLayout(motion=True, infrared=True)
    rsim.write_realsense_streams(tmp_path / "scan.bag", rig, [(0.5, rgb), (0.533, rgb)], [(0.5, depth_units), (0.533, depth_units)], layout)
    report = import_recording(tmp_path / "scan.bag", board, tmp_path / "capture", ImportOptions())
    assert report.frames_written == 2 and report.registration == "reprojected", report
    _, depths = rsim.read_back(tmp_path / "capture")
    error_mm = 1000 * (depths[0] - truth)[depths[0] > 0]
    assert error_mm.size > 0.8 * truth.size
    assert abs(np.median(error_mm)) < 0.3 and np.percentile(np.abs(error_mm), 95) < 1.0, np.percentile(error_mm, [5, 50, 95])


@pytest.mark.parametrize("on_camera_clock", ["depth", "color"])
def test_streams_stamped_by_two_clocks_are_paired_as_they_arrived(on_camera_clock: str, board: Path, tmp_path: Path) -> None:
    """One stream stamped by the camera's clock (a day since it started), the other by the
    host's: their stamps never meet (before: no pair, the import refused), so the frames pair
    by when the recorder filed them, each colour frame with its own depth."""
    frames = rsim.tiny_frames(4, period_s=0.1)
    rig = rsim.Rig(color_camera=frames.camera, depth_camera=frames.camera, period_s=0.1)
    depths = [(t + 0.002, np.round(d / 0.001).astype(np.uint16)) for t, d in zip(frames.times_s, frames.depths_m)]
    layout = rsim.RealSenseLayout(device_clock=(on_camera_clock,))
    rsim.write_realsense_streams(tmp_path / "scan.bag", rig, list(zip(frames.times_s, frames.colors)), depths, layout)
    report = import_recording(tmp_path / "scan.bag", board, tmp_path / "capture", ImportOptions())
    assert report.frames_written == len(frames.times_s) and any("paired by the times the frames arrived" in n for n in report.notes)
    colors, read_depths = rsim.read_back(tmp_path / "capture")
    for k, (color, depth) in enumerate(zip(colors, read_depths, strict=True)):
        assert np.array_equal(color, frames.colors[k]) and np.abs(depth - frames.depths_m[k]).max() < 1e-6, k


def test_capture_without_a_camera_says_what_to_do(board: Path, tmp_path: Path) -> None:
    """An installer running the README's capture line with the camera unplugged (or on a USB 2
    port, where it does not enumerate) is told to plug it in or to play a recording."""
    import pyrealsense2 as rs
    from typer.testing import CliRunner

    from homemodel.cli import app

    if len(rs.context().query_devices()):
        pytest.skip("a RealSense camera is connected")
    out = tmp_path / "scan"
    args = ["turntable", "capture", "--device", "realsense", "--board", str(board), "--out", str(out)]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 2 and "USB 3 port" in result.output and "--playback FILE.bag" in result.output, result.output
    assert len(result.output.strip().splitlines()) == 1 and not out.exists()
