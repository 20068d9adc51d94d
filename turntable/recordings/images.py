"""Image files and ROS image messages decoded to what a frame source yields: colour as
(H, W, 3) uint8 RGB, depth as (H, W) uint16 units or float32 metres."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from homemodel.core.errors import InputError
from homemodel.core.images import read_image

_COLOR_ENCODINGS = {"rgb8": 3, "bgr8": 3, "rgba8": 4, "bgra8": 4, "mono8": 1, "8uc1": 1, "8uc3": 3}
_DEPTH_ENCODINGS = {"16uc1": np.dtype("<u2"), "mono16": np.dtype("<u2"), "32fc1": np.dtype("<f4")}


def read_rgb(path: Path) -> np.ndarray:
    import cv2

    image = read_image(path)
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)


def read_depth_units(path: Path) -> np.ndarray:
    import cv2

    raw = read_image(path, cv2.IMREAD_UNCHANGED)
    if raw.ndim != 2 or raw.dtype != np.uint16:
        raise InputError(f"{path}: a depth image must be single-channel 16-bit, got {raw.dtype} with shape {raw.shape}")
    return raw


def is_depth_encoding(encoding: str) -> bool:
    return encoding.lower() in _DEPTH_ENCODINGS


def is_color_encoding(encoding: str) -> bool:
    return encoding.lower() in _COLOR_ENCODINGS


def decode_image_message(message: object, where: str) -> np.ndarray:
    """A sensor_msgs/Image's pixels: RGB uint8 for colour encodings, uint16 or float32 for depth."""
    import cv2

    encoding = str(message.encoding).lower()
    height, width, step = int(message.height), int(message.width), int(message.step)
    data = np.asarray(message.data, dtype=np.uint8)
    if len(data) < height * step:
        raise InputError(f"{where}: an image message has {len(data)} bytes, {height} rows of {step} expected")
    rows = data[: height * step].reshape(height, step)
    if encoding in _DEPTH_ENCODINGS:
        dtype = _DEPTH_ENCODINGS[encoding]
        if int(message.is_bigendian):
            dtype = dtype.newbyteorder(">")
        image = rows[:, : width * dtype.itemsize].copy().view(dtype).reshape(height, width)
        return image.astype(dtype.newbyteorder("="))
    if encoding not in _COLOR_ENCODINGS:
        raise InputError(f"{where}: image encoding {message.encoding!r} is neither colour nor depth")
    channels = _COLOR_ENCODINGS[encoding]
    image = rows[:, : width * channels].reshape(height, width, channels)
    conversion = {
        "bgr8": cv2.COLOR_BGR2RGB,
        "rgba8": cv2.COLOR_RGBA2RGB,
        "bgra8": cv2.COLOR_BGRA2RGB,
        "mono8": cv2.COLOR_GRAY2RGB,
        "8uc1": cv2.COLOR_GRAY2RGB,
    }.get(encoding)
    return np.ascontiguousarray(image if conversion is None else cv2.cvtColor(image, conversion))


def decode_compressed_message(message: object, where: str) -> np.ndarray:
    """A sensor_msgs/CompressedImage: JPEG/PNG colour, or compressedDepth (a 12-byte header before a PNG)."""
    import cv2

    data = np.asarray(message.data, dtype=np.uint8)
    form = str(message.format).lower()
    if "compresseddepth" in form:
        data = data[12:]
    image = cv2.imdecode(data, cv2.IMREAD_UNCHANGED)
    if image is None:
        raise InputError(f"{where}: a compressed image ({message.format!r}) does not decode")
    if image.ndim == 2 and image.dtype != np.uint8:
        return image
    if image.ndim == 2:
        return cv2.cvtColor(image, cv2.COLOR_GRAY2RGB)
    code = cv2.COLOR_BGRA2RGB if image.shape[2] == 4 else cv2.COLOR_BGR2RGB
    return cv2.cvtColor(image, code)
