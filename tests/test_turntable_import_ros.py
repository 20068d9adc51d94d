"""ROS 1 and ROS 2 bags in the layouts real drivers and recorders write, imported (no
reconstruction): small frames written with rosbags' writers (and a Humble bag's sqlite3 by
hand), read back from the capture folder and compared with what was written."""

from __future__ import annotations

import re
import struct
import tempfile
from collections.abc import Callable
from functools import partial
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import recording_sim as rsim
from homemodel.cli import app
from homemodel.core.errors import InputError
from homemodel.geometry.camera import Camera, load_camera
from turntable.board import grid_board, save_board
from turntable.recordings import ImportOptions, import_recording
from turntable.recordings.rosbag import is_rectified

FRAMES = rsim.tiny_frames()
COLOR_FRAME, DEPTH_FRAME = "camera_color_optical_frame", "camera_depth_optical_frame"


@pytest.fixture(scope="module")
def board(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("board") / "board.yaml"
    save_board(grid_board(table_diameter_m=0.4, tag_size_m=0.04), path)
    return path


def _mm(depth_m: np.ndarray) -> np.ndarray:
    return np.round(depth_m * 1000).astype(np.uint16)


def bayer(rgb: np.ndarray, pattern: str) -> np.ndarray:
    """The mosaic a sensor with the 2x2 `pattern` (ROS's name: rggb, grbg...) reads of `rgb`."""
    channel = {"r": 0, "g": 1, "b": 2}
    out = np.empty(rgb.shape[:2], np.uint8)
    for k, letter in enumerate(pattern):
        out[k // 2 :: 2, k % 2 :: 2] = rgb[k // 2 :: 2, k % 2 :: 2, channel[letter]]
    return out


def compressed_depth(depth_m: np.ndarray, encoding: str, *, rvl: bool = False) -> bytes:
    """compressed_depth_image_transport's payload with its defaults (depth_quantization 100,
    depth_max 10 m): 16UC1 as stored, 32FC1 as quantised inverse depth; PNG or ROS 2's RVL."""
    import cv2

    if encoding == "16UC1":
        quant_a = quant_b = 0.0
        units = _mm(depth_m)
    else:
        quant_a, quant_b = 100.0 * 101.0, 1.0 - 100.0 * 101.0 / 10.0
        with np.errstate(divide="ignore"):
            units = np.where(depth_m > 0, (quant_a / depth_m + quant_b), 0).astype(np.uint16)  # truncated, as ROS does
    header = struct.pack("<iff", 0, quant_a, quant_b)
    if rvl:
        body = struct.pack("<II", units.shape[1], units.shape[0]) + rsim.encode_rvl(units)
    else:
        body = cv2.imencode(".png", units)[1].tobytes()
    return header + body


def jpeg(rgb: np.ndarray) -> bytes:
    """image_transport's JPEG (OpenCV's encoder) at full chroma: with 4:2:0, decoding smooths the
    random 2x2 colour blocks by up to 84 levels, which would hide a channel swap."""
    import cv2

    sampling = [cv2.IMWRITE_JPEG_SAMPLING_FACTOR, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_444]
    return cv2.imencode(".jpg", rgb[..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, 100, *sampling])[1].tobytes()


def _streams(
    ros: rsim.RosMessages,
    color: tuple[str, Callable[[float | None, int], object]],
    depth: tuple[str, Callable[[float | None, int], object]],
    *,
    color_info: str,
    depth_info: str | None = None,
    stamped: bool = True,
    camera: Camera = FRAMES.camera,
    color_frame: str = COLOR_FRAME,
) -> list[tuple[float, str, object]]:
    """Both streams' messages 2 ms apart in each frame, and the CameraInfo beside each (depth
    registered: colour's camera and frame)."""
    messages = [(0.0, color_info, ros.camera_info(0.0, camera, color_frame))]
    if depth_info:
        messages.append((0.0, depth_info, ros.camera_info(0.0, camera, color_frame)))
    for k, t in enumerate(FRAMES.times_s):
        messages.append((t, color[0], color[1](t if stamped else None, k)))
        messages.append((t + 0.002, depth[0], depth[1](t + 0.002 if stamped else None, k)))
    return messages


def _raw_color(ros: rsim.RosMessages, topic: str, encoding: str = "rgb8", frame: str = COLOR_FRAME) -> tuple:
    convert = {
        "rgb8": lambda c: c,
        "bgr8": lambda c: c[..., ::-1],
        "bgra8": lambda c: np.dstack([c[..., ::-1], np.full(c.shape[:2], 255, np.uint8)]),
        "yuv422": lambda c: rsim.yuv422(c, "uyvy"),
        "yuv422_yuy2": lambda c: rsim.yuv422(c, "yuyv"),
    }[encoding]
    return topic, lambda t, k: ros.image(t, convert(FRAMES.colors[k]), encoding, frame)


def _raw_depth(ros: rsim.RosMessages, topic: str, encoding: str = "16UC1", frame: str = COLOR_FRAME) -> tuple:
    convert = {"16UC1": _mm, "mono16": _mm, "32FC1": lambda d: np.where(d > 0, d, np.nan).astype(np.float32)}[encoding]
    return topic, lambda t, k: ros.image(t, convert(FRAMES.depths_m[k]), encoding, frame)


def _aligned(ros: rsim.RosMessages, **options: object) -> list[tuple[float, str, object]]:
    """realsense-ros's colour and aligned depth, with colour's CameraInfo."""
    return _streams(
        ros, _raw_color(ros, "/camera/color/image_raw"), _raw_depth(ros, "/camera/aligned_depth_to_color/image_raw"),
        color_info="/camera/color/camera_info", **options,
    )


def _other_camera_streams(ros: rsim.RosMessages, namespace: str, depth_topic: str) -> list[tuple[float, str, object]]:
    """A second, unregistered depth stream (another size and frame) and an infrared one: what
    the driver also publishes and the importer must pass over."""
    other = Camera(width=8, height=6, fx=10.0, fy=10.0, cx=3.5, cy=2.5)
    messages = [(0.0, f"{namespace}/depth/camera_info", ros.camera_info(0.0, other, DEPTH_FRAME))]
    for t in FRAMES.times_s:
        messages.append((t, depth_topic, ros.image(t, np.full((6, 8), 400, np.uint16), "16UC1", DEPTH_FRAME)))
        messages.append((t, f"{namespace}/infra1/image_rect_raw", ros.image(t, np.zeros((6, 8), np.uint8), "mono8", DEPTH_FRAME)))
    return messages


def realsense_ros1_lz4(folder: Path) -> Path:
    """realsense2_camera (ROS 1) with align_depth, recorded `rosbag record --lz4`."""
    ros = rsim.RosMessages(1)
    messages = _streams(
        ros, _raw_color(ros, "/camera/color/image_raw"), _raw_depth(ros, "/camera/aligned_depth_to_color/image_raw"),
        color_info="/camera/color/camera_info", depth_info="/camera/aligned_depth_to_color/camera_info",
    )
    messages += _other_camera_streams(ros, "/camera", "/camera/depth/image_rect_raw")
    messages.append((0.0, "/tf_static", ros.tf_static([("camera_link", COLOR_FRAME, np.eye(4)), ("camera_link", DEPTH_FRAME, np.eye(4))])))
    rsim.write_bag(folder / "realsense.bag", ros, messages, compression="lz4")
    return folder / "realsense.bag"


def realsense_ros2_humble(folder: Path) -> Path:
    """realsense2_camera 4.x (ROS 2, its /camera/camera namespace) recorded by Humble's
    `ros2 bag record`: no message definitions in the bag."""
    ros = rsim.RosMessages(2)
    ns = "/camera/camera"
    messages = _streams(
        ros, _raw_color(ros, f"{ns}/color/image_raw", "bgr8"), _raw_depth(ros, f"{ns}/aligned_depth_to_color/image_raw"),
        color_info=f"{ns}/color/camera_info", depth_info=f"{ns}/aligned_depth_to_color/camera_info",
    )
    messages += _other_camera_streams(ros, ns, f"{ns}/depth/image_rect_raw")
    rsim.write_humble_bag(folder / "humble_bag", ros, messages)
    return folder / "humble_bag"


def ros2_sqlite(folder: Path, *, compression: str | None, file_alone: bool) -> Path:
    """`ros2 bag record` in sqlite3: zstd-compressed whole (`--compression-mode file`, given as
    its metadata.yaml) or a message at a time (`message`); or given as its .db3 file alone."""
    import shutil

    ros = rsim.RosMessages(2)
    messages = _aligned(ros)
    rsim.write_bag(folder / "bag", ros, messages, compression=compression)
    if not file_alone:
        return folder / "bag" / "metadata.yaml" if compression == "file" else folder / "bag"
    shutil.move(next((folder / "bag").glob("*.db3")), folder / "scan.db3")
    return folder / "scan.db3"


def ros1_bz2_padded_big_endian(folder: Path) -> Path:
    """`rosbag record --bz2`; colour rows padded to a 64-byte step, depth mono16 big-endian."""
    ros = rsim.RosMessages(1)
    color = ("/camera/color/image_raw", lambda t, k: ros.image(t, FRAMES.colors[k], "rgb8", COLOR_FRAME, pad=64 - 3 * 16))
    depth = ("/camera/depth_registered/image_raw", lambda t, k: ros.image(t, _mm(FRAMES.depths_m[k]), "mono16", COLOR_FRAME, big_endian=True))
    messages = _streams(ros, color, depth, color_info="/camera/color/camera_info")
    rsim.write_bag(folder / "bz2.bag", ros, messages, compression="bz2")
    return folder / "bz2.bag"


def mcap_file(folder: Path) -> Path:
    """A ROS 2 (Jazzy) bag in MCAP storage, given as its .mcap file alone, without metadata.yaml."""
    import shutil

    ros = rsim.RosMessages(2)
    messages = _streams(
        ros, _raw_color(ros, "/camera/color/image_raw"), _raw_depth(ros, "/camera/depth_registered/image_rect", "32FC1"),
        color_info="/camera/color/camera_info", depth_info="/camera/depth_registered/camera_info",
    )
    rsim.write_bag(folder / "jazzy", ros, messages, storage="mcap")
    shutil.move(next((folder / "jazzy").glob("*.mcap")), folder / "scan.mcap")
    return folder / "scan.mcap"


def compressed_only(folder: Path) -> Path:
    """Only image_transport's plugins recorded: colour as JPEG (`compressed`), depth as
    `compressedDepth` PNG."""
    ros = rsim.RosMessages(1)
    color = ("/camera/color/image_raw/compressed", lambda t, k: ros.compressed(t, jpeg(FRAMES.colors[k]), "rgb8; jpeg compressed bgr8", COLOR_FRAME))
    depth = (
        "/camera/aligned_depth_to_color/image_raw/compressedDepth",
        lambda t, k: ros.compressed(t, compressed_depth(FRAMES.depths_m[k], "16UC1"), "16UC1; compressedDepth png", COLOR_FRAME),
    )
    messages = _streams(ros, color, depth, color_info="/camera/color/camera_info", depth_info="/camera/aligned_depth_to_color/camera_info")
    rsim.write_bag(folder / "compressed.bag", ros, messages)
    return folder / "compressed.bag"


def compressed_depth_ros2(folder: Path, *, encoding: str, rvl: bool, color_encoding: str) -> Path:
    """compressedDepth in a ROS 2 sqlite3 bag: PNG, or RVL (Humble's compressed_depth_image_transport
    with format rvl); of 16UC1, or of 32FC1 (inverse depth quantised)."""
    ros = rsim.RosMessages(2)
    form = f"{encoding}; compressedDepth {'rvl' if rvl else 'png'}"
    depth = (
        "/camera/aligned_depth_to_color/image_raw/compressedDepth",
        lambda t, k: ros.compressed(t, compressed_depth(FRAMES.depths_m[k], encoding, rvl=rvl), form, COLOR_FRAME),
    )
    messages = _streams(
        ros, _raw_color(ros, "/camera/color/image_raw", color_encoding), depth,
        color_info="/camera/color/camera_info", depth_info="/camera/aligned_depth_to_color/camera_info",
    )
    rsim.write_bag(folder / "compressed_depth", ros, messages)
    return folder / "compressed_depth"


def azure_kinect(folder: Path) -> Path:
    """Azure_Kinect_ROS_Driver: BGRA colour, depth_to_rgb (registered) beside the raw depth and
    a mono16 infrared, the colour lens as rational_polynomial with 8 coefficients."""
    ros = rsim.RosMessages(1)
    messages = _streams(
        ros, _raw_color(ros, "/rgb/image_raw", "bgra8", "rgb_camera_link"), _raw_depth(ros, "/depth_to_rgb/image_raw", frame="rgb_camera_link"),
        color_info="/rgb/camera_info", color_frame="rgb_camera_link",
    )
    messages[0] = (0.0, "/rgb/camera_info", ros.camera_info(0.0, FRAMES.camera, "rgb_camera_link", model="rational_polynomial", d=AZURE_D))
    messages.append((0.0, "/depth_to_rgb/camera_info", ros.camera_info(0.0, FRAMES.camera, "rgb_camera_link", model="rational_polynomial", d=AZURE_D)))
    for t in FRAMES.times_s:
        messages.append((t, "/depth/image_raw", ros.image(t, np.full((6, 8), 400, np.uint16), "16UC1", "depth_camera_link")))
        messages.append((t, "/ir/image_raw", ros.image(t, np.full((6, 8), 900, np.uint16), "mono16", "depth_camera_link")))
    rsim.write_bag(folder / "azure.bag", ros, messages)
    return folder / "azure.bag"


# An Azure Kinect colour camera's k1 k2 p1 p2 k3 k4 k5 k6 (its rational terms are far from zero).
AZURE_D = [0.52, -2.65, 0.0006, -0.0002, 1.51, 0.40, -2.48, 1.44]


def kinect2(folder: Path) -> Path:
    """iai_kinect2: hd, qhd and sd namespaces, one camera_info each; only qhd's depth is
    registered to a colour stream recorded here."""
    ros = rsim.RosMessages(1)
    messages = _streams(
        ros, _raw_color(ros, "/kinect2/qhd/image_color", "bgr8"), _raw_depth(ros, "/kinect2/qhd/image_depth_rect"),
        color_info="/kinect2/qhd/camera_info",
    )
    hd = Camera(width=32, height=24, fx=40.0, fy=40.0, cx=15.5, cy=11.5)
    sd = Camera(width=8, height=6, fx=10.0, fy=10.0, cx=3.5, cy=2.5)
    messages += [(0.0, "/kinect2/hd/camera_info", ros.camera_info(0.0, hd, COLOR_FRAME)), (0.0, "/kinect2/sd/camera_info", ros.camera_info(0.0, sd, "kinect2_ir_optical_frame"))]
    for t in FRAMES.times_s:
        messages.append((t, "/kinect2/hd/image_color", ros.image(t, np.zeros((24, 32, 3), np.uint8), "bgr8", COLOR_FRAME)))
        messages.append((t, "/kinect2/sd/image_depth", ros.image(t, np.full((6, 8), 400, np.uint16), "16UC1", "kinect2_ir_optical_frame")))
    rsim.write_bag(folder / "kinect2.bag", ros, messages)
    return folder / "kinect2.bag"


def openni_bayer(folder: Path) -> Path:
    """openni_launch (Kinect v1, Xtion): the raw Bayer colour and depth_registered."""
    ros = rsim.RosMessages(1)
    color = ("/camera/rgb/image_raw", lambda t, k: ros.image(t, bayer(UNIFORM[k], "grbg"), "bayer_grbg8", COLOR_FRAME))
    messages = _streams(ros, color, _raw_depth(ros, "/camera/depth_registered/image_raw"), color_info="/camera/rgb/camera_info")
    rsim.write_bag(folder / "openni.bag", ros, messages)
    return folder / "openni.bag"


# Uniform frames for the Bayer mosaic (demosaicing interpolates, exactly so only on flat colour).
UNIFORM = [np.broadcast_to(np.array(c, np.uint8), FRAMES.colors[0].shape).copy() for c in ([200, 40, 90], [30, 180, 60], [90, 20, 230], [128, 128, 128], [250, 250, 10])]


def unstamped(folder: Path) -> Path:
    """A driver that leaves header.stamp at zero: the bag's own log times pair the frames."""
    ros = rsim.RosMessages(1)
    messages = _aligned(ros, stamped=False)
    rsim.write_bag(folder / "unstamped.bag", ros, messages)
    return folder / "unstamped.bag"


def edited_ros2(folder: Path, edit: Callable[[rsim.RosMessages, object], None]) -> Path:
    """realsense-ros's streams in a ROS 2 bag, every message edited as a careless writer leaves it."""
    ros = rsim.RosMessages(2)
    messages = _aligned(ros)
    for _, _, message in messages:
        edit(ros, message)
    rsim.write_bag(folder / "edited", ros, messages)
    return folder / "edited"


def _one_stamp(ros: rsim.RosMessages, message: object) -> None:
    message.header.stamp = ros.header(0.25, "").stamp  # every header stamped the recording's start


def _step_unset(_: rsim.RosMessages, message: object) -> None:
    if hasattr(message, "step"):
        message.step = 0  # rows unpadded, step left 0


def colour_info_only(folder: Path) -> Path:
    """A depth stream of colour's size with no CameraInfo of its own (only colour's recorded)."""
    ros = rsim.RosMessages(2)
    messages = _streams(ros, _raw_color(ros, "/cam/color/image"), _raw_depth(ros, "/cam/depth/image"), color_info="/cam/color/camera_info")
    rsim.write_bag(folder / "colour_info_only", ros, messages)
    return folder / "colour_info_only"


def shared_camera_info(folder: Path) -> Path:
    """One CameraInfo for the camera, not beside either image (`/camera/camera_info` with
    `/camera/rgb/image` and `/camera/depth/image`), and a smaller one that fits neither."""
    ros = rsim.RosMessages(2)
    messages = _streams(ros, _raw_color(ros, "/camera/rgb/image"), _raw_depth(ros, "/camera/depth/image"), color_info="/camera/camera_info")
    other = Camera(width=8, height=6, fx=10.0, fy=10.0, cx=3.5, cy=2.5)
    messages.append((0.0, "/camera/rgb/preview/camera_info", ros.camera_info(0.0, other, COLOR_FRAME)))
    rsim.write_bag(folder / "shared_info", ros, messages)
    return folder / "shared_info"


def rectified_colour(folder: Path, topic: str) -> Path:
    """A colour topic named rectified (image_proc's `image_rect_color`, iai_kinect2's
    `image_color_rect`): seen with the CameraInfo's P; its K and D (another focal length, a
    strong lens) are the raw image's, as those drivers publish them."""
    ros = rsim.RosMessages(1)
    namespace = topic.rsplit("/", 1)[0]
    messages = _streams(
        ros, _raw_color(ros, topic), _raw_depth(ros, "/camera/depth_registered/image_raw"), color_info=f"{namespace}/camera_info"
    )
    raw = Camera(**{**FRAMES.camera.model_dump(), "fx": 23.0, "fy": 23.0, "distortion": (0.2, -0.1, 0.01, 0.0, 0.0)})
    info = ros.camera_info(0.0, raw, COLOR_FRAME)
    info.P[[0, 2, 5, 6]] = [FRAMES.camera.fx, FRAMES.camera.cx, FRAMES.camera.fy, FRAMES.camera.cy]
    messages[0] = (0.0, f"{namespace}/camera_info", info)
    rsim.write_bag(folder / "rectified.bag", ros, messages)
    return folder / "rectified.bag"


def ros1_split(folder: Path) -> Path:
    """`rosbag record --split`: parts `scan_0.bag`... following each other in time (CameraInfo
    only in the first), given by its middle part; `scan_3.bag` beside them is another take,
    a minute later, not a part."""
    ros = rsim.RosMessages(1)
    messages = sorted(_aligned(ros, depth_info="/camera/aligned_depth_to_color/camera_info"), key=lambda m: m[0])
    cut = [FRAMES.times_s[2] - 0.01, FRAMES.times_s[4] - 0.01]
    for k, (start, end) in enumerate(zip([-1.0, *cut], [*cut, 1e9])):
        rsim.write_bag(folder / f"scan_{k}.bag", ros, [m for m in messages if start <= m[0] < end])
    later = [(t + 60.0, topic, message) for t, topic, message in messages if t >= cut[1]]
    rsim.write_bag(folder / "scan_3.bag", ros, later)
    return folder / "scan_1.bag"


def ros2_split(folder: Path) -> Path:
    """`ros2 bag record --max-bag-size`: one folder, its metadata.yaml listing three .db3
    files (Humble's), the CameraInfo only in the first."""
    ros = rsim.RosMessages(2)
    rsim.write_humble_bag(folder / "split", ros, _aligned(ros, depth_info="/camera/aligned_depth_to_color/camera_info"), files=3)
    return folder / "split"


def ros2_folder_without_metadata(folder: Path) -> Path:
    """A Jazzy MCAP recording whose recorder was killed before it wrote metadata.yaml (rosbag2
    writes it on closing; `ros2 bag reindex` remakes it): the folder holds only its split
    files, `bag_0.mcap`... `bag_2.mcap` (the CameraInfo only in the first)."""
    ros = rsim.RosMessages(2)
    messages = sorted(_aligned(ros, depth_info="/camera/aligned_depth_to_color/camera_info"), key=lambda m: m[0])
    cut = [FRAMES.times_s[2] - 0.01, FRAMES.times_s[4] - 0.01]
    (folder / "bag").mkdir()
    for k, (start, end) in enumerate(zip([-1.0, *cut], [*cut, 1e9])):
        rsim.write_bag(folder / f"part{k}", ros, [m for m in messages if start <= m[0] < end], storage="mcap")
        next((folder / f"part{k}").glob("*.mcap")).rename(folder / "bag" / f"bag_{k}.mcap")
    return folder / "bag"


def astra_own_frame_name(folder: Path) -> Path:
    """The older ros2_astra_camera with depth_align: `depth/image_raw` registered to colour but
    in a frame of its own name (`color_optical_frame`, colour's is `camera_color_optical_frame`),
    its CameraInfo colour's intrinsics, no transform to colour's frame in /tf_static."""
    ros = rsim.RosMessages(2)
    registered_frame = "color_optical_frame"
    messages = _streams(
        ros, _raw_color(ros, "/camera/color/image_raw"), _raw_depth(ros, "/camera/depth/image_raw", frame=registered_frame),
        color_info="/camera/color/camera_info",
    )
    messages.append((0.0, "/camera/depth/camera_info", ros.camera_info(0.0, FRAMES.camera, registered_frame)))
    messages.append((0.0, "/tf_static", ros.tf_static([("camera_link", COLOR_FRAME, np.eye(4)), ("camera_link", DEPTH_FRAME, np.eye(4))])))
    rsim.write_humble_bag(folder / "astra", ros, messages)
    return folder / "astra"


VARIANTS = {
    # name: (writer, format told, colour tolerance, depth tolerance m, expected colours)
    "realsense-ros1-lz4": (realsense_ros1_lz4, "ros1", 0, 0.0, FRAMES.colors),
    "ros1-split-in-parts": (ros1_split, "ros1", 0, 0.0, FRAMES.colors),
    "ros2-split-in-files": (ros2_split, "ros2", 0, 0.0, FRAMES.colors),
    "ros2-mcap-folder-without-metadata": (ros2_folder_without_metadata, "ros2", 0, 0.0, FRAMES.colors),
    "astra-registered-depth-in-a-frame-of-its-own-name": (astra_own_frame_name, "ros2", 0, 0.0, FRAMES.colors),
    "realsense-ros2-humble-no-definitions": (realsense_ros2_humble, "ros2", 0, 0.0, FRAMES.colors),
    "ros2-mcap-file-32FC1": (mcap_file, "ros2", 0, 0.0, FRAMES.colors),
    "ros2-zstd-file": (partial(ros2_sqlite, compression="file", file_alone=False), "ros2", 0, 0.0, FRAMES.colors),
    "ros2-zstd-message": (partial(ros2_sqlite, compression="message", file_alone=False), "ros2", 0, 0.0, FRAMES.colors),
    "ros2-db3-file-alone": (partial(ros2_sqlite, compression=None, file_alone=True), "ros2", 0, 0.0, FRAMES.colors),
    "ros1-bz2-padded-rows-big-endian-mono16": (ros1_bz2_padded_big_endian, "ros1", 0, 0.0, FRAMES.colors),
    "compressed-jpeg-and-compressedDepth-png": (compressed_only, "ros1", 3, 0.0, FRAMES.colors),
    "compressedDepth-32FC1-and-uyvy": (
        partial(compressed_depth_ros2, encoding="32FC1", rvl=False, color_encoding="yuv422"), "ros2", 3, 2e-4, FRAMES.colors
    ),
    "compressedDepth-rvl-and-yuyv": (
        partial(compressed_depth_ros2, encoding="16UC1", rvl=True, color_encoding="yuv422_yuy2"), "ros2", 3, 0.0, FRAMES.colors
    ),
    "azure-kinect-bgra8-rational": (azure_kinect, "ros1", 0, 0.0, FRAMES.colors),
    "kinect2-namespaces": (kinect2, "ros1", 0, 0.0, FRAMES.colors),
    "openni-bayer-depth-registered": (openni_bayer, "ros1", 2, 0.0, UNIFORM),
    "unstamped": (unstamped, "ros1", 0, 0.0, FRAMES.colors),
    "one-stamp-throughout": (partial(edited_ros2, edit=_one_stamp), "ros2", 0, 0.0, FRAMES.colors),
    "one-camera-info-elsewhere": (shared_camera_info, "ros2", 0, 0.0, FRAMES.colors),
    "depth-without-camera-info": (colour_info_only, "ros2", 0, 0.0, FRAMES.colors),
    "step-left-unset": (partial(edited_ros2, edit=_step_unset), "ros2", 0, 0.0, FRAMES.colors),
    "image-proc-rectified": (partial(rectified_colour, topic="/camera/rgb/image_rect_color"), "ros1", 0, 0.0, FRAMES.colors),
    "kinect2-rectified": (partial(rectified_colour, topic="/kinect2/qhd/image_color_rect"), "ros1", 0, 0.0, FRAMES.colors),
}


@pytest.mark.parametrize("name", list(VARIANTS))
def test_each_layout_imports_its_frames(name: str, board: Path, tmp_path: Path) -> None:
    write, told, color_tolerance, depth_tolerance_m, colors = VARIANTS[name]
    recording = write(tmp_path)
    report = import_recording(recording, board, tmp_path / "capture", ImportOptions())
    assert report.format == told and report.registration == "recording", report
    assert report.frames_written == len(FRAMES.times_s) and report.pairs_associated == len(FRAMES.times_s)
    camera = load_camera(tmp_path / "capture" / "camera.yaml")
    if name != "azure-kinect-bgra8-rational":  # its lens refitted: test_rational_lens_refitted...
        assert (camera.fx, camera.cy, camera.has_distortion) == (FRAMES.camera.fx, FRAMES.camera.cy, False), name
    read_colors, read_depths = rsim.read_back(tmp_path / "capture")
    for k, (color, depth) in enumerate(zip(read_colors, read_depths)):
        assert np.abs(color.astype(int) - colors[k].astype(int)).max() <= color_tolerance, (name, k)
        truth = FRAMES.depths_m[k]
        assert np.array_equal(depth > 0, truth > 0), (name, k)  # no depth stays none
        assert np.abs(depth - truth).max() <= depth_tolerance_m + 1e-6, (name, k)  # float32 read back


@pytest.mark.parametrize(
    ("topic", "rectified"),
    [
        ("/camera/rgb/image_rect_color", True),
        ("/kinect2/qhd/image_color_rect", True),
        ("/kinect2/sd/image_depth_rect", True),
        ("/stereo/left/rect/image", True),
        ("/camera/depth/image_rect_raw", False),  # realsense-ros: its sensor's own image
        ("/kinect2/qhd/image_color", False),
        ("/camera/color/image_raw", False),
    ],
)
def test_a_topic_is_taken_as_rectified_by_its_name(topic: str, rectified: bool) -> None:
    assert is_rectified(topic) == rectified


def test_a_rectified_topic_s_lens_left_out_is_said(board: Path, tmp_path: Path) -> None:
    recording = rectified_colour(tmp_path, "/kinect2/qhd/image_color_rect")
    report = import_recording(recording, board, tmp_path / "capture", ImportOptions())
    assert any("rectified" in note and "0.2, -0.1" in note for note in report.notes), report.notes


def test_unstamped_frames_are_said_to_be_paired_by_log_time(board: Path, tmp_path: Path) -> None:
    report = import_recording(unstamped(tmp_path), board, tmp_path / "capture", ImportOptions())
    assert any("no time stamp" in note for note in report.notes)
    assert report.max_time_offset_ms == pytest.approx(2.0, abs=0.01)


def test_rational_lens_refitted_to_the_projection_it_makes(board: Path, tmp_path: Path) -> None:
    """The 8-coefficient lens (OpenCV's rational model) becomes five Brown-Conrady terms that
    project every pixel's ray within a tenth of a pixel of where the eight put it."""
    import cv2

    report = import_recording(azure_kinect(tmp_path), board, tmp_path / "capture", ImportOptions())
    assert any("refitted" in note for note in report.notes)
    camera = load_camera(tmp_path / "capture" / "camera.yaml")
    u, v = np.meshgrid(np.arange(camera.width), np.arange(camera.height))
    pixels = np.column_stack([u.ravel(), v.ravel()]).astype(np.float64)
    rays = cv2.undistortPointsIter(
        pixels.reshape(-1, 1, 2), FRAMES.camera.matrix, np.array(AZURE_D), None, None,
        (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12),
    ).reshape(-1, 2)
    projected = camera.project(np.column_stack([rays, np.ones(len(rays))]))
    assert np.abs(projected - pixels).max() < 0.1


def test_a_rational_colour_lens_the_refit_cannot_hold_is_undone_in_its_images(board: Path, tmp_path: Path) -> None:
    """check29b's Azure-like colour lens (k4-k6 0.39 -2.43 1.37) refitted as five terms was 7.2
    px off at worst at 1280x720, and its bottle came out 0.78 mm from the truth against its
    twin's 0.14. Here 320x180, 1.4 px off: the colour (a smooth pattern on a plane, the depth
    registered to it as Azure's depth_to_rgb) is now seen through its pinhole, and each capture
    pixel shows what its ray meets."""
    import cv2

    lens = [0.512, -2.61, 0.0006, -0.0002, 1.45, 0.39, -2.43, 1.37]
    camera = Camera(width=320, height=180, fx=152.0, fy=152.0, cx=159.5, cy=89.5)

    def seen(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Grey and depth (m) of the plane z = 0.6 + 0.2 x along the ray (x, y, 1)."""
        return 128 + 100 * np.sin(2 * np.pi * x / 0.25) * np.cos(2 * np.pi * y / 0.25), 0.6 / (1 - 0.2 * x)

    v, u = np.mgrid[0 : camera.height, 0 : camera.width]
    pixels = np.column_stack([u.ravel(), v.ravel()]).astype(np.float64)
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)
    rays = cv2.undistortPointsIter(pixels.reshape(-1, 1, 2), camera.matrix, np.array(lens), None, None, criteria).reshape(-1, 2)
    gray, depth_m = (a.reshape(camera.height, camera.width) for a in seen(rays[:, 0], rays[:, 1]))
    ros = rsim.RosMessages(1)
    messages = [
        (0.0, "/rgb/camera_info", ros.camera_info(0.0, camera, "rgb_camera_link", model="rational_polynomial", d=lens)),
        (0.0, "/depth_to_rgb/camera_info", ros.camera_info(0.0, camera, "rgb_camera_link", model="rational_polynomial", d=lens)),
    ]
    for t in FRAMES.times_s:
        rgb = np.repeat(np.round(gray).astype(np.uint8)[..., None], 3, axis=2)
        messages.append((t, "/rgb/image_raw", ros.image(t, rgb, "rgb8", "rgb_camera_link")))
        messages.append((t, "/depth_to_rgb/image_raw", ros.image(t, _mm(depth_m), "16UC1", "rgb_camera_link")))
    rsim.write_bag(tmp_path / "azure.bag", ros, messages)
    report = import_recording(tmp_path / "azure.bag", board, tmp_path / "capture", ImportOptions())
    colors, depths = rsim.read_back(tmp_path / "capture")
    read = load_camera(tmp_path / "capture" / "camera.yaml").pixel_rays()
    expected_gray, expected_depth = (a.reshape(camera.height, camera.width) for a in seen(read[:, 0], read[:, 1]))
    # The pinhole's corners past the lens's image have none; their edge's colour is blended with black.
    inside = cv2.erode((depths[0] > 0).astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    assert inside.mean() > 0.85, inside.mean()
    # One pixel off is up to 17 grey levels here; the refit was 1.4 px off at worst.
    assert np.abs(colors[0][..., 0] - expected_gray)[inside].max() < 6, np.abs(colors[0][..., 0] - expected_gray)[inside].max()
    assert np.abs(depths[0] - expected_depth)[inside].max() < 0.001, np.abs(depths[0] - expected_depth)[inside].max()
    assert any("undistorted with the rational lens's eight terms" in note for note in report.notes), report.notes


def test_undoing_a_rational_colour_lens_keeps_small_tags_readable(board: Path, tmp_path: Path) -> None:
    """check29b: the Azure-like bottle at half size (tags ~10 px) lost half its tags to the
    bilinear undistortion, 2.14 mm from the truth (0.95 by Lanczos). The board seen from 0.5 m
    above through that lens at 320x180 (tags ~12 px): the imported colour shows 20 of the 35
    tags its pinhole view does bilinearly, 28 now."""
    import cv2

    from test_turntable_import_folders import board_at
    from turntable.tags import DetectionOptions, detect_tags

    lens = [0.512, -2.61, 0.0006, -0.0002, 1.45, 0.39, -2.43, 1.37]
    camera = Camera(width=320, height=180, fx=152.0, fy=152.0, cx=159.5, cy=89.5)

    def seen(rays: np.ndarray) -> np.ndarray:
        return board_at(board, (rays[:, 0] * 0.5).reshape(180, 320), (-rays[:, 1] * 0.5).reshape(180, 320))

    v, u = np.mgrid[0 : camera.height, 0 : camera.width]
    pixels = np.column_stack([u.ravel(), v.ravel()]).astype(np.float64).reshape(-1, 1, 2)
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)
    rgb = seen(cv2.undistortPointsIter(pixels, camera.matrix, np.array(lens), None, None, criteria).reshape(-1, 2))
    ros = rsim.RosMessages(1)
    info = ros.camera_info(0.0, camera, "rgb_camera_link", model="rational_polynomial", d=lens)
    messages = [(0.0, "/rgb/camera_info", info), (0.0, "/depth_to_rgb/camera_info", info)]
    for t in FRAMES.times_s:
        messages.append((t, "/rgb/image_raw", ros.image(t, rgb, "rgb8", "rgb_camera_link")))
        messages.append((t, "/depth_to_rgb/image_raw", ros.image(t, np.full((180, 320), 500, np.uint16), "16UC1", "rgb_camera_link")))
    rsim.write_bag(tmp_path / "azure.bag", ros, messages)
    import_recording(tmp_path / "azure.bag", board, tmp_path / "capture", ImportOptions())
    colors, _ = rsim.read_back(tmp_path / "capture")
    pinhole = seen(load_camera(tmp_path / "capture" / "camera.yaml").pixel_rays())
    found, there = (len(detect_tags(cv2.cvtColor(image, cv2.COLOR_RGB2GRAY), DetectionOptions())) for image in (colors[0], pinhole))
    assert found >= 0.7 * there, (found, there)


def test_a_broken_compressed_depth_is_refused_in_one_line(board: Path, tmp_path: Path) -> None:
    ros = rsim.RosMessages(2)
    depth = ("/camera/depth/image_raw/compressedDepth", lambda t, k: ros.compressed(t, compressed_depth(FRAMES.depths_m[k], "16UC1", rvl=True)[:40], "16UC1; compressedDepth rvl", COLOR_FRAME))
    messages = _streams(ros, _raw_color(ros, "/camera/color/image_raw"), depth, color_info="/camera/color/camera_info", depth_info="/camera/depth/camera_info")
    rsim.write_bag(tmp_path / "broken", ros, messages)
    result = CliRunner().invoke(app, ["turntable", "import", str(tmp_path / "broken"), "--board", str(board), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "an RVL depth image" in result.output and "broken" in result.output
    assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


def _rvl_bytes(codes: list[int]) -> np.ndarray:
    """4-bit codes packed as RVL packs them: the high end of little-endian 32-bit words first."""
    codes = codes + [0] * (-len(codes) % 8)
    words = [int("".join(f"{c:x}" for c in codes[k : k + 8]), 16) for k in range(0, len(codes), 8)]
    return np.frombuffer(np.array(words, "<u4").tobytes(), np.uint8)


def test_a_hostile_rvl_stream_is_refused_at_once_and_a_dense_one_decodes_whole() -> None:
    """A value of 22 codes (2**63 - 1024 plus 2**63: -1024 in 64 bits) made a run negative: alone
    it raised an IndexError, and after a run of 1,020 pixels the decoder went back and forth for
    ever, its memory growing. Both are refused in one line. What the decoder reads of a message
    is bounded by its pixels; the densest image (every step 65,534: 6 codes a pixel) is within
    it, and bytes after an image change nothing."""
    from turntable.recordings.rvl import decode_rvl

    overflowing = [0x8, 0x8, 0x8, 0xE] + [0xF] * 17 + [0x1]
    looping = [0x0, 0xC, 0xF, 0xF, 0x1] + [0x0] * 1021 + overflowing  # runs 0, 1,020 ... 0, -1,024
    for codes in ([0x0, *overflowing], looping):
        with pytest.raises(InputError, match="depth: an RVL depth image holds a value longer than any run"):
            decode_rvl(_rvl_bytes(codes), 640, 480, "depth")
    dense = np.where(np.indices((48, 64)).sum(axis=0) % 2, 65535, 1).astype(np.uint16)
    data = np.frombuffer(rsim.encode_rvl(dense), np.uint8)
    assert np.array_equal(decode_rvl(np.concatenate([data, np.zeros(1 << 20, np.uint8)]), 64, 48, "depth"), dense)



def test_images_claiming_too_many_pixels_or_an_odd_yuv_width_are_refused_before_decoding() -> None:
    """A compressed message's PNG header is checked against the pixel bound before OpenCV decodes
    it (a few megabytes of 16-bit PNG can claim gigabytes); a 4:2:2 image of odd width is refused
    in one line (OpenCV raised its assertion)."""
    import zlib
    from types import SimpleNamespace

    from turntable.recordings.images import decode_compressed_message, decode_image_message

    header = struct.pack(">IIBBBBB", 20000, 20000, 16, 0, 0, 0, 0)
    png = b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + b"IHDR" + header + struct.pack(">I", zlib.crc32(b"IHDR" + header))
    for form, data in (("png", png), ("16UC1; compressedDepth png", bytes(12) + png)):
        message = SimpleNamespace(format=form, data=np.frombuffer(data, np.uint8))
        with pytest.raises(InputError, match="depth: 20000x20000: 400000000 pixels is over the limit"):
            decode_compressed_message(message, "depth")
    yuyv = SimpleNamespace(encoding="yuyv", width=3, height=2, step=6, is_bigendian=0, data=np.zeros(12, np.uint8))
    with pytest.raises(InputError, match="colour: a yuyv image 3 pixels wide"):
        decode_image_message(yuyv, "colour")

@pytest.mark.parametrize("placed_by", ["extrinsics/depth_to_color", "/tf"])
def test_without_tf_static_the_depth_camera_is_placed_by(placed_by: str, board: Path, tmp_path: Path) -> None:
    """An unregistered depth camera 5 cm behind colour and turned 5 degrees, recorded without
    /tf_static: placed by realsense-ros's extrinsics/depth_to_color (a Humble bag, no message
    definitions), or by /tf repeated (ROS 1's tf static_transform_publisher). A wall square to
    the depth camera, 0.6 m away, must land where the colour camera sees it."""
    from rosbags.typesys import get_types_from_msg
    from scipy.spatial.transform import Rotation

    ros = rsim.RosMessages(2 if placed_by.startswith("extrinsics") else 1)
    camera = Camera(width=32, height=24, fx=30.0, fy=30.0, cx=15.5, cy=11.5)
    color_from_depth = np.eye(4)
    color_from_depth[:3, :3] = Rotation.from_euler("y", 5, degrees=True).as_matrix()
    color_from_depth[:3, 3] = [0.01, 0.0, -0.05]
    ns = "/camera/camera"
    messages = [
        (0.0, f"{ns}/color/camera_info", ros.camera_info(0.0, camera, COLOR_FRAME)),
        (0.0, f"{ns}/depth/camera_info", ros.camera_info(0.0, camera, DEPTH_FRAME)),
    ]
    if placed_by.startswith("extrinsics"):
        msgtype = "realsense2_camera_msgs/msg/Extrinsics"
        ros.store.register(get_types_from_msg("float64[9] rotation\nfloat64[3] translation", msgtype))
        rotation, translation = color_from_depth[:3, :3].T.ravel(), color_from_depth[:3, 3].copy()  # column-major
        messages.append((0.0, f"{ns}/extrinsics/depth_to_color", ros.type(msgtype)(rotation=rotation, translation=translation)))
    else:
        edges = [("camera_link", COLOR_FRAME, np.eye(4)), ("camera_link", DEPTH_FRAME, color_from_depth)]
        messages += [(0.1 * k, "/tf", ros.tf_static(edges)) for k in range(3)]
    for t in FRAMES.times_s:
        messages.append((t, f"{ns}/color/image_raw", ros.image(t, np.zeros((24, 32, 3), np.uint8), "rgb8", COLOR_FRAME)))
        messages.append((t, f"{ns}/depth/image_rect_raw", ros.image(t, np.full((24, 32), 600, np.uint16), "16UC1", DEPTH_FRAME)))
    bag = tmp_path / ("bag" if ros.ros_version == 2 else "scan.bag")
    if ros.ros_version == 2:
        rsim.write_humble_bag(bag, ros, messages)
    else:
        rsim.write_bag(bag, ros, messages)
    report = import_recording(bag, board, tmp_path / "capture", ImportOptions())
    assert report.registration == "reprojected" and f"no /tf_static: the depth camera placed by {placed_by}" in report.notes
    _, depths = rsim.read_back(tmp_path / "capture")
    # The wall in colour's frame: normal R z, through R (0, 0, 0.6) + t; each pixel's ray meets it.
    normal = color_from_depth[:3, :3][:, 2]
    offset = normal @ (color_from_depth[:3, :3] @ [0, 0, 0.6] + color_from_depth[:3, 3])
    rays = camera.pixel_rays().reshape(24, 32, 3)
    expected = offset / (rays @ normal)
    seen = depths[0] > 0
    assert seen.mean() > 0.6 and np.abs(depths[0] - expected)[seen].max() < 0.0015


def test_a_wide_rational_depth_lens_reprojects_along_its_own_rays(board: Path, tmp_path: Path) -> None:
    """An Azure Kinect's WFOV depth (120 degrees across, rational_polynomial with k4-k6 near
    k1-k3: 580 px off the best Brown-Conrady at full size), raw beside a 90-degree colour
    camera, as its ROS 2 driver records it with the point cloud off. A wall 0.6 m away must land
    where colour sees it: through the Brown-Conrady refit it landed up to 15 mm off (1.1 mm
    median); along the lens's own rays 0.9 mm at worst (the 1 mm units)."""
    from scipy.spatial.transform import Rotation

    ros = rsim.RosMessages(2)
    color = Camera(width=48, height=27, fx=24.0, fy=24.0, cx=23.5, cy=13.0)
    depth_camera = rsim.RationalLensCamera(width=64, height=64, fx=31.5, fy=31.5, cx=31.6, cy=31.2)
    color_from_depth = np.eye(4)
    color_from_depth[:3, :3] = Rotation.from_euler("x", -6, degrees=True).as_matrix()
    color_from_depth[:3, 3] = [0.032, -0.002, 0.004]
    normal = np.array([0.0, 0.2, 1.0])  # the wall in colour's frame: normal . p = 0.6
    depth_from_color = np.linalg.inv(color_from_depth)
    rays = depth_camera.pixel_rays()
    wall_normal_d, wall_offset_d = depth_from_color[:3, :3] @ normal, 0.6 - normal @ color_from_depth[:3, 3]
    depth_mm = _mm(np.nan_to_num(wall_offset_d / (rays @ wall_normal_d), nan=0.0).reshape(64, 64))
    pinhole = Camera(**{k: v for k, v in depth_camera.model_dump().items() if k != "rational"})
    messages = [
        (0.0, "/tf_static", ros.tf_static([("camera_base", "rgb_camera_link", np.eye(4)), ("camera_base", "depth_camera_link", color_from_depth)])),
        (0.0, "/rgb/camera_info", ros.camera_info(0.0, color, "rgb_camera_link", model="rational_polynomial", d=[0.0] * 8)),
        (0.0, "/depth/camera_info", ros.camera_info(0.0, pinhole, "depth_camera_link", model="rational_polynomial", d=list(depth_camera.rational))),
    ]
    for t in FRAMES.times_s[:2]:
        messages.append((t, "/rgb/image_raw", ros.image(t, np.zeros((27, 48, 4), np.uint8), "bgra8", "rgb_camera_link")))
        messages.append((t, "/depth/image_raw", ros.image(t, depth_mm, "16UC1", "depth_camera_link")))
    rsim.write_bag(tmp_path / "azure", ros, messages)
    report = import_recording(tmp_path / "azure", board, tmp_path / "capture", ImportOptions())
    assert report.registration == "reprojected", report
    _, depths = rsim.read_back(tmp_path / "capture")
    expected = 0.6 / (color.pixel_rays() @ normal).reshape(27, 48)
    seen = depths[0] > 0
    assert seen.mean() > 0.9, seen.mean()
    assert np.abs(depths[0] - expected)[seen].max() < 0.0015, np.abs(depths[0] - expected)[seen].max()


def _square_before_a_wall(camera: Camera, camera_from_scene: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Depth (m) and grey levels of a 10 cm square 0.45 m away before a wall at 0.6 m, as
    `camera` sees them from `camera_from_scene` (the scene in the colour camera's frame)."""
    rays = camera.pixel_rays() @ camera_from_scene[:3, :3]  # the rays in the scene's frame
    origin = -camera_from_scene[:3, :3].T @ camera_from_scene[:3, 3]
    depth = np.empty(len(rays))
    on_square = np.zeros(len(rays), dtype=bool)
    for plane_z, square in ((0.6, False), (0.45, True)):
        reach = (plane_z - origin[2]) / rays[:, 2]
        hit = origin + reach[:, None] * rays
        inside = (np.abs(hit[:, 0]) < 0.05) & (np.abs(hit[:, 1] - 0.005) < 0.05) if square else np.ones(len(rays), dtype=bool)
        depth = np.where(inside, reach, depth)  # the camera's z: the rays have z = 1 in its frame
        on_square |= inside & square
    gray = np.where(on_square, 200, 60).astype(np.uint8)
    return depth.reshape(camera.height, camera.width), gray.reshape(camera.height, camera.width)


UNPLACED_COLOR = Camera(width=160, height=120, fx=300.0, fy=300.0, cx=79.5, cy=59.5)
UNPLACED_DEPTH = Camera(width=160, height=120, fx=280.0, fy=280.0, cx=80.2, cy=59.1)


def _unplaced_bag(
    folder: Path,
    *,
    gray: np.ndarray | None = None,
    color_info: Camera = UNPLACED_COLOR,
    depth_info: Camera = UNPLACED_DEPTH,
) -> Path:
    """A ROS 2 bag of the image and camera_info topics alone (no /tf_static, no extrinsics
    topic): the square before a wall, the depth camera 15 mm beside colour and turned 0.6
    degrees; `gray` in place of colour's view of it, `*_info` the CameraInfo written."""
    from scipy.spatial.transform import Rotation

    color_from_depth = np.eye(4)
    color_from_depth[:3, :3] = Rotation.from_euler("yx", [0.6, -0.3], degrees=True).as_matrix()
    color_from_depth[:3, 3] = [-0.015, 0.001, 0.0]
    ros = rsim.RosMessages(2)
    messages = [
        (0.0, "/camera/color/camera_info", ros.camera_info(0.0, color_info, COLOR_FRAME)),
        (0.0, "/camera/depth/camera_info", ros.camera_info(0.0, depth_info, DEPTH_FRAME)),
    ]
    gray = _square_before_a_wall(UNPLACED_COLOR, np.eye(4))[1] if gray is None else gray
    depth_m, _ = _square_before_a_wall(UNPLACED_DEPTH, np.linalg.inv(color_from_depth))
    for t in FRAMES.times_s:
        messages.append((t, "/camera/color/image_raw", ros.image(t, np.dstack([gray] * 3), "rgb8", COLOR_FRAME)))
        messages.append((t, "/camera/depth/image_rect_raw", ros.image(t, _mm(depth_m), "16UC1", DEPTH_FRAME)))
    rsim.write_bag(folder, ros, messages)
    return folder


def test_a_depth_camera_the_recording_does_not_place_is_placed_by_its_edges(board: Path, tmp_path: Path) -> None:
    """The check's box came out 13 mm from its truth with the depth camera taken to sit at
    colour's own point; now placed by where the depth's silhouette edges land on colour's
    edges. The registered square lands on the colour square, all but a few of its outline's
    pixels."""
    report = import_recording(_unplaced_bag(tmp_path / "bag"), board, tmp_path / "capture", ImportOptions())
    _, depths = rsim.read_back(tmp_path / "capture")
    square = _square_before_a_wall(UNPLACED_COLOR, np.eye(4))[1] == 200
    seen_square = (depths[0] > 0) & (depths[0] < 0.5)
    # Off by a pixel along the whole outline would be 6 %: 2.4 % now, 25 % before.
    assert np.count_nonzero(square ^ seen_square) < 0.04 * np.count_nonzero(square), np.count_nonzero(square ^ seen_square)
    assert any(note.startswith("the depth camera placed at") for note in report.notes), report.notes


def test_a_placement_no_better_than_none_is_not_taken(board: Path, tmp_path: Path) -> None:
    """Colour whose edges are not the depth's (a speckled view: no silhouette there): the best
    of the searched offsets is chance's, and was taken, moving the depth up to 80 mm; now the
    depth stays at colour's point, said."""
    speckle = np.random.default_rng(7).integers(0, 256, (120, 160)).astype(np.uint8)
    report = import_recording(_unplaced_bag(tmp_path / "bag", gray=speckle), board, tmp_path / "capture", ImportOptions())
    assert any("as if the two cameras sat at one point" in note for note in report.notes), report.notes
    assert not any(note.startswith("the depth camera placed at") for note in report.notes), report.notes


def test_the_depth_camera_s_pose_given_in_the_camera_file_is_taken(board: Path, tmp_path: Path) -> None:
    """A recording without the depth camera's pose was placed by its edges or refused ("record it
    with the driver's /tf_static"), with no way to give the pose the user knows (a datasheet's
    baseline, a calibration): --camera's `color_from_depth`, in a file of that alone, is taken
    as given, and the square lands on colour's (2.4 % of its pixels differ, the registration's
    own half a depth pixel at the outline)."""
    import yaml
    from scipy.spatial.transform import Rotation

    given = np.eye(4)
    given[:3, :3] = Rotation.from_euler("yx", [0.6, -0.3], degrees=True).as_matrix()
    given[:3, 3] = [-0.015, 0.001, 0.0]
    (tmp_path / "camera.yaml").write_text(yaml.safe_dump({"color_from_depth": given.tolist()}))
    options = ImportOptions(camera_path=tmp_path / "camera.yaml")
    report = import_recording(_unplaced_bag(tmp_path / "bag"), board, tmp_path / "capture", options)
    assert "the depth camera's pose from --camera's color_from_depth" in report.notes, report.notes
    _, depths = rsim.read_back(tmp_path / "capture")
    square = _square_before_a_wall(UNPLACED_COLOR, np.eye(4))[1] == 200
    seen_square = (depths[0] > 0) & (depths[0] < 0.5)
    assert np.count_nonzero(square ^ seen_square) < 0.03 * np.count_nonzero(square), np.count_nonzero(square ^ seen_square)


def test_a_camera_file_s_pose_takes_its_tilt_and_height_from_the_board_s_table(board: Path, tmp_path: Path) -> None:
    """A datasheet's baseline given as color_from_depth (15 mm along x, not turned) for a depth
    camera turned 0.6 deg: readme_check's bottle came out a table slab 30 mm from its truth. The
    pose is laid on the board's table (its tilt and height): the registered table is flat."""
    import yaml
    from test_turntable_import_folders import BOARD_VIEW

    _box_on_the_board(board, tmp_path / "bag", _a_baseline())
    datasheet = np.eye(4)
    datasheet[0, 3] = -0.015
    (tmp_path / "camera.yaml").write_text(yaml.safe_dump({"color_from_depth": datasheet.tolist()}))
    options = ImportOptions(camera_path=tmp_path / "camera.yaml")
    report = import_recording(tmp_path / "bag", board, tmp_path / "capture", options)
    _, depths = rsim.read_back(tmp_path / "capture")
    rays = BOARD_VIEW.pixel_rays().reshape(BOARD_VIEW.height, BOARD_VIEW.width, 3)
    table = depths[0] > 0.46
    x, y, z = (rays[table] * depths[0][table, None]).T
    slope_x, slope_y, height = np.linalg.lstsq(np.column_stack([x, y, np.ones_like(x)]), z, rcond=None)[0]
    tilt_deg = np.degrees(np.arctan(np.hypot(slope_x, slope_y)))
    assert tilt_deg < 0.1 and abs(height - 0.5) < 0.001, (tilt_deg, height)
    assert any(note.startswith("--camera's color_from_depth laid on the board's table") for note in report.notes), report.notes


def test_a_camera_file_s_pose_that_is_not_rigid_is_refused_naming_it(board: Path, tmp_path: Path) -> None:
    import yaml

    stretched = np.diag([1.1, 1.0, 1.0, 1.0])
    (tmp_path / "camera.yaml").write_text(yaml.safe_dump({"color_from_depth": stretched.tolist()}))
    args = ["turntable", "import", str(tmp_path / "bag"), "--board", str(board), "--camera", str(tmp_path / "camera.yaml")]
    _unplaced_bag(tmp_path / "bag")
    result = CliRunner().invoke(app, [*args, "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and "camera.yaml: color_from_depth: the matrix is not a rigid transform" in result.output, result.output
    assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


def _box_on_the_board(board: Path, folder: Path, color_from_depth: np.ndarray, can_x_m: float = 0.0) -> Path:
    """A ROS 2 bag of the image and camera_info topics alone: the board seen from 0.5 m above, a
    can 10 cm across and 8 cm tall on it (its top at 0.42 m), the depth camera at
    `color_from_depth`. The can's rim is the depth's only edge, all at one distance: by the
    edges alone a turn (pitch, yaw) cannot be told from an offset."""
    from test_turntable_import_folders import BOARD_VIEW, _board_seen_from_above

    def seen(camera: Camera, camera_from_color: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        rays = camera.pixel_rays() @ camera_from_color[:3, :3]  # in colour's frame
        origin = -camera_from_color[:3, :3].T @ camera_from_color[:3, 3]
        reach = (0.42 - origin[2]) / rays[:, 2]
        hit = origin + reach[:, None] * rays
        on_can = np.hypot(hit[:, 0] - can_x_m, hit[:, 1]) < 0.05
        depth = np.where(on_can, reach, (0.5 - origin[2]) / rays[:, 2])  # the camera's z: rays have z = 1
        return depth.reshape(camera.height, camera.width), on_can.reshape(camera.height, camera.width)

    rgb = _board_seen_from_above(board, BOARD_VIEW, 0.5)
    # The can stands on white paper 24 cm across: the tags' cells (3.6 px here) would hide its rim.
    rays = BOARD_VIEW.pixel_rays().reshape(BOARD_VIEW.height, BOARD_VIEW.width, 3)
    rgb[np.hypot(rays[..., 0], rays[..., 1]) * 0.5 < 0.12] = 230
    rgb[seen(BOARD_VIEW, np.eye(4))[1]] = 40  # a dark can
    depth_m = seen(UNPLACED_DEPTH, np.linalg.inv(color_from_depth))[0]
    ros = rsim.RosMessages(2)
    messages = [
        (0.0, "/camera/color/camera_info", ros.camera_info(0.0, BOARD_VIEW, COLOR_FRAME)),
        (0.0, "/camera/depth/camera_info", ros.camera_info(0.0, UNPLACED_DEPTH, DEPTH_FRAME)),
    ]
    for t in FRAMES.times_s:
        messages.append((t, "/camera/color/image_raw", ros.image(t, rgb, "rgb8", COLOR_FRAME)))
        messages.append((t, "/camera/depth/image_rect_raw", ros.image(t, _mm(depth_m), "16UC1", DEPTH_FRAME)))
    rsim.write_bag(folder, ros, messages)
    return folder


def _a_baseline() -> np.ndarray:
    """A stereo depth camera's pose in colour's frame: 15 mm aside, turned 0.6 deg (yaw, pitch, roll)."""
    from scipy.spatial.transform import Rotation

    color_from_depth = np.eye(4)
    color_from_depth[:3, :3] = Rotation.from_euler("yxz", [0.6, -0.3, 0.2], degrees=True).as_matrix()
    color_from_depth[:3, 3] = [-0.015, 0.0015, 0.001]
    return color_from_depth


@pytest.mark.parametrize("can_x_m", [0.0, 0.1])
def test_the_board_s_table_places_what_the_edges_cannot(can_x_m: float, board: Path, tmp_path: Path) -> None:
    """readme_check's bottle (320x240 depth, the camera 0.4 m out, no /tf_static): its edges
    placed the depth camera 21 mm up and turned 2.2 deg, the table came out tilted 1.6 deg and
    the import was refused (before that, a table slab 41.8 mm from the truth). The depth's
    table is now laid on the board's by the tags, the edges placing only the rest: the
    registered table is flat at 0.5 m, the can's top where colour sees it. The can 10 cm
    aside, at the depth image's edge, its rim an arc: a turn about the table's normal and a
    sideways offset align it alike, and 1.3 deg was taken (f112919); now the least turn."""
    from test_turntable_import_folders import BOARD_VIEW

    truth = _a_baseline()
    bag = _box_on_the_board(board, tmp_path / "bag", truth, can_x_m)
    result = CliRunner().invoke(app, ["turntable", "import", str(bag), "--board", str(board), "--out", str(tmp_path / "o")])
    said = " ".join(result.output.split())
    assert result.exit_code == 0, said
    _, depths = rsim.read_back(tmp_path / "o")
    depth = depths[0]
    rays = BOARD_VIEW.pixel_rays().reshape(BOARD_VIEW.height, BOARD_VIEW.width, 3)
    table = depth > 0.46
    x, y, z = (rays[table] * depth[table, None]).T  # in colour's frame
    slope_x, slope_y, height = np.linalg.lstsq(np.column_stack([x, y, np.ones_like(x)]), z, rcond=None)[0]
    tilt_deg = np.degrees(np.arctan(np.hypot(slope_x, slope_y)))
    assert table.mean() > 0.15 and tilt_deg < 0.1 and abs(height - 0.5) < 0.001, (table.mean(), tilt_deg, height)
    can = (np.hypot(rays[..., 0] * 0.42 - can_x_m, rays[..., 1] * 0.42) < 0.05) & (depth > 0)  # in the depth's view
    seen_can = (depth > 0) & (depth < 0.46)
    assert np.count_nonzero(can ^ seen_can) < 0.04 * np.count_nonzero(can), np.count_nonzero(can ^ seen_can)
    assert "by the board's table and where depth and colour edges fall" in said, said
    turned = re.search(r"turned ([0-9.]+) deg", said)
    truth_deg = np.degrees(np.arccos((np.trace(truth[:3, :3]) - 1) / 2))
    assert turned is not None and abs(float(turned[1]) - truth_deg) < 0.3, (said, truth_deg)


@pytest.mark.parametrize("stream", ["color", "depth"])
def test_camera_info_of_another_size_than_its_images_is_refused_in_one_line(stream: str, board: Path, tmp_path: Path) -> None:
    """The placement read the images at the CameraInfo's size before the importer's check: an
    IndexError, a bug report and exit 1 (the depth's was a ValueError before the placement)."""
    wrong = {f"{stream}_info": Camera(**{**(UNPLACED_COLOR if stream == "color" else UNPLACED_DEPTH).model_dump(), "width": 200, "height": 150})}
    bag = _unplaced_bag(tmp_path / "bag", **wrong)
    result = CliRunner().invoke(app, ["turntable", "import", str(bag), "--board", str(board), "--out", str(tmp_path / "o")])
    said = "a colour frame" if stream == "color" else "a depth frame"
    assert result.exit_code == 2 and f"{bag}: {said} is 160x120, its intrinsics say 200x150" in result.output, result.output
    assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


def test_depth_units_are_not_taken_for_a_float_depth(board: Path, tmp_path: Path) -> None:
    """--depth-units-m says what a 16-bit depth's units are; a 32FC1 depth is in metres (REP
    118), and the flag would be ignored without a word."""
    with pytest.raises(InputError, match="--depth-units-m: its depth is in float metres, not in units"):
        import_recording(mcap_file(tmp_path), board, tmp_path / "capture", ImportOptions(depth_units_m=0.001))
    assert not (tmp_path / "capture").exists()


@pytest.mark.parametrize("fault", ["damaged", "missing"])
def test_a_split_bag_with_a_part_damaged_or_missing_is_refused_in_one_line(fault: str, board: Path, tmp_path: Path) -> None:
    """Its other parts are not imported as if the recording were whole: the part named."""
    ros1_split(tmp_path)
    part = tmp_path / "scan_1.bag"
    if fault == "damaged":
        part.write_bytes(part.read_bytes()[:200])
    else:
        part.unlink()
    out = tmp_path / "o"
    result = CliRunner().invoke(app, ["turntable", "import", str(tmp_path / "scan_0.bag"), "--board", str(board), "--out", str(out)])
    said = "is not readable" if fault == "damaged" else "is missing (scan_2.bag follows it)"
    assert result.exit_code == 2 and f"scan_1.bag: a part of the split bag scan_0.bag {said}" in result.output, result.output
    assert len(result.output.strip().splitlines()) == 1 and not out.exists()


def test_a_message_that_does_not_decode_is_refused_naming_its_topic(board: Path, tmp_path: Path) -> None:
    """A ROS 2 MCAP folder recorded with `--compression-mode message`, its metadata.yaml (which
    alone says the messages are compressed) lost with the recorder killed: the first message
    read raised rosbags' AnyReaderError, a bug report and exit 1."""
    ros = rsim.RosMessages(2)
    rsim.write_bag(tmp_path / "bag", ros, sorted(_aligned(ros), key=lambda m: m[0]), storage="mcap", compression="message")
    (tmp_path / "bag" / "metadata.yaml").unlink()
    result = CliRunner().invoke(app, ["turntable", "import", str(tmp_path / "bag"), "--board", str(board), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and f"{tmp_path / 'bag'}: a /camera/" in result.output and "message does not decode" in result.output
    assert "`ros2 bag reindex`" in result.output, result.output
    assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


@pytest.mark.parametrize("kind", ["ros1", "ros1-active"])
def test_a_bag_cut_short_is_refused_in_words(kind: str, board: Path, tmp_path: Path) -> None:
    """A .bag copied or recorded only in part: rosbags' "Bag index looks damaged: ('Header could
    not be read from file.',)" was printed as it came, a Python tuple. The file rosbag record
    leaves when killed (`scan.bag.active`) was "cannot tell the recording's format"."""
    ros = rsim.RosMessages(1)
    messages = sorted(_aligned(ros), key=lambda m: m[0])
    recording = cut = tmp_path / ("scan.bag.active" if kind == "ros1-active" else "scan.bag")
    rsim.write_bag(cut, ros, messages)
    cut.write_bytes(cut.read_bytes()[: cut.stat().st_size // 2])
    result = CliRunner().invoke(app, ["turntable", "import", str(recording), "--board", str(board), "--out", str(tmp_path / "o")])
    said = {
        "ros1": "cut short or damaged: its index cannot be read",
        "ros1-active": "a ROS 1 bag whose recording was never closed: `rosbag reindex` it",
    }[kind]
    assert result.exit_code == 2 and f"{recording}: " in result.output and said in result.output, result.output
    assert "('" not in result.output and len(result.output.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


@pytest.fixture
def own_temp(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The system's temporary folder, this test's own: where the bag reader makes its copies,
    checked empty after it without another process's copies (a parallel worker's) counting."""
    folder = tmp_path / "tmp"
    folder.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    return folder


@pytest.mark.parametrize("with_metadata", [False, True])
def test_an_mcap_file_cut_short_is_read_up_to_its_cut(with_metadata: bool, board: Path, tmp_path: Path, own_temp: Path) -> None:
    """A ROS 2 recorder killed leaves its MCAP file without an end (and the folder without
    metadata.yaml, which it writes on closing): rosbags' "File end magic is invalid", the whole
    recording refused. Its complete records are read, the frames up to the cut imported as
    they were recorded; a copy of the folder cut with its metadata.yaml alike."""
    ros = rsim.RosMessages(2)
    # An infrared stream beside, 1 MB a frame: rosbags' writer closes a chunk past 1 MB, so the
    # file holds one or two frames a chunk, as a camera's does.
    infrared = np.zeros((900, 1200), np.uint8)
    messages = _aligned(ros) + [(t, "/camera/infra1/image_rect_raw", ros.image(t, infrared, "mono8", DEPTH_FRAME)) for t in FRAMES.times_s]
    rsim.write_bag(tmp_path / "bag", ros, sorted(messages, key=lambda m: m[0]), storage="mcap")
    if not with_metadata:
        (tmp_path / "bag" / "metadata.yaml").unlink()
    cut = next((tmp_path / "bag").glob("*.mcap"))
    whole = cut.read_bytes()
    cut.write_bytes(whole[: len(whole) * 2 // 3])
    report = import_recording(tmp_path / "bag", board, tmp_path / "capture", ImportOptions())
    assert any(f"{cut.name} cut short (its recorder killed): read up to the cut" in note for note in report.notes), report.notes
    assert 0 < report.frames_written < len(FRAMES.times_s), report.frames_written
    colors, depths = rsim.read_back(tmp_path / "capture")
    for k, (color, depth) in enumerate(zip(colors, depths)):
        assert np.array_equal(color, FRAMES.colors[k]) and np.abs(depth - FRAMES.depths_m[k]).max() < 1e-6, k
    assert not list(own_temp.glob("homemodel-bag-copies-*")), "the cut file's copy is left behind"
    # Cut inside its first chunk, which holds the topics: said so (it was "no depth image topic ... topics: []").
    cut.write_bytes(whole[: len(whole) // 50])
    with pytest.raises(InputError, match="cut short before its first complete chunk"):
        import_recording(tmp_path / "bag", board, tmp_path / "capture2", ImportOptions())
    assert not list(own_temp.glob("homemodel-bag-copies-*")), "the cut file's copy is left behind"


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_a_bag_compressed_file_by_file_is_read_without_its_metadata(storage: str, board: Path, tmp_path: Path, own_temp: Path) -> None:
    """`ros2 bag record --compression-mode file` leaves `name_0.mcap.zstd` (or `.db3.zstd`), and
    only metadata.yaml says so: a folder of them alone (metadata.yaml lost, or the files copied
    without it) was "cannot tell the recording's format". Now decompressed and read, said."""
    ros = rsim.RosMessages(2)
    rsim.write_bag(tmp_path / "bag", ros, _aligned(ros), storage=storage, compression="file")
    (tmp_path / "bag" / "metadata.yaml").unlink()
    (compressed,) = (tmp_path / "bag").glob("*.zstd")
    report = import_recording(tmp_path / "bag", board, tmp_path / "capture", ImportOptions())
    assert f"{compressed.stem}.zstd decompressed (a bag recorded with --compression-mode file)" in report.notes, report.notes
    assert report.frames_written == len(FRAMES.times_s)
    colors, depths = rsim.read_back(tmp_path / "capture")
    assert all(np.array_equal(c, FRAMES.colors[k]) and np.abs(d - FRAMES.depths_m[k]).max() < 1e-6 for k, (c, d) in enumerate(zip(colors, depths)))
    assert not list(own_temp.glob("homemodel-bag-copies-*")), "the decompressed copy is left behind"


@pytest.mark.parametrize("name", ["notes.bag", "scan.mcap"])
def test_a_file_that_is_no_bag_is_said_to_be_none(name: str, board: Path, tmp_path: Path) -> None:
    """readme_check's `echo notes > notes.bag`: rosbags' "File magic is invalid." was printed as it came."""
    (tmp_path / name).write_text("notes\n")
    result = CliRunner().invoke(app, ["turntable", "import", str(tmp_path / name), "--board", str(board), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2 and f"{tmp_path / name}: not a readable" in result.output, result.output
    assert "it is no bag file (its first bytes are not a bag's)" in result.output and "magic" not in result.output
    assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


@pytest.mark.parametrize("name", ["zero.bag", "scan.mcap", "scan.db3"])
def test_an_empty_recording_file_is_said_to_be_empty(name: str, board: Path, tmp_path: Path) -> None:
    """readme_check's 0-byte .bag: "zero.bag: not a readable .bag: File 'zero.bag' seems to be
    empty." named the file twice in the reader's words."""
    (tmp_path / name).touch()
    result = CliRunner().invoke(app, ["turntable", "import", str(tmp_path / name), "--board", str(board), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2, result.output
    assert result.output.strip() == f"error: {tmp_path / name}: an empty file (0 bytes): nothing was recorded into it", result.output
    assert not (tmp_path / "o").exists()


def test_a_zstd_storage_file_that_decompresses_past_reason_is_refused(board: Path, tmp_path: Path, own_temp: Path) -> None:
    """read_core's note on ea8defe: a `.zstd` storage file was decompressed with no bound, so a
    hostile one of a few kB filled the temp disk before failing. Here 16 MB of zeros in under
    1 kB: refused at its first 4 MB, over 100x its size."""
    import zstandard

    folder = tmp_path / "bag"
    folder.mkdir()
    zeros = bytes(1 << 22)
    with (folder / "bag_0.mcap.zstd").open("wb") as raw, zstandard.ZstdCompressor(level=19).stream_writer(raw) as target:
        for _ in range(4):
            target.write(zeros)
    with pytest.raises(InputError, match=r"bag_0\.mcap\.zstd: decompresses to more than .* not a recording's storage file"):
        import_recording(folder, board, tmp_path / "capture", ImportOptions())
    assert not (tmp_path / "capture").exists()
    assert not list(own_temp.glob("homemodel-bag-copies-*")), "the partial copy is left behind"


def test_a_zstd_storage_file_too_large_for_the_temporary_disk_says_so(
    board: Path, tmp_path: Path, own_temp: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A real recording compressed whole that would fill the temporary folder's disk is refused
    naming the disk, not called "not a recording's storage file" (here the disk has 1 GiB and
    2 kB free)."""
    import shutil
    from types import SimpleNamespace

    ros = rsim.RosMessages(2)
    rsim.write_bag(tmp_path / "bag", ros, _aligned(ros), storage="mcap", compression="file")
    (tmp_path / "bag" / "metadata.yaml").unlink()
    monkeypatch.setattr(shutil, "disk_usage", lambda _: SimpleNamespace(free=(1 << 30) + 2048))
    with pytest.raises(InputError, match=r"\.mcap\.zstd: decompressed it would leave under 1 GiB free in .*set TMPDIR"):
        import_recording(tmp_path / "bag", board, tmp_path / "capture", ImportOptions())
    assert not (tmp_path / "capture").exists() and not list(own_temp.glob("homemodel-bag-copies-*"))
