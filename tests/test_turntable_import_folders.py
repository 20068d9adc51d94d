"""TUM and Open3D/Redwood folders as the datasets and tools ship them, imported (no
reconstruction) and read back against the frames written: the TUM benchmark, TUM's
associate.py output alone, lists and associations a user wrote (Windows encodings, commas, files
told apart by bit depth), ICL-NUIM (depth first, frame numbers), ETH3D (its calibration.txt);
Open3D's RSBagReader.save_frames, its RealSense recorder and Redwood sample (intrinsics JSON
written by Open3D itself, or its PinholeCameraParameters), Redwood's object scans (times in the
names, no intrinsics), frames numbered without padding, a reconstruction system config JSON
given as the recording."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import recording_sim as rsim
from homemodel.cli import app
from homemodel.geometry.camera import Camera, load_camera, save_camera
from turntable.board import grid_board, save_board
from turntable.recordings import ImportOptions, detect_format, import_recording

FRAMES = rsim.tiny_frames(12)  # 12: "10.png" sorts before "2.png" by name
TUM_START_S = 1305031102.0


@pytest.fixture(scope="module")
def board(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("board") / "board.yaml"
    save_board(grid_board(table_diameter_m=0.4, tag_size_m=0.04), path)
    return path


def _write(path: Path, image: np.ndarray) -> None:
    """RGB colour (JPEG at full chroma and quality, else PNG) or uint16 depth."""
    import cv2

    path.parent.mkdir(parents=True, exist_ok=True)
    if image.ndim == 3:
        jpeg = [cv2.IMWRITE_JPEG_QUALITY, 100, cv2.IMWRITE_JPEG_SAMPLING_FACTOR, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_444]
        assert cv2.imwrite(str(path), image[..., ::-1], jpeg if path.suffix == ".jpg" else [])
    else:
        assert cv2.imwrite(str(path), image)


def _units(depth_m: np.ndarray, per_metre: float) -> np.ndarray:
    return np.round(depth_m * per_metre).astype(np.uint16)


def _tum_files(folder: Path, *, depth_delay_s: float = 0.012) -> tuple[list[str], list[str]]:
    """rgb/ and depth/ named by their float time stamps as the TUM benchmark names them; the
    "timestamp path" lines."""
    color_lines, depth_lines = [], []
    for k, t in enumerate(FRAMES.times_s):
        tc, td = TUM_START_S + t, TUM_START_S + t + depth_delay_s
        _write(folder / f"rgb/{tc:.6f}.png", FRAMES.colors[k])
        _write(folder / f"depth/{td:.6f}.png", _units(FRAMES.depths_m[k], 5000))
        color_lines.append(f"{tc:.6f} rgb/{tc:.6f}.png")
        depth_lines.append(f"{td:.6f} depth/{td:.6f}.png")
    return color_lines, depth_lines


def tum_benchmark(folder: Path) -> Path:
    """rgbd_dataset_freiburg*: the two lists with their three comment lines, ground truth and
    accelerometer beside them."""
    color, depth = _tum_files(folder)
    header = "# {} maps\n# file: 'rgbd_dataset_freiburg1_xyz.bag'\n# timestamp filename\n"
    (folder / "rgb.txt").write_text(header.format("color images") + "\n".join(color) + "\n")
    (folder / "depth.txt").write_text(header.format("depth") + "\n".join(depth) + "\n")
    (folder / "groundtruth.txt").write_text("# ground truth trajectory\n# timestamp tx ty tz qx qy qz qw\n")
    (folder / "accelerometer.txt").write_text("# accelerometer data\n# timestamp ax ay az\n")
    return folder


def tum_associations_only(folder: Path) -> Path:
    """What ORB-SLAM's examples read: associate.py's "time rgb time depth" lines, no lists."""
    color, depth = _tum_files(folder)
    (folder / "associations.txt").write_text("\n".join(f"{c} {d}" for c, d in zip(color, depth)) + "\n")
    return folder


def tum_lists_written_on_windows(folder: Path) -> Path:
    """rgb.txt and depth.txt made by a user's script on Windows: PowerShell's `>` (UTF-16 with
    its byte-order mark, CRLF lines), "time,path" lines (TUM's associate.py reads a comma as a
    space), a decimal comma in the depth times, paths with backslashes."""
    color, depth = _tum_files(folder)
    color = [line.replace(" ", ",").replace("/", "\\") for line in color]
    depth = [line.replace(".", ",", 1) for line in depth]
    for name, lines in (("rgb.txt", color), ("depth.txt", depth)):
        (folder / name).write_bytes(("# timestamp filename\r\n" + "\r\n".join(lines) + "\r\n").encode("utf-16"))
    return folder


def tum_user_associations(folder: Path) -> Path:
    """A user's associations.txt, both images of a frame in one folder told apart by their
    names (`frames/<t>_color.png`, `frames/<t>_depth.png`: no depth/ folder), a UTF-8 BOM,
    ", " between fields."""
    color, depth = _tum_files(folder)
    lines = []
    for c, d in zip(color, depth):
        (tc, pc), (td, pd) = c.split(), d.split()
        named = (f"frames/{tc}_color.png", f"frames/{tc}_depth.png")
        (folder / "frames").mkdir(exist_ok=True)
        (folder / pc).rename(folder / named[0])
        (folder / pd).rename(folder / named[1])
        lines.append(f"{tc}, {named[0]}, {td}, {named[1]}")
    (folder / "associations.txt").write_bytes(("\n".join(lines) + "\n").encode("utf-8-sig"))
    return folder


def icl_nuim(folder: Path) -> Path:
    """ICL-NUIM's TUM-compatible sequences: "n depth/n.png n rgb/n.png", depth first."""
    lines = []
    for k in range(len(FRAMES.times_s)):
        _write(folder / f"rgb/{k}.png", FRAMES.colors[k])
        _write(folder / f"depth/{k}.png", _units(FRAMES.depths_m[k], 5000))
        lines.append(f"{k} depth/{k}.png {k} rgb/{k}.png")
    (folder / "associations.txt").write_text("\n".join(lines) + "\n")
    return folder


def eth3d(folder: Path) -> Path:
    """ETH3D's SLAM benchmark: TUM's lists, associated.txt, and calibration.txt "fx fy cx cy"."""
    tum_benchmark(folder)
    camera = FRAMES.camera
    (folder / "calibration.txt").write_text(f"{camera.fx} {camera.fy} {camera.cx} {camera.cy}\n")
    return folder


def _write_open3d_intrinsic(path: Path, camera: Camera) -> None:
    """Open3D's own writer of a PinholeCameraIntrinsic (column-major intrinsic_matrix)."""
    import open3d as o3d

    intrinsic = o3d.camera.PinholeCameraIntrinsic(camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy)
    assert o3d.io.write_pinhole_camera_intrinsic(str(path), intrinsic)


def _numbered(folder: Path, names: Callable[[int], tuple[str, str]], per_metre: float) -> None:
    for k in range(len(FRAMES.times_s)):
        color, depth = names(k)
        _write(folder / color, FRAMES.colors[k])
        _write(folder / depth, _units(FRAMES.depths_m[k], per_metre))


def open3d_save_frames_d405(folder: Path) -> Path:
    """RSBagReader.save_frames of a D405 recording: color/00000.jpg, depth/00000.png in 0.1 mm,
    intrinsic.json its metadata (the intrinsics with depth_scale 10000, fps, formats)."""
    import json

    _numbered(folder, lambda k: (f"color/{k:05d}.jpg", f"depth/{k:05d}.png"), 10000)
    _write_open3d_intrinsic(folder / "intrinsic.json", FRAMES.camera)
    metadata = json.loads((folder / "intrinsic.json").read_text())
    metadata.update(depth_scale=10000.0, fps=30, device_name="Intel RealSense D405", serial_number="123622270224",
                    color_format="RGB8", depth_format="Z16", color_channels=3, stream_length_usec=400000)
    (folder / "intrinsic.json").write_text(json.dumps(metadata, indent=4))
    return folder


def open3d_realsense_recorder(folder: Path) -> Path:
    """examples/python/reconstruction_system/sensors/realsense_recorder.py: color/000000.jpg,
    depth/000000.png in mm, camera_intrinsic.json without a depth scale."""
    _numbered(folder, lambda k: (f"color/{k:06d}.jpg", f"depth/{k:06d}.png"), 1000)
    _write_open3d_intrinsic(folder / "camera_intrinsic.json", FRAMES.camera)
    return folder


def redwood_sample(folder: Path) -> Path:
    """Open3D's SampleRedwoodRGBDImages: color/, depth/, camera_primesense.json, trajectory.log."""
    _numbered(folder, lambda k: (f"color/{k:05d}.jpg", f"depth/{k:05d}.png"), 1000)
    _write_open3d_intrinsic(folder / "camera_primesense.json", FRAMES.camera)
    (folder / "trajectory.log").write_text("0 0 1\n1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n")
    return folder


def unpadded_numbers(folder: Path) -> Path:
    _numbered(folder, lambda k: (f"image/{k}.png", f"depth/{k}.png"), 1000)
    _write_open3d_intrinsic(folder / "intrinsic.json", FRAMES.camera)
    return folder


def redwood_object_scan(folder: Path) -> Path:
    """Redwood's object scans: rgb/ and depth/ named frame-microseconds, the depth frames 5 ms
    after the colour ones and numbered on their own, one depth frame missing, no intrinsics
    (its camera from --camera); read with one colour frame more than depth frames."""
    for k, t in enumerate(FRAMES.times_s):
        _write(folder / f"rgb/{k + 1:07d}-{round(t * 1e6):012d}.jpg", FRAMES.colors[k])
    depth_numbers = [k for k in range(len(FRAMES.times_s)) if k != 6]
    for n, k in enumerate(depth_numbers):
        _write(folder / f"depth/{n + 1:07d}-{round((FRAMES.times_s[k] + 0.005) * 1e6):012d}.png", _units(FRAMES.depths_m[k], 1000))
    return folder


def open3d_camera_parameters(folder: Path) -> Path:
    """The camera saved with Open3D's write_pinhole_camera_parameters (its intrinsic_matrix
    under `intrinsic`, beside an extrinsic), as a user keeps the camera a script used."""
    import open3d as o3d

    _numbered(folder, lambda k: (f"color/{k:06d}.png", f"depth/{k:06d}.png"), 1000)
    camera = FRAMES.camera
    parameters = o3d.camera.PinholeCameraParameters()
    parameters.intrinsic = o3d.camera.PinholeCameraIntrinsic(camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy)
    parameters.extrinsic = np.eye(4)
    assert o3d.io.write_pinhole_camera_parameters(str(folder / "camera.json"), parameters)
    return folder


def hand_written_row_major(folder: Path) -> Path:
    """An intrinsic.json written by hand in reading order (row-major), not as Open3D writes it."""
    import json

    _numbered(folder, lambda k: (f"color/{k:06d}.png", f"depth/{k:06d}.png"), 1000)
    matrix = FRAMES.camera.matrix.ravel().tolist()
    (folder / "intrinsic.json").write_text(json.dumps({"width": 16, "height": 12, "intrinsic_matrix": matrix}))
    return folder


def open3d_config(folder: Path) -> Path:
    """Open3D's reconstruction system run on a TUM-like dataset: its config JSON (given as the
    recording) names the dataset folder and says depth_scale 5000; the folder holds
    camera_intrinsic.json."""
    import json

    _numbered(folder / "dataset", lambda k: (f"color/{k:06d}.png", f"depth/{k:06d}.png"), 5000)
    _write_open3d_intrinsic(folder / "dataset" / "camera_intrinsic.json", FRAMES.camera)
    config = {"name": "tum scan", "path_dataset": "../dataset/", "path_intrinsic": "", "depth_scale": 5000.0, "depth_max": 3.0}
    (folder / "config").mkdir()
    (folder / "config" / "tum.json").write_text(json.dumps(config, indent=4))
    return folder / "config" / "tum.json"


VARIANTS = {
    # name: (writer, format told, needs --camera, JPEG colour, frames missing)
    "tum-benchmark": (tum_benchmark, "tum", True, False, ()),
    "tum-associations-only": (tum_associations_only, "tum", True, False, ()),
    "tum-lists-written-on-windows": (tum_lists_written_on_windows, "tum", True, False, ()),
    "tum-user-associations-told-by-bit-depth": (tum_user_associations, "tum", True, False, ()),
    "icl-nuim-depth-first": (icl_nuim, "tum", True, False, ()),
    "eth3d-calibration": (eth3d, "tum", False, False, ()),
    "open3d-save-frames-d405": (open3d_save_frames_d405, "open3d", False, True, ()),
    "open3d-realsense-recorder": (open3d_realsense_recorder, "open3d", False, True, ()),
    "redwood-sample": (redwood_sample, "open3d", False, True, ()),
    "unpadded-numbers": (unpadded_numbers, "open3d", False, False, ()),
    "redwood-object-scan": (redwood_object_scan, "open3d", True, True, (6,)),
    "open3d-reconstruction-config": (open3d_config, "open3d", False, False, ()),
    "hand-written-row-major-intrinsics": (hand_written_row_major, "open3d", False, False, ()),
    "open3d-camera-parameters-json": (open3d_camera_parameters, "open3d", False, False, ()),
}
SCALES = {"tum": 1 / 5000, "open3d-save-frames-d405": 1e-4, "open3d-reconstruction-config": 1 / 5000}


@pytest.mark.parametrize("name", list(VARIANTS))
def test_each_layout_imports_its_frames(name: str, board: Path, tmp_path: Path) -> None:
    write, told, needs_camera, lossy, missing = VARIANTS[name]
    recording = write(tmp_path / "recording")
    assert detect_format(recording) == told
    camera_path = None
    if needs_camera:
        camera_path = tmp_path / "camera.yaml"
        save_camera(FRAMES.camera, camera_path)
    report = import_recording(recording, board, tmp_path / "capture", ImportOptions(camera_path=camera_path))
    kept = [k for k in range(len(FRAMES.times_s)) if k not in missing]
    assert report.format == told and report.frames_written == len(kept), report
    assert report.intrinsics_from == ("--camera" if needs_camera else "recording")
    camera = load_camera(tmp_path / "capture" / "camera.yaml")
    scale = SCALES.get(name, SCALES.get(told, 1e-3))
    assert (camera.fx, camera.cx, camera.width) == (FRAMES.camera.fx, FRAMES.camera.cx, FRAMES.camera.width)
    assert camera.depth_scale_m == pytest.approx(scale)
    colors, depths = rsim.read_back(tmp_path / "capture")
    for k, color, depth in zip(kept, colors, depths, strict=True):
        assert np.abs(color.astype(int) - FRAMES.colors[k].astype(int)).max() <= (3 if lossy else 0), (name, k)
        truth = FRAMES.depths_m[k]
        assert np.array_equal(depth > 0, truth > 0) and np.abs(depth - truth).max() < 1e-6, (name, k)


def test_calibration_txt_wins_over_the_camera_given(board: Path, tmp_path: Path) -> None:
    given = tmp_path / "camera.yaml"
    save_camera(Camera(**{**FRAMES.camera.model_dump(), "fx": 30.0}), given)
    report = import_recording(eth3d(tmp_path / "recording"), board, tmp_path / "capture", ImportOptions(camera_path=given))
    assert report.intrinsics_disagreement == ["--camera: fx 30.00 vs the recording's 20.00 (the recording's kept)"]


def test_a_scan_without_intrinsics_is_refused_in_one_line(board: Path, tmp_path: Path) -> None:
    recording = redwood_object_scan(tmp_path / "scan")
    (recording / "moved.json").symlink_to(tmp_path / "gone.json")  # a dangling link is no intrinsics file
    result = CliRunner().invoke(app, ["turntable", "import", str(recording), "--board", str(board), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "no intrinsics" in result.output and "--camera" in result.output
    assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


def test_numbered_frames_carry_no_times_and_redwood_s_keep_theirs(board: Path, tmp_path: Path) -> None:
    """A recorder numbers the frames it kept, so a number is no time: times made up from the
    numbers (1/30 s each, as before) let reconstruct fit a turn rate to them and pose blurred
    frames by it, at wrong angles after a dropped frame (a box at 0.5 m, an Open3D folder with
    two frames dropped and two blurred: 0.77 mm from the truth, 0.29 without the made-up times).
    Redwood's names carry the times, and recording.json keeps them."""
    import json

    camera_path = tmp_path / "camera.yaml"
    save_camera(FRAMES.camera, camera_path)
    for write, timed in ((unpadded_numbers, False), (redwood_object_scan, True)):
        capture = tmp_path / f"capture_{write.__name__}"
        import_recording(write(tmp_path / write.__name__), board, capture, ImportOptions(camera_path=camera_path))
        frames = json.loads((capture / "recording.json").read_text())["frames"]
        times = [frame["time_s"] for frame in frames]
        if timed:  # the colour frames' own times, from the first, the missing depth frame's colour left out
            kept = [t - FRAMES.times_s[0] for k, t in enumerate(FRAMES.times_s) if k != 6]
            assert times == pytest.approx(kept, abs=1e-6)
            assert [frame["depth_offset_s"] for frame in frames] == pytest.approx([0.005] * len(kept), abs=1e-6)
        else:
            assert times == [None] * len(FRAMES.times_s) and all(frame["depth_offset_s"] is None for frame in frames)


def test_a_depth_png_of_another_size_is_refused_naming_it(board: Path, tmp_path: Path) -> None:
    """One depth image of a TUM folder cut to another size: the file named (the whole frame's
    check named only the folder, and the user looked through 34 PNGs)."""
    import cv2

    recording = tum_benchmark(tmp_path / "scan")
    odd = sorted((recording / "depth").iterdir())[2]
    cv2.imwrite(str(odd), cv2.imread(str(odd), cv2.IMREAD_UNCHANGED)[:-2])
    camera = tmp_path / "camera.yaml"
    save_camera(FRAMES.camera, camera)
    args = ["turntable", "import", str(recording), "--board", str(board), "--camera", str(camera), "--out", str(tmp_path / "o")]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 2 and f"{odd}: depth" in result.output and "has another size" in result.output, result.output
    assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


def _board_seen_from_above(board_path: Path, camera: Camera, height_m: float) -> np.ndarray:
    """RGB of the board's tags seen straight down from `height_m` (the table's +y up the image)."""
    v, u = np.mgrid[0 : camera.height, 0 : camera.width]
    return board_at(board_path, (u - camera.cx) * height_m / camera.fx, -(v - camera.cy) * height_m / camera.fy)


def board_at(board_path: Path, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """RGB of the board's tags at table points (x, y) m, each array an image's pixels."""
    from turntable.board import TAG_CELLS, load_board, tag_bits

    board = load_board(board_path)
    white = np.ones(x.shape, dtype=bool)
    half, cell = board.tag_size_m / 2, board.tag_size_m / TAG_CELLS
    for tag in board.tags:
        dx, dy = x - tag.center_m[0], y - tag.center_m[1]
        inside = (np.abs(dx) < half) & (np.abs(dy) < half)
        col, row = ((dx[inside] + half) // cell).astype(int), ((half - dy[inside]) // cell).astype(int)
        white[inside] = tag_bits(tag.id)[np.clip(row, 0, TAG_CELLS - 1), np.clip(col, 0, TAG_CELLS - 1)]
    return np.repeat(np.where(white, 230, 20).astype(np.uint8)[..., None], 3, axis=2)


BOARD_VIEW = Camera(width=320, height=240, fx=300.0, fy=300.0, cx=159.5, cy=119.5)


def _tum_over_the_board(board: Path, folder: Path, depths_m: list[float], per_metre: int) -> list[str]:
    """A TUM folder of the board seen from 0.5 m above, its k-th depth image all `depths_m[k]`
    in `per_metre` units; the import command's arguments before --out."""
    import cv2

    rgb = _board_seen_from_above(board, BOARD_VIEW, 0.5)
    for name in ("rgb", "depth"):
        (folder / name).mkdir(parents=True)
    lines: dict[str, list[str]] = {"rgb": [], "depth": []}
    for k, depth_m in enumerate(depths_m):
        t = f"{TUM_START_S + k / 30:.6f}"
        cv2.imwrite(str(folder / f"rgb/{t}.png"), rgb[..., ::-1])
        cv2.imwrite(str(folder / f"depth/{t}.png"), np.full((240, 320), round(depth_m * per_metre), np.uint16))
        for name in lines:
            lines[name].append(f"{t} {name}/{t}.png")
    for name, listed in lines.items():
        (folder / f"{name}.txt").write_text("\n".join(listed) + "\n")
    save_camera(BOARD_VIEW, folder.parent / "camera.yaml")
    return ["turntable", "import", str(folder), "--board", str(board), "--camera", str(folder.parent / "camera.yaml")]


@pytest.mark.parametrize("per_metre", [5000, 1000])
def test_depth_in_other_units_than_read_is_refused(per_metre: int, board: Path, tmp_path: Path) -> None:
    """A TUM-layout folder whose depth PNGs are in mm (TUM's are 1/5000 m), as a user's own
    script writes a RealSense's: read 5x too near, it reconstructed into a 0.5 m slab 95 mm
    from the box's truth, said only in a note. The depth at the board's tag corners against
    where the tags' pose puts them: refused naming the units that fit and the flag that says
    them; right units pass; with the flag, the mm folder imports in mm."""
    folder = tmp_path / "scan"
    args = _tum_over_the_board(board, folder, [0.5, 0.5], per_metre)
    result = CliRunner().invoke(app, [*args, "--out", str(tmp_path / "o")])
    if per_metre == 5000:
        assert result.exit_code == 0, result.output
        return
    assert result.exit_code == 2 and f"{folder}: the depth reads the board's tags 0.20x as far as they are" in result.output, result.output
    assert "in 1 mm units it would fit (--depth-units-m 0.001)" in result.output and len(result.output.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()
    result = CliRunner().invoke(app, [*args, "--depth-units-m", "0.001", "--out", str(tmp_path / "o")])
    assert result.exit_code == 0 and "--depth-units-m" in result.output, result.output
    assert load_camera(tmp_path / "o" / "camera.yaml").depth_scale_m == pytest.approx(0.001)
    _, depths = rsim.read_back(tmp_path / "o")
    assert all(np.abs(depth - 0.5).max() < 1e-6 for depth in depths)


def test_the_units_verdict_is_not_one_frame_s(board: Path, tmp_path: Path) -> None:
    """A RealSense's first frames may read the board off (auto-exposure settling, the projector
    warming): the verdict rested on the first posed frame alone and refused the recording; now
    the median of three frames ten apart. The first frame 25 % far, the others right: imported;
    two of three 25 % far: refused."""
    for name, wrong in (("first", {0}), ("most", {0, 10})):
        depths = [0.625 if k in wrong else 0.5 for k in range(21)]
        args = _tum_over_the_board(board, tmp_path / name / "scan", depths, 5000)
        result = CliRunner().invoke(app, [*args, "--out", str(tmp_path / name / "o")])
        if name == "first":
            assert result.exit_code == 0, result.output
        else:
            assert result.exit_code == 2 and "the depth reads the board's tags 1.25x as far" in result.output, result.output


def test_a_recording_without_depth_is_refused_at_import(board: Path, tmp_path: Path) -> None:
    """check29b: a TUM folder whose depth PNGs are all 0 (a driver that wrote none) imported,
    and reconstruct refused it as "no depth point fell inside the object's cylinder", pointing
    at the object, not the recording."""
    args = _tum_over_the_board(board, tmp_path / "scan", [0.0, 0.0, 0.0], 5000)
    result = CliRunner().invoke(app, [*args, "--out", str(tmp_path / "o")])
    said = f"{tmp_path / 'scan'}: no depth: its 3 depth frames read none (every pixel 0)"
    assert result.exit_code == 2 and said in " ".join(result.output.split()), result.output
    assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


def test_a_camera_file_of_another_size_than_the_images_is_named(board: Path, tmp_path: Path) -> None:
    """check29b: --camera saying 640x480 for a folder of 320x240 images was refused naming the
    first depth PNG, "said to be registered to the 640x480 colour", where the camera file is at
    fault: now the colour image and --camera's file."""
    args = _tum_over_the_board(board, tmp_path / "scan", [0.5], 5000)
    save_camera(Camera(width=640, height=480, fx=600.0, fy=600.0, cx=319.5, cy=239.5), tmp_path / "camera.yaml")
    result = CliRunner().invoke(app, [*args, "--out", str(tmp_path / "o")])
    said = "the colour image is 320x240 but --camera's camera file says 640x480"
    assert result.exit_code == 2 and said in " ".join(result.output.split()), result.output
    assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


@pytest.mark.parametrize("fault", ["fewer depth", "zero focal length", "depth as jpg"])
def test_an_open3d_folder_s_faults_are_said_in_words(fault: str, board: Path, tmp_path: Path) -> None:
    """check29b: colour images without a depth partner were left out unsaid ("frames dropped 0");
    a zero focal length printed pydantic's two validation errors and their web address; depth
    saved as 8-bit JPEG was only "no depth images"."""
    import json

    recording = open3d_realsense_recorder(tmp_path / "scan")
    depths = sorted((recording / "depth").glob("*.png"))
    if fault == "fewer depth":
        depths[-1].unlink()
    elif fault == "zero focal length":
        data = json.loads((recording / "camera_intrinsic.json").read_text())
        (recording / "camera_intrinsic.json").write_text(json.dumps({**data, "intrinsic_matrix": [0.0] * 9}))
    else:
        for path in depths:
            path.rename(path.with_suffix(".jpg"))
    result = CliRunner().invoke(app, ["turntable", "import", str(recording), "--board", str(board), "--out", str(tmp_path / "o")])
    said = " ".join(result.output.split())
    if fault == "fewer depth":
        left_out = f"{len(depths)} colour and {len(depths) - 1} depth images: the {len(depths) - 1} of one number paired, 1 colour"
        assert result.exit_code == 0 and left_out in said, said
        return
    expected = "fx: Input should be greater than 0" if fault == "zero focal length" else f"({len(depths)} .jpg files: depth must be 16-bit PNG)"
    assert result.exit_code == 2 and expected in said and "pydantic" not in said, said
    assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


def test_an_intrinsic_json_of_another_shape_says_so_and_gives_way_to_the_camera_file(board: Path, tmp_path: Path) -> None:
    """check29b: a user's intrinsic.json of its own shape ({"fx": ...}) was refused with a bare
    KeyError's text ("'intrinsic_matrix'"), even with --camera given: such a folder could not be
    imported without deleting the file. Now it says what is missing, and --camera's file is
    taken in its place, said."""
    import json

    recording = open3d_realsense_recorder(tmp_path / "scan")
    camera = FRAMES.camera
    flat = {"width": camera.width, "height": camera.height, "fx": camera.fx, "fy": camera.fy, "cx": camera.cx, "cy": camera.cy}
    (recording / "camera_intrinsic.json").write_text(json.dumps(flat))
    args = ["turntable", "import", str(recording), "--board", str(board)]
    result = CliRunner().invoke(app, [*args, "--out", str(tmp_path / "o")])
    said = "not an Open3D camera intrinsic file: no intrinsic_matrix (its keys: width, height, fx, fy, cx, cy)"
    assert result.exit_code == 2 and said in " ".join(result.output.split()), result.output
    save_camera(camera, tmp_path / "camera.yaml")
    result = CliRunner().invoke(app, [*args, "--camera", str(tmp_path / "camera.yaml"), "--out", str(tmp_path / "o")])
    assert result.exit_code == 0 and "--camera's camera file taken" in " ".join(result.output.split()), result.output
    assert load_camera(tmp_path / "o" / "camera.yaml").fx == camera.fx


@pytest.mark.parametrize("text", ["[1, 2]", '"abc"'])
def test_an_intrinsic_json_that_is_no_object_is_refused_in_one_line(text: str, board: Path, tmp_path: Path) -> None:
    recording = open3d_realsense_recorder(tmp_path / "scan")
    (recording / "camera_intrinsic.json").write_text(text)
    result = CliRunner().invoke(app, ["turntable", "import", str(recording), "--board", str(board), "--out", str(tmp_path / "o")])
    said = f"{recording / 'camera_intrinsic.json'}: not an Open3D camera intrinsic file"
    assert result.exit_code == 2 and said in result.output, result.output
    assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "o").exists()
