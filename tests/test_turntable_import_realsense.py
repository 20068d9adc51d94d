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
from homemodel.geometry.camera import load_camera
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
    # Depth in the same camera and frame as colour: the SDK's align then moves no pixel.
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
