"""Recordings of a simulated turntable capture as real RGB-D cameras would write them, with
real sensor faults: lens distortion, depth from another camera (own intrinsics, size and
pose), the structured-light noise model sigma(z) = 0.0012 + 0.0019 (z - 0.4)^2 m, holes at
grazing angles, flying pixels at depth edges, dropped frames, jittered depth times (the
table keeps turning: a late depth frame sees it turned further), motion blur on some frames.

`record` renders the streams from a clean capture (its colour, warped through the
lens; depth ray-cast again from the depth camera); the `write_*` functions store them in each
format the importer reads.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from homemodel.core.srgb import srgb_encode
from homemodel.geometry.camera import Camera, load_camera
from homemodel.geometry.raycast import RayCaster
from homemodel.exchange.cameras import read_cameras, true_cameras_file
from turntable.simulate import render_depth, simulated_scene


@dataclass(kw_only=True)
class Rig:
    color_camera: Camera  # what the recording's colour images are seen with (may be distorted)
    depth_camera: Camera | None = None  # None: depth registered to colour (rendered in its pixels)
    color_from_depth: np.ndarray = field(default_factory=lambda: np.eye(4))
    depth_scale_m: float = 0.001
    period_s: float = 1.0  # between colour frames
    # The colour stream's transfer curve: the simulator renders linear light; a camera delivers
    # it sRGB-encoded ("srgb": each 8-bit level encoded after the lens and the blur).
    color_encoding: str = "linear"


@dataclass(kw_only=True)
class Recorded:
    rig: Rig
    colors: list[tuple[float, np.ndarray]]  # (time s, RGB uint8)
    depths: list[tuple[float, np.ndarray]]  # (time s, uint16 units of rig.depth_scale_m)


def distorted(camera: Camera, **fields: object) -> Camera:
    return Camera(**{**camera.model_dump(), **fields})


# An Azure Kinect depth lens (k1 k2 p1 p2 k3 k4 k5 k6, rational_polynomial as its ROS driver
# gives it): at fx 504 its 1024x1024 WFOV image spans 120 degrees.
AZURE_WFOV_DEPTH_D = (5.14, 3.46, 0.0, 0.0, 0.172, 5.47, 5.23, 0.92)


class RationalLensCamera(Camera):
    """A depth camera through a radial rational lens (`rational`, OpenCV's eight coefficients,
    p1 = p2 = 0), which the Camera's models only approximate: its rays from the forward model
    by a monotone table, not by OpenCV's iterative inversion an importer may use."""

    rational: tuple[float, ...] = AZURE_WFOV_DEPTH_D

    def pixel_rays(self) -> np.ndarray:
        k1, k2, _, _, k3, k4, k5, k6 = self.rational
        undistorted = np.tan(np.radians(np.linspace(0.0, 84.0, 20000)))
        r2 = undistorted**2
        distorted = undistorted * (1 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1 + r2 * (k4 + r2 * (k5 + r2 * k6)))
        v, u = np.mgrid[0 : self.height, 0 : self.width]
        x, y = (u.ravel() - self.cx) / self.fx, (v.ravel() - self.cy) / self.fy
        r = np.hypot(x, y)
        scale = np.interp(r, distorted, undistorted, right=np.nan) / np.where(r > 0, r, 1.0)
        scale[r == 0] = 1.0
        return np.column_stack([x * scale, y * scale, np.ones_like(x)])


def depth_camera_for(color: Camera, *, width: int, height: int, hfov_deg: float) -> Camera:
    f = width / 2 / math.tan(math.radians(hfov_deg) / 2)
    return Camera(width=width, height=height, fx=f, fy=f * 1.002, cx=(width - 1) / 2 + 1.3, cy=(height - 1) / 2 - 0.8)


def baseline(dx_m: float = -0.015, yaw_deg: float = 0.6) -> np.ndarray:
    """color_from_depth of a depth camera beside the colour one, turned a little."""
    from scipy.spatial.transform import Rotation

    color_from_depth = np.eye(4)
    color_from_depth[:3, :3] = Rotation.from_euler("yxz", [yaw_deg, -0.3, 0.2], degrees=True).as_matrix()
    color_from_depth[:3, 3] = [dx_m, 0.0015, 0.001]
    return color_from_depth


def _noisy(depth: np.ndarray, cosine: np.ndarray, rng: np.random.Generator, flying: bool) -> np.ndarray:
    sigma = 0.0012 + 0.0019 * (depth - 0.4) ** 2
    noisy = depth + rng.normal(size=depth.shape) * sigma
    noisy[cosine < math.cos(math.radians(80.0))] = np.nan
    if flying:  # half the pixels beside a jump over 1 cm read between the two surfaces
        padded = np.pad(depth, 1, mode="edge")
        right, below = padded[1:-1, 2:], padded[2:, 1:-1]
        for other in (right, below):
            edge = np.isfinite(depth) & np.isfinite(other) & (np.abs(other - depth) > 0.01)
            edge &= rng.random(depth.shape) < 0.5
            mix = rng.uniform(0.2, 0.8, depth.shape)
            noisy[edge] = (depth * mix + other * (1 - mix))[edge]
    return noisy


_SRGB_OF_LEVEL = np.round(srgb_encode(np.arange(256) / 255.0) * 255).astype(np.uint8)


def srgb_encoded(image: np.ndarray) -> np.ndarray:
    """An 8-bit linear image's levels sRGB-encoded, as a camera delivers them."""
    return _SRGB_OF_LEVEL[image]


def _motion_blur(rgb: np.ndarray, length_px: int) -> np.ndarray:
    import cv2

    kernel = np.zeros((length_px, length_px), np.float32)
    kernel[length_px // 2, :] = 1.0 / length_px
    return cv2.filter2D(rgb, -1, kernel, borderType=cv2.BORDER_REFLECT)


def record(
    clean_dir: Path,
    rig: Rig,
    *,
    drop_fraction: float = 0.03,
    jitter_s: float = 0.02,
    blurred: tuple[int, ...] = (),
    noise: bool = True,
    seed: int = 0,
    start_frame: int = 0,
    turns: float = 1.0,
) -> Recorded:
    """`turns`: how far the table turns while recording (1.5: the first half turn seen twice)."""
    import cv2

    clean_dir = Path(clean_dir)
    rng = np.random.default_rng(seed)
    options, scene = simulated_scene(clean_dir)
    caster = RayCaster(scene)
    clean_camera = load_camera(clean_dir / "camera.yaml")
    poses = read_cameras(true_cameras_file(clean_dir)).poses
    turn = sorted(poses)
    n = len(turn)
    # Started mid-turn, and as many frames as the turns take, the views of a turn repeating.
    stems = [turn[(start_frame + k) % n] for k in range(max(1, round(turns * n)))]
    map_x, map_y = rig.color_camera.remap_from(clean_camera)
    axis = np.array([*options.axis_offset_m, 0.0])
    turn_s = n * rig.period_s
    drops = max(1, round(drop_fraction * n)) if drop_fraction > 0 else 0
    drop_color = set(rng.choice(len(stems), drops, replace=False).tolist()) if drops else set()
    drop_depth = set(rng.choice(sorted(set(range(len(stems))) - drop_color), drops, replace=False).tolist()) if drops else set()
    depth_camera = rig.depth_camera or rig.color_camera
    depth_from_color = np.linalg.inv(rig.color_from_depth) if rig.depth_camera is not None else np.eye(4)
    colors, depths = [], []
    for k, stem in enumerate(stems):
        t = k * rig.period_s
        if k not in drop_color:
            bgr = cv2.imread(str(clean_dir / "color" / f"{stem}.png"))
            rgb = cv2.cvtColor(cv2.remap(bgr, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE), cv2.COLOR_BGR2RGB)
            rgb = _motion_blur(rgb, 9) if k in blurred else rgb
            colors.append((t, srgb_encoded(rgb) if rig.color_encoding == "srgb" else rgb))
        if k not in drop_depth:
            delay = float(rng.uniform(-jitter_s, jitter_s))
            turned = 2 * math.pi * delay / turn_s  # the table's further turn while the depth waited
            c, s = math.cos(turned), math.sin(turned)
            rz = np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
            shift = np.eye(4)
            shift[:3, 3] = axis
            camera_from_table = poses[stem] @ shift @ rz @ np.linalg.inv(shift)
            depth, cosine = render_depth(caster, depth_camera, depth_from_color @ camera_from_table)
            if noise:
                depth = _noisy(depth, cosine, rng, flying=True)
            units = np.where(np.isfinite(depth), np.round(depth / rig.depth_scale_m), 0)
            units[(units < 0) | (units > 65535)] = 0
            depths.append((t + delay, units.astype(np.uint16)))
    return Recorded(rig=rig, colors=colors, depths=depths)


def write_tum(recorded: Recorded, folder: Path, start_s: float = 1305031102.0) -> None:
    """TUM: registered depth in 1/5000 m (the rig must have no depth camera and that scale)."""
    import cv2

    assert recorded.rig.depth_camera is None and recorded.rig.depth_scale_m == 1 / 5000
    for kind, items in (("rgb", recorded.colors), ("depth", recorded.depths)):
        (folder / kind).mkdir(parents=True)
        lines = [f"# {kind} maps", "# file: 'rgbd_dataset_homemodel'", "# timestamp filename"]
        for t, image in items:
            name = f"{kind}/{start_s + t:.6f}.png"
            cv2.imwrite(str(folder / name), cv2.cvtColor(image, cv2.COLOR_RGB2BGR) if kind == "rgb" else image)
            lines.append(f"{start_s + t:.6f} {name}")
        (folder / f"{kind}.txt").write_text("\n".join(lines) + "\n")


def write_open3d(recorded: Recorded, folder: Path) -> None:
    """Open3D's recorder layout: registered depth, frames by order, intrinsic.json (pinhole)."""
    import cv2

    camera = recorded.rig.color_camera
    assert recorded.rig.depth_camera is None and not camera.has_distortion
    (folder / "color").mkdir(parents=True)
    (folder / "depth").mkdir()
    # Frames pair by order there: only the frames both streams kept (the recorder drops whole pairs).
    depth_at = {round(t / recorded.rig.period_s): image for t, image in recorded.depths}
    k = 0
    for t, rgb in recorded.colors:
        depth = depth_at.get(round(t / recorded.rig.period_s))
        if depth is None:
            continue
        cv2.imwrite(str(folder / "color" / f"{k:06d}.jpg"), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, 95])
        cv2.imwrite(str(folder / "depth" / f"{k:06d}.png"), depth)
        k += 1
    intrinsic = {
        "width": camera.width,
        "height": camera.height,
        "intrinsic_matrix": camera.matrix.T.ravel().tolist(),
        "depth_scale": 1.0 / recorded.rig.depth_scale_m,
    }
    (folder / "intrinsic.json").write_text(json.dumps(intrinsic))


class RosMessages:
    """sensor_msgs, tf2_msgs and their serialisation for one ROS generation, from rosbags'
    typestore (ROS 1 Noetic or ROS 2 Humble), as the drivers fill them in."""

    def __init__(self, ros_version: int, origin_s: float = 1700000000.0) -> None:
        from rosbags.typesys import Stores, get_typestore, get_types_from_msg

        self.ros_version = ros_version
        self.origin_s = origin_s
        self.store = get_typestore(Stores.ROS1_NOETIC if ros_version == 1 else Stores.ROS2_HUMBLE)
        if ros_version == 1:  # rosbags' Noetic store lacks tf2_msgs
            self.store.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"))

    def type(self, name: str) -> type:
        return self.store.types[name]

    def header(self, time_s: float, frame: str) -> object:
        """A header stamped `time_s` after the origin (None: a zero stamp, as some drivers leave it)."""
        sec, nanosec = 0, 0
        if time_s is not None:
            sec = math.floor(self.origin_s + time_s)
            nanosec = int(round((self.origin_s + time_s - sec) * 1e9)) % 1_000_000_000
        stamp = self.type("builtin_interfaces/msg/Time")(sec=sec, nanosec=nanosec)
        seq = {"seq": 0} if self.ros_version == 1 else {}
        return self.type("std_msgs/msg/Header")(stamp=stamp, frame_id=frame, **seq)

    def image(
        self, time_s: float, pixels: np.ndarray, encoding: str, frame: str, *, big_endian: bool = False, pad: int = 0
    ) -> object:
        """sensor_msgs/Image of `pixels` as stored (the caller orders the channels for the
        encoding); `pad` bytes closing each row, as some drivers align their rows."""
        pixels = np.ascontiguousarray(pixels)
        if big_endian:
            pixels = pixels.astype(pixels.dtype.newbyteorder(">"))
        rows = pixels.view(np.uint8).reshape(pixels.shape[0], -1)
        rows = np.pad(rows, ((0, 0), (0, pad)))
        return self.type("sensor_msgs/msg/Image")(
            header=self.header(time_s, frame), height=pixels.shape[0], width=pixels.shape[1], encoding=encoding,
            is_bigendian=int(big_endian), step=rows.shape[1], data=rows.ravel(),
        )

    def compressed(self, time_s: float, data: bytes, form: str, frame: str) -> object:
        return self.type("sensor_msgs/msg/CompressedImage")(
            header=self.header(time_s, frame), format=form, data=np.frombuffer(data, np.uint8)
        )

    def camera_info(
        self, time_s: float, camera: Camera, frame: str, *, model: str | None = None, d: list[float] | None = None
    ) -> object:
        """The CameraInfo of `camera` (plumb_bob or equidistant from its model; `model` and `d`
        to write another, such as rational_polynomial's 8 coefficients)."""
        if model is None:
            model = "equidistant" if camera.distortion_model == "kannala_brandt" else "plumb_bob"
        if d is None:
            d = camera.distortion_coefficients.tolist() if camera.has_distortion else [0.0] * 5
        roi = self.type("sensor_msgs/msg/RegionOfInterest")(x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
        p = np.zeros(12)
        p[[0, 2, 5, 6, 10]] = [camera.fx, camera.cx, camera.fy, camera.cy, 1.0]
        matrices = {"d": np.asarray(d, dtype=np.float64), "k": camera.matrix.ravel(), "r": np.eye(3).ravel(), "p": p}
        if self.ros_version == 1:  # ROS 1 spells them D K R P
            matrices = {name.upper(): value for name, value in matrices.items()}
        return self.type("sensor_msgs/msg/CameraInfo")(
            header=self.header(time_s, frame), height=camera.height, width=camera.width, distortion_model=model,
            binning_x=0, binning_y=0, roi=roi, **matrices,
        )

    def tf_static(self, edges: list[tuple[str, str, np.ndarray]]) -> object:
        """A TFMessage of (parent, child, parent_from_child 4x4) edges."""
        from scipy.spatial.transform import Rotation

        def stamped(parent: str, child: str, matrix: np.ndarray) -> object:
            q = Rotation.from_matrix(matrix[:3, :3]).as_quat()
            translation = self.type("geometry_msgs/msg/Vector3")(*(float(v) for v in matrix[:3, 3]))
            rotation = self.type("geometry_msgs/msg/Quaternion")(*(float(v) for v in q))
            return self.type("geometry_msgs/msg/TransformStamped")(
                header=self.header(0.0, parent), child_frame_id=child,
                transform=self.type("geometry_msgs/msg/Transform")(translation=translation, rotation=rotation),
            )

        return self.type("tf2_msgs/msg/TFMessage")(transforms=[stamped(*edge) for edge in edges])

    def serialize(self, message: object) -> bytes:
        serialize = self.store.serialize_ros1 if self.ros_version == 1 else self.store.serialize_cdr
        return serialize(message, type(message).__msgtype__)


def write_bag(
    path: Path,
    ros: RosMessages,
    messages: list[tuple[float, str, object]],
    *,
    storage: str = "sqlite3",
    compression: str | None = None,
) -> None:
    """(log time s, topic, message) to a ROS 1 .bag (`compression`: bz2 or lz4 chunks, as
    `rosbag record --bz2/--lz4` writes) or a ROS 2 bag folder (`storage`: sqlite3 or mcap,
    rosbag2 version 9 with the message definitions, as Jazzy writes; `compression`: file or
    message, zstd as `ros2 bag record --compression-mode` writes)."""
    if ros.ros_version == 1:
        from rosbags.rosbag1 import Writer

        writer = Writer(path)
        if compression is not None:
            writer.set_compression(getattr(Writer.CompressionFormat, compression.upper()))
    else:
        from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer

        writer = Writer(path, version=9, storage_plugin=getattr(StoragePlugin, storage.upper()))
        if compression is not None:
            writer.set_compression(getattr(CompressionMode, compression.upper()), CompressionFormat.ZSTD)
    with writer:
        connections = {}
        for time_s, topic, message in sorted(messages, key=lambda m: m[0]):
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, type(message).__msgtype__, typestore=ros.store)
            writer.write(connections[topic], int((ros.origin_s + max(time_s, 0.0)) * 1e9), ros.serialize(message))


def write_humble_bag(folder: Path, ros: RosMessages, messages: list[tuple[float, str, object]], *, files: int = 1) -> None:
    """A ROS 2 Humble bag as `ros2 bag record` writes it: metadata.yaml version 5 and sqlite3
    files of schema 3, without the message definitions that later rosbag2 versions keep;
    `files` > 1: split as `--max-bag-size` does (here into as many messages a file),
    `{name}_0.db3`, `{name}_1.db3`..."""
    import sqlite3

    import yaml

    assert ros.ros_version == 2
    folder.mkdir(parents=True)
    ordered = sorted(messages, key=lambda m: m[0])
    topics: dict[str, tuple[int, str, int]] = {}
    stamps = []
    names = [f"{folder.name}_{k}.db3" for k in range(files)]
    databases = []
    for name in names:
        db = sqlite3.connect(folder / name)
        db.executescript(
            "CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);"
            "INSERT INTO schema VALUES (3, 'humble');"
            "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,"
            " serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);"
            "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL,"
            " data BLOB NOT NULL);"
        )
        databases.append(db)
    for n, (time_s, topic, message) in enumerate(ordered):
        msgtype = type(message).__msgtype__
        if topic not in topics:
            topics[topic] = (len(topics) + 1, msgtype, 0)
            for db in databases:  # each split file lists every topic, as rosbag2 writes them
                db.execute("INSERT INTO topics VALUES (?, ?, ?, 'cdr', '')", (len(topics), topic, msgtype))
        number, _, count = topics[topic]
        topics[topic] = (number, msgtype, count + 1)
        stamp = int((ros.origin_s + max(time_s, 0.0)) * 1e9)
        stamps.append(stamp)
        db = databases[n * files // len(ordered)]
        db.execute("INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)", (number, stamp, ros.serialize(message)))
    for db in databases:
        db.commit()
        db.close()
    info = {
        "version": 5,
        "storage_identifier": "sqlite3",
        "relative_file_paths": names,
        "duration": {"nanoseconds": max(stamps) - min(stamps)},
        "starting_time": {"nanoseconds_since_epoch": min(stamps)},
        "message_count": len(stamps),
        "topics_with_message_count": [
            {
                "topic_metadata": {"name": t, "type": msgtype, "serialization_format": "cdr", "offered_qos_profiles": ""},
                "message_count": count,
            }
            for t, (_, msgtype, count) in topics.items()
        ],
        "compression_format": "",
        "compression_mode": "",
    }
    (folder / "metadata.yaml").write_text(yaml.safe_dump({"rosbag2_bagfile_information": info}, sort_keys=False))


def write_rosbag(recorded: Recorded, path: Path, *, ros_version: int) -> None:
    """/camera/color/image_raw (rgb8) and /camera/depth/image_rect_raw (16UC1, mm) with their
    CameraInfo, and /tf_static placing both optical frames under camera_link."""
    rig = recorded.rig
    assert rig.depth_scale_m == 0.001 and rig.depth_camera is not None
    ros = RosMessages(ros_version)
    color, depth = "camera_color_optical_frame", "camera_depth_optical_frame"
    # camera_link sits at the colour camera; the depth optical frame beside it.
    tf = ros.tf_static([("camera_link", color, np.eye(4)), ("camera_link", depth, rig.color_from_depth)])
    messages = [
        (0.0, "/tf_static", tf),
        (0.0, "/camera/color/camera_info", ros.camera_info(0.0, rig.color_camera, color)),
        (0.0, "/camera/depth/camera_info", ros.camera_info(0.0, rig.depth_camera, depth)),
    ]
    messages += [(ts, "/camera/color/image_raw", ros.image(ts, rgb, "rgb8", color)) for ts, rgb in recorded.colors]
    messages += [(ts, "/camera/depth/image_rect_raw", ros.image(ts, d, "16UC1", depth)) for ts, d in recorded.depths]
    write_bag(path, ros, messages)


_DEVICE_UPTIME_S = 86400.25


@dataclass(kw_only=True)
class RealSenseLayout:
    """What a .bag's device holds, as the RealSense Viewer records each camera."""

    color_format: str = "rgb8"  # the colour stream's pixels: rgb8, bgr8, rgba8, bgra8 or yuyv
    color_on_depth_sensor: bool = False  # D405: colour comes from the stereo module itself
    infrared: bool = False  # the stereo module's two Y8 streams recorded too
    color_model: str = "brown_conrady"  # D415/D435 colour: inverse_brown_conrady (zero coefficients)
    device_name: str | None = None  # the device's camera_info name, as a real device reports it
    compressed: bool = False  # the recorder's LZ4 chunks
    depth_units_option: bool = True  # False: a writer that leaves out the depth sensor's depth_units
    frame_numbers: bool = True  # False: every frame numbered 0, as a writer that never sets them
    extrinsics: bool = True  # False: no depth-to-colour extrinsics registered
    motion: bool = False  # D435i/D455: the Motion Module's accel (100 Hz) and gyro (200 Hz) streams recorded too
    # Streams stamped by the camera's own clock (hardware_clock: ms since it started, a day
    # ago here), the others by the host's (system_time), as a sensor without frame metadata
    # is. The frames are then written in real time: the recorder files each at its arrival.
    device_clock: tuple[str, ...] = ()


_FILING_ATTEMPTS = 5


def write_realsense_streams(
    path: Path,
    rig: Rig,
    colors: list[tuple[float, np.ndarray]],
    depths: list[tuple[float, np.ndarray]],
    layout: RealSenseLayout | None = None,
) -> None:
    """A RealSense .bag written by pyrealsense2's software device and recorder (2.55.1 writes
    .bag), depth in the depth sensor's units with its own intrinsics and extrinsics to colour;
    colour given as RGB, stored in the layout's format. With `device_clock` the frames are
    filed in real time, and written again when the scheduler filed one late (a loaded machine):
    their filed times must keep the given spacing within min(period / 4, 15 ms)."""
    layout = layout or RealSenseLayout()
    for _ in range(_FILING_ATTEMPTS if layout.device_clock else 1):
        _record_realsense(path, rig, colors, depths, layout)
        if not layout.device_clock or _filed_on_time(path, colors, depths, min(0.25 * rig.period_s, 0.015)):
            return
    raise RuntimeError(f"{path}: the frames were not filed on time in {_FILING_ATTEMPTS} attempts")


def _filed_on_time(path: Path, colors: list[tuple[float, np.ndarray]], depths: list[tuple[float, np.ndarray]], tolerance_s: float) -> bool:
    """Whether the bag's colour and depth frames were filed at their times (each stream in
    order; one common shift allowed) within `tolerance_s`."""
    from rosbags.rosbag1 import Reader

    filed: dict[str, list[float]] = {"Color": [], "Depth": []}
    with Reader(path) as reader:
        for connection, log_ns, _ in reader.messages():
            kind = connection.topic.split("/")[3].split("_")[0] if connection.topic.endswith("/image/data") else None
            if kind in filed:
                filed[kind].append(1e-9 * log_ns)
    if [len(filed["Color"]), len(filed["Depth"])] != [len(colors), len(depths)]:
        return False
    shifts = [f - t for kind, given in (("Color", colors), ("Depth", depths)) for f, (t, _) in zip(filed[kind], given)]
    return max(shifts) - min(shifts) <= tolerance_s


def _record_realsense(
    path: Path,
    rig: Rig,
    colors: list[tuple[float, np.ndarray]],
    depths: list[tuple[float, np.ndarray]],
    layout: RealSenseLayout,
) -> None:
    import pyrealsense2 as rs

    depth_camera = rig.depth_camera or rig.color_camera

    def intrinsics(camera: Camera, model: str) -> object:
        i = rs.intrinsics()
        i.width, i.height, i.fx, i.fy, i.ppx, i.ppy = camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy
        i.model = getattr(rs.distortion, model)
        i.coeffs = [float(c) for c in (camera.distortion_coefficients if camera.has_distortion else np.zeros(5))]
        return i

    def stored(rgb: np.ndarray) -> np.ndarray:
        form = layout.color_format
        if form == "yuyv":
            return yuv422(rgb, "yuyv")
        channels = rgb[..., ::-1] if form.startswith("bgr") else rgb
        return np.dstack([channels, np.full(rgb.shape[:2], 255, np.uint8)]) if form.endswith("a8") else channels

    device = rs.software_device()
    if layout.device_name:
        device.register_info(rs.camera_info.name, layout.device_name)
        device.register_info(rs.camera_info.serial_number, "123622270224")
    depth_sensor = device.add_sensor("Stereo Module")
    color_sensor = depth_sensor if layout.color_on_depth_sensor else device.add_sensor("RGB Camera")
    # The frame rate the recording claims: one a period (the importer pairs within half of it).
    fps = max(1, round(1 / rig.period_s))
    streams = [
        (depth_sensor, rs.stream.depth, 0, depth_camera, 0, 2, rs.format.z16, "brown_conrady"),
        (color_sensor, rs.stream.color, 0, rig.color_camera, 1, stored(colors[0][1]).shape[2], getattr(rs.format, layout.color_format), layout.color_model),
    ]
    if layout.infrared:
        streams += [(depth_sensor, rs.stream.infrared, n, depth_camera, 1 + n, 1, rs.format.y8, "brown_conrady") for n in (1, 2)]
    profiles = []
    for sensor, kind, index, camera, uid, bpp, form, model in streams:
        stream = rs.video_stream()
        stream.type, stream.uid, stream.index, stream.fps, stream.bpp, stream.fmt = kind, uid, index, fps, bpp, form
        stream.width, stream.height, stream.intrinsics = camera.width, camera.height, intrinsics(camera, model)
        profiles.append(sensor.add_video_stream(stream))
    depth_profile, color_profile = profiles[:2]
    motion_rates = {"accel": 100, "gyro": 200} if layout.motion else {}
    motion_sensor = device.add_sensor("Motion Module") if layout.motion else None
    for uid, (kind, rate) in enumerate(motion_rates.items(), start=10):
        stream = rs.motion_stream()
        stream.type, stream.uid, stream.index, stream.fps, stream.fmt = getattr(rs.stream, kind), uid, 0, rate, rs.format.motion_xyz32f
        profiles.append(motion_sensor.add_motion_stream(stream))
        streams.append((motion_sensor, kind))
    if layout.depth_units_option:
        depth_sensor.add_read_only_option(rs.option.depth_units, rig.depth_scale_m)
    extrinsics = rs.extrinsics()
    extrinsics.rotation = rig.color_from_depth[:3, :3].T.ravel().tolist()  # column-major
    extrinsics.translation = rig.color_from_depth[:3, 3].tolist()
    if layout.extrinsics:
        depth_profile.register_extrinsics_to(color_profile, extrinsics)
    recorder = rs.recorder(str(path), device, layout.compressed)
    queue = rs.syncer()
    sensors = {id(s): s for s, *_ in streams}
    for sensor in sensors.values():
        sensor.open([profile for profile, (owner, *_) in zip(profiles, streams) if owner is sensor])
        sensor.start(queue)
    events = [(t, "depth", d) for t, d in depths] + [(t, "color", stored(c)) for t, c in colors]
    if layout.infrared:
        events += [(t, f"infrared{n}", np.zeros(d.shape, np.uint8)) for t, d in depths for n in (1, 2)]
    end_s = max(t for t, *_ in events)
    for kind, rate in motion_rates.items():  # gravity on y, a little noise: what a still camera reads
        events += [(k / rate, kind, np.array([0.01, -9.81 if kind == "accel" else 0.0, 0.02], np.float32)) for k in range(int(end_s * rate) + 1)]
    profile_of = dict(zip(["depth", "color", *(["infrared1", "infrared2"] if layout.infrared else []), *motion_rates], profiles))
    sensor_of = {"depth": depth_sensor, "color": color_sensor, "infrared1": depth_sensor, "infrared2": depth_sensor}
    sensor_of |= dict.fromkeys(motion_rates, motion_sensor)
    numbers = dict.fromkeys(profile_of, 0)
    started = time.monotonic()
    for t, kind, pixels in sorted(events, key=lambda e: e[0]):
        numbers[kind] += 1
        if layout.device_clock:  # the recorder files each frame at its arrival: on one clock, the host's
            time.sleep(max(0.0, started + t - time.monotonic()))
        if kind in motion_rates:
            motion = rs.software_motion_frame()
            motion.data = rs.vector()
            motion.data.x, motion.data.y, motion.data.z = (float(v) for v in pixels)
            motion.timestamp, motion.domain, motion.frame_number = 1000.0 * (t + 1.0), rs.timestamp_domain.system_time, numbers[kind]
            motion.profile = profile_of[kind].as_motion_stream_profile()
            motion_sensor.on_motion_frame(motion)
            continue
        frame = rs.software_video_frame()
        frame.pixels = np.ascontiguousarray(pixels)
        frame.bpp = pixels.itemsize * (pixels.shape[2] if pixels.ndim == 3 else 1)
        frame.stride = pixels.shape[1] * frame.bpp
        on_device = kind in layout.device_clock
        frame.timestamp = 1000.0 * (t + (_DEVICE_UPTIME_S if on_device else 1.0))
        frame.domain = rs.timestamp_domain.hardware_clock if on_device else rs.timestamp_domain.system_time
        frame.frame_number = numbers[kind] if layout.frame_numbers else 0
        frame.profile = profile_of[kind].as_video_stream_profile()
        if kind == "depth":
            frame.depth_units = rig.depth_scale_m
        sensor_of[kind].on_video_frame(frame)
    for sensor in sensors.values():
        sensor.stop()
        sensor.close()
    del recorder  # closes the file


def write_realsense_bag(recorded: Recorded, path: Path) -> None:
    """The recorded streams as a RealSense Viewer .bag of a D400 (RGB colour on its own sensor)."""
    assert recorded.rig.depth_camera is not None
    write_realsense_streams(path, recorded.rig, recorded.colors, recorded.depths)


@dataclass(kw_only=True)
class TinyFrames:
    """A few small frames to write in a recording's layout and read back: what an import test
    compares the capture folder with."""

    camera: Camera  # colour's, depth registered to it
    times_s: list[float]  # each frame's (both streams'; a writer may jitter them)
    colors: list[np.ndarray]  # RGB uint8; constant over 2x2 blocks (chroma subsampling, Bayer keep them)
    depths_m: list[np.ndarray]  # float64 metres on the millimetre grid, 0 where there is none


def tiny_frames(n: int = 5, *, width: int = 16, height: int = 12, period_s: float = 1 / 30, seed: int = 0) -> TinyFrames:
    rng = np.random.default_rng(seed)
    camera = Camera(width=width, height=height, fx=20.0, fy=20.0, cx=(width - 1) / 2, cy=(height - 1) / 2)
    blocks = [rng.integers(16, 240, (height // 2, width // 2, 3), dtype=np.uint8) for _ in range(n)]
    colors = [np.repeat(np.repeat(b, 2, axis=0), 2, axis=1) for b in blocks]
    depths = [np.round(rng.uniform(0.35, 0.95, (height, width)), 3) for _ in range(n)]
    for depth in depths:
        depth[rng.random(depth.shape) < 0.1] = 0.0
    return TinyFrames(camera=camera, times_s=[0.5 + k * period_s for k in range(n)], colors=colors, depths_m=depths)


def read_back(capture_dir: Path) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """A capture folder's colour (RGB) and depth (metres, 0 for none) frames in order."""
    from turntable.capture import load_capture, read_color, read_depth

    capture = load_capture(capture_dir)
    colors = [read_color(f.color, capture.camera) for f in capture.frames]
    depths = [np.nan_to_num(read_depth(f.depth, capture.camera), nan=0.0) for f in capture.frames]
    return colors, depths


def encode_rvl(image: np.ndarray) -> bytes:
    """RVL of a uint16 image as the paper's encoder (and ROS 2's compressed_depth_image_transport)
    writes it: 4-bit codes packed high end first into little-endian 32-bit words; runs of zeros
    and of non-zero pixels, the latter as zigzag differences from the previous non-zero pixel."""
    codes: list[int] = []

    def put(value: int) -> None:
        while True:
            code, value = value & 0x7, value >> 3
            codes.append(code | (0x8 if value else 0))
            if not value:
                return

    flat = [int(v) for v in np.asarray(image).ravel()]
    at, previous = 0, 0
    while at < len(flat):
        start = at
        while at < len(flat) and flat[at] == 0:
            at += 1
        put(at - start)
        start = at
        while at < len(flat) and flat[at] != 0:
            at += 1
        put(at - start)
        for value in flat[start:at]:
            delta, previous = value - previous, value
            put((delta << 1) ^ (delta >> 31))
    codes += [0] * (-len(codes) % 8)
    words = [int("".join(f"{c:x}" for c in codes[k : k + 8]), 16) for k in range(0, len(codes), 8)]
    return np.array(words, "<u4").tobytes()


def _bt601(rgb: np.ndarray) -> np.ndarray:
    """Y, U, V in video range, as UVC cameras and ROS's yuv422 drivers deliver them."""
    r, g, b = (rgb[..., k].astype(np.float64) for k in range(3))
    y = 16 + (65.481 * r + 128.553 * g + 24.966 * b) / 255
    u = 128 + (-37.797 * r - 74.203 * g + 112.0 * b) / 255
    v = 128 + (112.0 * r - 93.786 * g - 18.214 * b) / 255
    return np.round(np.stack([y, u, v], axis=-1)).clip(0, 255).astype(np.uint8)


def yuv422(rgb: np.ndarray, order: str) -> np.ndarray:
    """(H, W, 2) bytes of a 4:2:2 image, `order` "uyvy" or "yuyv" (chroma of the pair's first pixel)."""
    yuv = _bt601(rgb)
    y, u, v = yuv[..., 0], yuv[:, 0::2, 1], yuv[:, 0::2, 2]
    out = np.empty(rgb.shape[:2] + (2,), np.uint8)
    chroma_first = order == "uyvy"
    out[..., 1 if chroma_first else 0] = y
    out[:, 0::2, 0 if chroma_first else 1] = u
    out[:, 1::2, 0 if chroma_first else 1] = v
    return out
