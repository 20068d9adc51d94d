"""ROS 1 (.bag) and ROS 2 (a folder with metadata.yaml, or its .db3/.mcap) recordings, read
with the pure-Python `rosbags`: a colour and a depth `sensor_msgs/Image` (or
`CompressedImage`) topic, each with the `CameraInfo` beside it, and `/tf_static` for the
depth camera's pose in colour's when the depth is not registered (an `aligned_depth_to_color`
topic, or depth in colour's frame at its size, is)."""

from __future__ import annotations

import glob
import re
import shutil
import tempfile
from collections import deque
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from homemodel.core.errors import InputError
from homemodel.geometry.camera import Camera
from turntable.recordings.images import (
    decode_compressed_message,
    decode_image_message,
    is_color_encoding,
    is_depth_encoding,
)
from turntable.recordings.lens import opencv_pixel_rays, refit_as_brown_conrady, undistort_opencv, undistortion_maps
from turntable.recordings.mcap_cut import is_cut_short, recovered_copy, remove_copies
from turntable.recordings.source import StreamSetup
from turntable.recordings.timed import TimedStreamsSource

# A storage file compressed whole (`ros2 bag record --compression-mode file`): images compress
# a few times at most, so past this ratio it is no recording (a decompression bomb).
MAX_ZSTD_RATIO = 100
FREE_SPACE_KEPT_BYTES = 1 << 30
ZSTD_CHUNK_BYTES = 1 << 22

IMAGE_TYPES = ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage")
INFO_TYPE = "sensor_msgs/msg/CameraInfo"
TF_TYPE = "tf2_msgs/msg/TFMessage"
FLOAT_DEPTH_SCALE_M = 0.0001  # float depth (32FC1 metres) is written in 0.1 mm units
# A rational colour lens whose five-term refit is off more than this somewhere has its images
# undistorted instead: check29b's Azure-like lens (k4-k6 0.39 -2.43 1.37) refitted 7.2 px off
# at worst, 0.53 px in the median, and its bottle came out 0.78 mm from the truth against its
# twin's 0.14. The tags' corners are read to ~0.1 px.
MAX_REFIT_PX = 0.25
_SPLIT_PART = re.compile(r"^(?P<prefix>.+)_(?P<index>\d+)$")
# rosbag starts a part at the first message past the limit: the gap is one message interval.
_SPLIT_GAP_S = 1.0


def unreadable_bag(exc: Exception) -> str:
    """Why a bag reader refused a file, in words: rosbags says a bag cut short (a copy or a
    recording stopped mid-write) as "Bag index looks damaged: ('Header could not be read ...',)",
    and an MCAP file without its footer (a recorder killed before closing it) as "File end
    magic is invalid"; a file that is no bag at all as "File magic is invalid"."""
    text = str(exc).lower()
    if "index looks damaged" in text:
        return "cut short or damaged: its index cannot be read"
    if "end magic is invalid" in text:
        return "cut short: its MCAP file has no end (a recording killed before it closed the file); `mcap recover` rewrites it whole"
    if "file magic is invalid" in text:
        return "it is no bag file (its first bytes are not a bag's)"
    return str(exc)


ROS2_STORAGE = (".db3", ".mcap")


def is_storage_file(path: Path) -> bool:
    """A ROS 2 storage file: `.db3`, `.mcap`, or either compressed whole (`--compression-mode file`: `.db3.zstd`)."""
    return path.suffix in ROS2_STORAGE or (path.suffix == ".zstd" and Path(path.stem).suffix in ROS2_STORAGE)


def storage_files(folder: Path) -> list[Path]:
    """A ROS 2 bag folder's storage files in their split order (`name_0.mcap`, `name_1.mcap`...)."""
    found = [p for p in folder.iterdir() if is_storage_file(p) and p.is_file() and not p.name.startswith(".")]
    return sorted(found, key=lambda p: tuple(int(t) if t.isdigit() else t for t in re.split(r"(\d+)", p.stem)))


def ros2_paths(path: Path) -> list[Path]:
    """What rosbags opens of a ROS 2 bag: its folder (given as itself, its metadata.yaml, or one
    of its storage files); a folder without metadata.yaml (a recorder killed before it wrote
    one, or files copied without it): its storage files, each read on its own."""
    path = Path(path)
    if path.is_file() and path.name == "metadata.yaml":
        return [path.parent]
    if path.is_file() and is_storage_file(path) and (path.parent / "metadata.yaml").is_file():
        return [path.parent]
    if path.is_dir() and not (path / "metadata.yaml").is_file():
        return storage_files(path) or [path]
    return [path]


def split_parts(path: Path) -> list[Path]:
    """A ROS 1 bag `rosbag record --split` wrote in parts (`scan_0.bag`, `scan_1.bag`... or
    `scan_<date>_0.bag`...): every part, in order, whichever was given. Parts follow each other
    in time; a sibling that starts later than `_SPLIT_GAP_S` after the previous one's end is
    another recording with a similar name (`take_1.bag`, `take_2.bag`), not a part."""
    from rosbags.rosbag1 import Reader, ReaderError

    match = _SPLIT_PART.match(path.stem)
    if path.suffix != ".bag" or match is None:
        return [path]
    prefix = match["prefix"]
    numbered = {}
    for sibling in path.parent.glob(f"{glob.escape(prefix)}_*.bag"):
        found = _SPLIT_PART.match(sibling.stem)
        if found is not None and found["prefix"] == prefix:
            numbered[int(found["index"])] = sibling
    spans, broken = {}, {}
    for index, part in numbered.items():
        try:
            with Reader(part) as reader:
                spans[index] = (reader.start_time, reader.end_time)
        except (ReaderError, OSError, ValueError, KeyError) as exc:
            broken[index] = exc
    given = int(match["index"])
    if given not in spans:
        return [path]  # its own error comes when it is opened

    def joins(before: int, after: int) -> bool:
        for index in (before, after):
            if index in broken:  # a part missing from the middle of a recording: refused, not skipped
                raise InputError(
                    f"{numbered[index]}: a part of the split bag {path.name} is not readable: {unreadable_bag(broken[index])}"
                )
        return before in spans and after in spans and 0 <= spans[after][0] - spans[before][1] <= _SPLIT_GAP_S * 1e9

    first = last = given
    while joins(first - 1, first):
        first -= 1
    while joins(last, last + 1):
        last += 1
    # A part missing from the numbering: the next part found starts no later than the missing
    # ones could have lasted (as long as the longest part, each) after the run's end.
    longest_ns = max(end - start for start, end in spans.values())
    for edge, step in ((last, 1), (first, -1)):
        beyond = [index for index in spans if (index - edge) * step > 1]
        if edge + step in numbered or not beyond:
            continue
        nearest = min(beyond, key=lambda index: abs(index - edge))
        gap_ns = spans[nearest][0] - spans[edge][1] if step > 0 else spans[edge][0] - spans[nearest][1]
        if 0 <= gap_ns <= (abs(nearest - edge) - 1) * longest_ns + _SPLIT_GAP_S * 1e9:
            missing = path.with_name(f"{prefix}_{edge + step}.bag")
            raise InputError(f"{missing}: a part of the split bag {path.name} is missing ({numbered[nearest].name} follows it)")
    return [numbered[index] for index in range(first, last + 1)]


def _field(message: object, *names: str) -> object:
    for name in names:  # ROS 2 spells CameraInfo's fields k, d; ROS 1 K, D
        if hasattr(message, name):
            return getattr(message, name)
    raise AttributeError(names[0])


def _stamp_s(message: object) -> float:
    stamp = message.header.stamp
    return float(stamp.sec) + 1e-9 * float(stamp.nanosec)


def is_rectified(image_topic: str) -> bool:
    """A topic named rectified: image_proc's `image_rect`, `image_rect_color`, iai_kinect2's
    `image_color_rect`, `image_depth_rect`, or a `rect` namespace. Its CameraInfo's D is the raw
    image's lens, already undone, so it is seen with P, without distortion. (realsense-ros's
    `image_rect_raw` is its sensor's own image.)"""
    parts = image_topic.strip("/").split("/")
    name = parts[-1]
    return "rect" in parts or name.endswith("_rect") or (name.startswith("image_rect") and name != "image_rect_raw")


def camera_from_info(info: object, where: str, *, rectified: bool = False) -> tuple[Camera, list[str], list[float] | None]:
    """The Camera of a CameraInfo (plumb_bob / rational_polynomial: Brown-Conrady; equidistant:
    Kannala-Brandt; a rectified image: P's intrinsics, no distortion), notes on what it could
    not carry, and the lens to undo in its images (a rational one the five terms do not hold:
    the Camera is then its pinhole), else None."""
    k = np.asarray(_field(info, "k", "K"), dtype=np.float64).reshape(3, 3)
    d = [float(v) for v in np.asarray(_field(info, "d", "D"), dtype=np.float64)]
    model = str(info.distortion_model).lower()
    width, height = int(info.width), int(info.height)
    if rectified:
        k = np.asarray(_field(info, "p", "P"), dtype=np.float64).reshape(3, 4)[:, :3]
    if k[0, 0] <= 0 or k[1, 1] <= 0 or width <= 0 or height <= 0:
        raise InputError(f"{where}: the CameraInfo has no intrinsics (K = {k.ravel().tolist()}, {width}x{height})")
    notes = []
    camera = Camera.from_matrix(k, width=width, height=height)
    if rectified:
        if any(d):
            notes.append(f"{where}: rectified images: read as a pinhole with the CameraInfo's P, its distortion D {np.trim_zeros(d, 'b')} left out")
        return camera, notes, None
    if model == "equidistant":
        kannala_brandt = {"distortion": tuple((d + [0.0] * 4)[:4]), "distortion_model": "kannala_brandt"}
        return Camera(**{**camera.model_dump(), **kannala_brandt}), notes, None
    if not any(d):
        return camera, notes, None
    if model not in ("plumb_bob", "rational_polynomial", ""):
        notes.append(f"{where}: distortion model {info.distortion_model!r} read as Brown-Conrady")
    if any(d[5:]):  # k4-k6 (Azure Kinect's lenses need them): fit the five-term model to all eight
        eight = (d + [0.0] * 8)[:8]
        refitted, residual_px = refit_as_brown_conrady(camera, undistort_opencv(eight))
        if residual_px <= MAX_REFIT_PX:
            notes.append(f"{where}: rational terms k4-k6 {d[5:8]} refitted as Brown-Conrady ({residual_px:.3f} px at worst)")
            return refitted, notes, None
        notes.append(
            f"{where}: its images undistorted with the rational lens's eight terms (k4-k6 {d[5:8]}; refitted as "
            f"Brown-Conrady they were {residual_px:.3f} px off at worst)"
        )
        return camera, notes, eight
    return Camera(**{**camera.model_dump(), "distortion": tuple((d + [0.0] * 5)[:5])}), notes, None


class _TfTree:
    def __init__(self) -> None:
        self.edges: dict[str, list[tuple[str, np.ndarray]]] = {}

    def add(self, parent: str, child: str, parent_from_child: np.ndarray) -> None:
        self.edges.setdefault(parent, []).append((child, parent_from_child))
        self.edges.setdefault(child, []).append((parent, np.linalg.inv(parent_from_child)))

    def a_from_b(self, a: str, b: str) -> np.ndarray | None:
        """Breadth-first from b to a, composing; None when not connected."""
        found = {b: np.eye(4)}
        queue = deque([b])
        while queue:
            frame = queue.popleft()
            for other, frame_from_other in self.edges.get(frame, []):
                if other not in found:
                    found[other] = np.linalg.inv(frame_from_other) @ found[frame]  # other_from_b
                    queue.append(other)
        return found.get(a)


def _transform_matrix(transform: object) -> np.ndarray:
    q, t = transform.rotation, transform.translation
    matrix = np.eye(4)
    from scipy.spatial.transform import Rotation

    matrix[:3, :3] = Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix()
    matrix[:3, 3] = [t.x, t.y, t.z]
    return matrix


# realsense-ros's depth-to-colour extrinsics, and its ROS 2 message (ROS 1's adds a header
# first; its bags carry their definitions).
_EXTRINSICS_TOPIC = "extrinsics/depth_to_color"
_EXTRINSICS_MSG = "float64[9] rotation\nfloat64[3] translation"
# Topic names that say the depth was registered to colour (realsense-ros, openni, Azure Kinect).
_REGISTERED_NAMES = ("aligned_depth_to_color", "depth_registered", "depth_to_rgb", "depth_to_color")


def _named_registered(depth_topic: str) -> bool:
    return any(name in depth_topic for name in _REGISTERED_NAMES)


def image_base(connection: object) -> str:
    """The image topic a connection carries: an image_transport plugin's topic
    (`.../image_raw/compressed`, `.../compressedDepth`) less its plugin's name."""
    if connection.msgtype == "sensor_msgs/msg/CompressedImage":
        return connection.topic.rsplit("/", 1)[0]
    return connection.topic


def _namespace(connection: object) -> str:
    return image_base(connection).rsplit("/", 1)[0]


def _shared_prefix(a: str, b: str) -> int:
    parts_a, parts_b = a.split("/"), b.split("/")
    return next((n for n, (x, y) in enumerate(zip(parts_a, parts_b)) if x != y), min(len(parts_a), len(parts_b)))


class RosBagSource(TimedStreamsSource):
    """Both ROS generations; `format` says which the importer named (ros1 or ros2)."""

    def __init__(self, path: Path, *, ros_version: int, **kwargs: object) -> None:
        super().__init__(path, **kwargs)
        self.ros_version = ros_version
        self._reader = None
        self._without_metadata = False
        self._color_maps: tuple[np.ndarray, np.ndarray] | None = None  # `lens.undistortion_maps` of colour's
        self._copies: Path | None = None  # a temporary folder of storage files made readable (decompressed, cut MCAP)

    def open(self) -> StreamSetup:
        try:
            return self._open()
        except BaseException:
            self.close()  # the cut MCAP files' copies too: `with` does not close what did not open
            raise

    def _open(self) -> StreamSetup:
        from rosbags.highlevel import AnyReader, AnyReaderError
        from rosbags.typesys import Stores, get_typestore

        cut_notes: list[str] = []
        try:
            # Bags before ROS 2 Iron keep no message definitions: read them as Humble's.
            paths = split_parts(self.path) if self.ros_version == 1 else ros2_paths(self.path)
            with_metadata = any(p.is_dir() for p in paths)
            if self.ros_version == 2:
                paths = self._read_up_to_cuts(paths, cut_notes)
            reader = AnyReader(paths, default_typestore=get_typestore(Stores.ROS2_HUMBLE))
            reader.open()
            self._reader = reader  # once open: close() closes it
        except (AnyReaderError, OSError, ValueError, KeyError) as exc:
            raise InputError(f"{self.path}: not a readable ROS {self.ros_version} bag: {unreadable_bag(exc)}") from None
        where = str(self.path)
        split_note = [f"a bag split in {len(paths)} parts: {', '.join(p.name for p in paths)} read"] if len(paths) > 1 else []
        self._without_metadata = self.ros_version == 2 and paths[0].is_file()
        if self._without_metadata:
            without = "without its metadata.yaml" if with_metadata else "no metadata.yaml"
            split_note = [f"{without}: {', '.join(p.name for p in paths)} read on {'their' if len(paths) > 1 else 'its'} own"]
        split_note += cut_notes
        reader = self._reader
        images = {c.topic: c for c in reader.connections if c.msgtype in IMAGE_TYPES}
        self._depth_dtypes: dict[str, type] = {}
        self._sizes: dict[str, tuple[int, int]] = {}  # image topic -> (width, height) of its first image
        kinds = {topic: self._kind(c) for topic, c in images.items()}
        colors = [c for topic, c in images.items() if kinds[topic] == "color"]
        depths = [c for topic, c in images.items() if kinds[topic] == "depth"]
        if not depths:
            raise InputError(f"{where}: no depth image topic (16UC1, 32FC1 or compressedDepth); topics: {sorted(kinds)}")
        if not colors:
            raise InputError(f"{where}: no colour image topic; topics: {sorted(kinds)}")
        infos = {c.topic: self._info_for(c) for c in colors + depths}

        def registered_to(color: object) -> list[object]:
            info = infos[color.topic]
            return [] if info is None else [d for d in depths if self._registered(d, infos[d.topic], info)]

        # The colour camera's own stream (not infrared, nor colour resampled into the depth
        # camera's pixels), one with a depth registered to it first, raw before compressed.
        self._color = max(
            colors,
            key=lambda c: (
                ("color" in c.topic or "rgb" in c.topic) and "to_depth" not in c.topic,
                bool(registered_to(c)),
                c.msgtype == "sensor_msgs/msg/Image",
                -len(c.topic),
            ),
        )
        color_info = infos[self._color.topic]
        if color_info is None:
            raise InputError(f"{where}: no intrinsics: no CameraInfo beside {self._color.topic}")
        registered = registered_to(self._color)
        self._depth = max(
            depths,
            key=lambda c: (
                c in registered,
                _shared_prefix(_namespace(c), _namespace(self._color)),
                c.msgtype == "sensor_msgs/msg/Image",
                "depth" in c.topic,
            ),
        )
        depth_info = infos[self._depth.topic]
        color_camera, notes, lens = camera_from_info(
            color_info, f"{where} {self._color.topic}", rectified=is_rectified(image_base(self._color))
        )
        self._color_maps = None if lens is None else undistortion_maps(color_camera, lens)
        depth_scale = 0.001 if self._depth_dtypes[self._depth.topic] == np.uint16 else FLOAT_DEPTH_SCALE_M
        color_camera = Camera(**{**color_camera.model_dump(), "depth_scale_m": depth_scale})
        setup = StreamSetup(format=f"ros{self.ros_version}", color_camera=color_camera, notes=split_note + notes)
        if self._depth in registered and depth_info is None and not _named_registered(self._depth.topic):
            setup.notes.append(f"{self._depth.topic} has no CameraInfo and colour's size: taken as registered to colour")
        elif (
            self._depth in registered
            and depth_info is not None
            and not _named_registered(self._depth.topic)
            and depth_info.header.frame_id != color_info.header.frame_id
        ):
            setup.notes.append(
                f"{self._depth.topic} in {depth_info.header.frame_id!r} has colour's intrinsics and no transform to "
                f"{color_info.header.frame_id!r}: taken as registered to colour"
            )
        if self._depth not in registered:
            if depth_info is None:
                raise InputError(f"{where}: no intrinsics for the unregistered depth: no CameraInfo beside {self._depth.topic}")
            rectified = is_rectified(image_base(self._depth))
            setup.depth_camera, depth_notes, _ = camera_from_info(depth_info, f"{where} {self._depth.topic}", rectified=rectified)
            d = [float(v) for v in np.asarray(_field(depth_info, "d", "D"), dtype=np.float64)]
            if any(d[5:]) and not rectified:
                # A lens with k4-k6 (an Azure Kinect's 120-degree WFOV one is 580 px off its
                # Brown-Conrady refit): the depth reprojected along its own model's rays.
                setup.depth_rays, lost = opencv_pixel_rays(setup.depth_camera, (d + [0.0] * 8)[:8])
                depth_notes = [f"{where} {self._depth.topic}: rays from its rational_polynomial lens ({lost:.1%} of pixels past its reach)"]
            setup.notes += depth_notes
            setup.color_from_depth, placed_by = self._color_from_depth(color_info.header.frame_id, depth_info.header.frame_id)
            if placed_by not in (None, "/tf_static"):
                setup.notes.append(f"no /tf_static: the depth camera placed by {placed_by}")
            if setup.color_from_depth is None:  # then placed by its edges (TimedStreamsSource)
                setup.notes.append(f"no /tf_static from {depth_info.header.frame_id} to {color_info.header.frame_id}")
        return setup

    def _color_from_depth(self, color_frame: str, depth_frame: str) -> tuple[np.ndarray | None, str | None]:
        """The depth camera's pose in colour's and what gave it: one frame, /tf_static, else
        /tf, else realsense-ros's extrinsics; (None, None) when nothing does."""
        if color_frame == depth_frame:
            return np.eye(4), None
        for placed_by, find in (
            ("/tf_static", lambda: self._tf(color_frame, depth_frame, "/tf_static")),
            ("/tf", lambda: self._tf(color_frame, depth_frame, "/tf")),
            (_EXTRINSICS_TOPIC, self._realsense_extrinsics),
        ):
            if (found := find()) is not None:
                return found, placed_by
        return None, None

    def _realsense_extrinsics(self) -> np.ndarray | None:
        """color_from_depth from realsense-ros's `.../extrinsics/depth_to_color` (a column-major
        rotation and a translation in metres), recorded where /tf_static was not."""
        connections = [c for c in self._reader.connections if c.topic.endswith(_EXTRINSICS_TOPIC)]
        if not connections:
            return None
        msgtype = connections[0].msgtype
        if msgtype not in self._reader.typestore.fielddefs:  # a bag without message definitions
            from rosbags.typesys import get_types_from_msg

            self._reader.typestore.register(get_types_from_msg(_EXTRINSICS_MSG, msgtype))
        message = self._first(connections[0].topic)
        matrix = np.eye(4)
        matrix[:3, :3] = np.asarray(message.rotation, dtype=np.float64).reshape(3, 3).T
        matrix[:3, 3] = np.asarray(message.translation, dtype=np.float64)
        return matrix

    def _registered(self, depth: object, depth_info: object | None, color_info: object) -> bool:
        """Depth in colour's pixels: said by its topic's name, or its CameraInfo is colour's (its
        frame, or its intrinsics with no transform between the frames), or it has none and
        colour's size (a camera's single CameraInfo)."""
        if _named_registered(depth.topic):
            return True
        color_size = (int(color_info.width), int(color_info.height))
        if depth_info is None:
            return self._sizes[depth.topic] == color_size
        depth_size = (int(depth_info.width), int(depth_info.height))
        if depth_size != color_size:
            return False
        frames = (color_info.header.frame_id, depth_info.header.frame_id)
        if frames[0] == frames[1]:
            return True
        # A frame of its own but colour's intrinsics and no transform to colour's frame (the
        # older ros2_astra_camera names its registered depth's frame `color_optical_frame`
        # beside colour's `camera_color_optical_frame`): reprojecting it would not move a pixel.
        same_lens = True
        for names in (("k", "K"), ("d", "D")):
            a, b = (np.asarray(_field(info, *names), dtype=np.float64) for info in (depth_info, color_info))
            same_lens &= a.shape == b.shape and np.allclose(a, b)
        return same_lens and self._color_from_depth(*frames)[0] is None

    def close(self) -> None:
        if self._reader is not None:
            self._reader.close()
        remove_copies(self._copies)
        self._copies = None

    def _read_up_to_cuts(self, paths: list[Path], notes: list[str]) -> list[Path]:
        """`paths`, or where a storage file among them is compressed whole without the
        metadata.yaml that says so, or is an MCAP file cut short (its recorder killed), their
        storage files each on its own: the compressed ones by a decompressed copy, the cut ones
        by a copy holding their complete records (`mcap_cut`), said in `notes`."""
        files = [file for p in paths for file in (storage_files(p) if p.is_dir() else [p])]
        cut = [file for file in files if file.suffix == ".mcap" and is_cut_short(file)]
        # Read through metadata.yaml (none cut), rosbags decompresses them itself.
        read_alone = bool(cut) or any(p.is_file() for p in paths)
        compressed = [file for file in files if file.suffix == ".zstd"] if read_alone else []
        if not compressed and not cut:
            return paths
        self._copies = Path(tempfile.mkdtemp(prefix="homemodel-bag-copies-"))
        read = []
        for file in files:
            if file in compressed:
                file = self._decompressed(file)
                notes.append(f"{file.name}.zstd decompressed (a bag recorded with --compression-mode file)")
            if file in cut:
                file, dropped = recovered_copy(file, self._copies)
                notes.append(f"{file.name} cut short (its recorder killed): read up to the cut, its last {dropped} bytes left out")
            read.append(file)
        return read

    def _decompressed(self, file: Path) -> Path:
        """A zstd-compressed storage file decompressed into the copies' folder (name without .zstd),
        refused once it grows past `MAX_ZSTD_RATIO` times its compressed size (a hostile file of a
        few kB can claim terabytes) or would leave the folder's disk under FREE_SPACE_KEPT_BYTES
        free (a real recording too large for it: said as such)."""
        import zstandard

        assert self._copies is not None
        copy = self._copies / file.stem
        limit = MAX_ZSTD_RATIO * max(file.stat().st_size, 1)
        room = shutil.disk_usage(self._copies).free - FREE_SPACE_KEPT_BYTES
        written = 0
        try:
            with file.open("rb") as source, copy.open("wb") as target, zstandard.ZstdDecompressor().stream_reader(source) as reader:
                while chunk := reader.read(ZSTD_CHUNK_BYTES):
                    written += len(chunk)
                    if written > limit:
                        raise InputError(f"{file}: decompresses to more than {MAX_ZSTD_RATIO}x its size: not a recording's storage file")
                    if written > room:
                        raise InputError(
                            f"{file}: decompressed it would leave under {FREE_SPACE_KEPT_BYTES >> 30} GiB free in "
                            f"{self._copies.parent}: free some space there, or set TMPDIR to a larger disk"
                        )
                    target.write(chunk)
        except zstandard.ZstdError as exc:
            raise InputError(f"{file}: not a zstd-compressed storage file: {exc}") from None
        return copy

    def _decode(self, connection: object, raw: bytes) -> object:
        """A message, or one line naming the topic when its bytes do not decode (a damaged
        bag; or one read without metadata.yaml, which alone says its messages are compressed)."""
        from rosbags.highlevel import AnyReaderError

        try:
            return self._reader.deserialize(raw, connection.msgtype)
        except AnyReaderError as exc:
            hint = ""
            if self._without_metadata:
                hint = "; read without metadata.yaml, which would say whether its messages are compressed: `ros2 bag reindex` remakes it"
            raise InputError(f"{self.path}: a {connection.topic} message does not decode ({exc}){hint}") from None

    def _first(self, topic: str) -> object | None:
        connections = [c for c in self._reader.connections if c.topic == topic]
        for connection, _, raw in self._reader.messages(connections=connections):
            return self._decode(connection, raw)
        return None

    def _kind(self, connection: object) -> str | None:
        """"color", "depth" or None (no message, or neither encoding); notes its size and depth type."""
        message = self._first(connection.topic)
        if message is None:
            return None
        if connection.msgtype.endswith("CompressedImage"):
            shape = decode_compressed_message(message, f"{self.path} {connection.topic}").shape
            self._sizes[connection.topic] = (shape[1], shape[0])
            form = str(message.format).lower()
            depth = "compresseddepth" in form or "16uc1" in form or "32fc1" in form or "depth" in connection.topic
            if depth:
                self._depth_dtypes[connection.topic] = np.float32 if form.startswith("32fc1") else np.uint16
            return "depth" if depth else "color"
        self._sizes[connection.topic] = (int(message.width), int(message.height))
        encoding = str(message.encoding)
        if is_depth_encoding(encoding):
            self._depth_dtypes[connection.topic] = np.uint16 if encoding.lower() != "32fc1" else np.float32
            return "depth"
        return "color" if is_color_encoding(encoding) else None

    def _info_for(self, image: object) -> object | None:
        """The CameraInfo beside an image topic (`.../color/camera_info` for `.../color/image_raw`);
        else, elsewhere (`/camera/camera_info` for `/camera/rgb/image`), the nearest one of the
        image's size."""
        namespace = _namespace(image)
        infos = [c for c in self._reader.connections if c.msgtype == INFO_TYPE]
        beside = [c for c in infos if c.topic.rsplit("/", 1)[0] == namespace]
        if beside:
            return self._first(beside[0].topic)
        fitting = [
            (_shared_prefix(c.topic.rsplit("/", 1)[0], namespace), info)
            for c in infos
            if (info := self._first(c.topic)) is not None and (int(info.width), int(info.height)) == self._sizes[image.topic]
        ]
        return max(fitting, key=lambda f: f[0])[1] if fitting else None

    def _tf(self, a: str, b: str, topic: str) -> np.ndarray | None:
        """a_from_b from the transforms on `topic` (/tf_static; or /tf, where ROS 1's tf
        static_transform_publisher repeats them), each edge as first given."""
        tree = _TfTree()
        seen: set[tuple[str, str]] = set()
        connections = [c for c in self._reader.connections if c.msgtype == TF_TYPE and c.topic.rstrip("/").endswith(topic)]
        for connection, _, raw in self._reader.messages(connections=connections) if connections else ():
            added = False
            for stamped in self._decode(connection, raw).transforms:
                edge = (stamped.header.frame_id, stamped.child_frame_id)
                if edge not in seen:
                    seen.add(edge)
                    tree.add(*edge, _transform_matrix(stamped.transform))
                    added = True
            if added and (found := tree.a_from_b(a, b)) is not None:
                return found
        return None

    def _messages(self) -> Iterator[tuple[str, int, object, int]]:
        """(kind, index in its stream, (connection, raw), log time ns) in the bag's order; every
        connection of the two topics (a topic recorded from two publishers has two)."""
        counters = {"color": 0, "depth": 0}
        kind_of = {self._color.topic: "color", self._depth.topic: "depth"}
        connections = [c for c in self._reader.connections if c.topic in kind_of]
        for connection, log_ns, raw in self._reader.messages(connections=connections):
            kind = kind_of[connection.topic]
            index = counters[kind]
            counters[kind] += 1
            yield kind, index, (connection, raw), log_ns

    def stream_times(self) -> tuple[np.ndarray, np.ndarray]:
        stamps: dict[str, list[float]] = {"color": [], "depth": []}
        logged: dict[str, list[float]] = {"color": [], "depth": []}
        for kind, _, (connection, raw), log_ns in self._messages():
            stamps[kind].append(_stamp_s(self._decode(connection, raw)))
            logged[kind].append(1e-9 * log_ns)
        # A driver (or writer) that leaves the header's stamp at zero, or at one value throughout.
        unstamped = [kind for kind in stamps if len(stamps[kind]) > 1 and len(set(stamps[kind])) == 1]
        if unstamped:
            self.setup.notes.append(
                f"{' and '.join(unstamped)} images carry no time stamp (all {stamps[unstamped[0]][0]:.3f} s): "
                "paired by the times the bag logged them"
            )
            stamps = logged
        return np.array(stamps["color"]), np.array(stamps["depth"])

    def stream_images(self, chosen: list[tuple[int, int]]) -> Iterator[tuple[str, int, np.ndarray]]:
        wanted = {("color", i) for i, _ in chosen} | {("depth", j) for _, j in chosen}
        for kind, index, (connection, raw), _ in self._messages():
            if (kind, index) not in wanted:
                continue
            message = self._decode(connection, raw)
            where = f"{self.path} {connection.topic}"
            if connection.msgtype.endswith("CompressedImage"):
                image = decode_compressed_message(message, where)
            else:
                image = decode_image_message(message, where)
            yield kind, index, self._undistorted(kind, image)

    def _undistorted(self, kind: str, image: np.ndarray) -> np.ndarray:
        """Colour through its pinhole where its lens is undone, and a depth registered to it
        alike (the nearest depth pixel: none blended across an edge)."""
        import cv2

        if self._color_maps is None or (kind == "depth" and self.setup.depth_camera is not None):
            return image
        if image.shape[:2] != self._color_maps[0].shape:
            return image  # refused by the size check, naming the frame
        # Lanczos keeps small tags' cells sharp: bilinearly, check29b's half-size Azure bottle (tags
        # ~10 px) lost half its tags and 6 of 16 frames' poses, 2.14 mm from the truth; 0.95 now.
        interpolation = cv2.INTER_LANCZOS4 if kind == "color" else cv2.INTER_NEAREST
        return cv2.remap(image, *self._color_maps, interpolation, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
