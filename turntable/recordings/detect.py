"""Which kind of recording a path is, from its layout alone."""

from __future__ import annotations

from pathlib import Path
from typing import Literal, get_args

from homemodel.core.errors import InputError
from turntable.recordings.open3d_folder import COLOR_FOLDERS, intrinsics_file, is_config
from turntable.recordings.rosbag import is_storage_file, storage_files, unreadable_bag
from turntable.recordings.tum import LISTS, associations_file

RecordingFormat = Literal["realsense-bag", "ros1", "ros2", "tum", "open3d"]
FORMATS: tuple[str, ...] = get_args(RecordingFormat)


def _is_realsense_bag(path: Path) -> bool:
    """librealsense writes its streams under /device_0/... in a ROS 1 bag."""
    from rosbags.rosbag1 import Reader, ReaderError

    try:
        with Reader(path) as reader:
            return any(c.topic.startswith("/device_0/") for c in reader.connections)
    except (ReaderError, OSError, ValueError, KeyError) as exc:
        raise InputError(f"{path}: not a readable .bag: {unreadable_bag(exc)}") from None


def detect_format(path: Path) -> str:
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such recording")
    if path.is_file():
        if path.stat().st_size == 0:  # a recorder that never wrote (the readers' own words name the file twice)
            raise InputError(f"{path}: an empty file (0 bytes): nothing was recorded into it")
        if is_config(path):
            return "open3d"
        if path.name.endswith(".bag.active"):  # rosbag record's name for the file it writes
            raise InputError(
                f"{path}: a ROS 1 bag whose recording was never closed: `rosbag reindex` it and rename it to .bag"
            )
        if path.suffix == ".bag":
            return "realsense-bag" if _is_realsense_bag(path) else "ros1"
        if is_storage_file(path) or path.name == "metadata.yaml":
            return "ros2"
        raise InputError(
            f"{path}: cannot tell the recording's format (a .bag, .db3, .mcap or Open3D config .json file?); give --format"
        )
    if (path / "metadata.yaml").is_file():
        return "ros2"
    if any((path / name).is_file() for name in LISTS) or associations_file(path) is not None:
        return "tum"
    if (path / "depth").is_dir() and (any((path / n).is_dir() for n in COLOR_FOLDERS) or intrinsics_file(path)):
        return "open3d"
    if storage_files(path):  # a ROS 2 bag folder without its metadata.yaml
        return "ros2"
    raise InputError(
        f"{path}: cannot tell the recording's format (no metadata.yaml, rgb.txt/depth.txt or associations.txt, "
        "or depth/ beside color/); give --format"
    )
