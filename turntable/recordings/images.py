"""Image files and ROS image messages decoded to what a frame source yields: colour as
(H, W, 3) uint8 RGB, depth as (H, W) uint16 units or float32 metres."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from homemodel.core.errors import InputError
from homemodel.core.images import checked_image_size, read_image

# sensor_msgs/image_encodings' colour encodings: bytes stored a pixel, and the name of OpenCV's
# conversion to RGB (None: stored as RGB). ROS's "yuv422" is UYVY; "yuv422_yuy2" YUYV (Iron
# names them "uyvy" and "yuyv"); OpenCV names a Bayer pattern by its second row, ROS by its first.
_COLOR_ENCODINGS: dict[str, tuple[int, str | None]] = {
    "rgb8": (3, None),
    "8uc3": (3, None),
    "bgr8": (3, "COLOR_BGR2RGB"),
    "rgba8": (4, "COLOR_RGBA2RGB"),
    "bgra8": (4, "COLOR_BGRA2RGB"),
    "8uc4": (4, "COLOR_BGRA2RGB"),
    "mono8": (1, "COLOR_GRAY2RGB"),
    "8uc1": (1, "COLOR_GRAY2RGB"),
    "yuv422": (2, "COLOR_YUV2RGB_UYVY"),
    "uyvy": (2, "COLOR_YUV2RGB_UYVY"),
    "yuv422_yuy2": (2, "COLOR_YUV2RGB_YUYV"),
    "yuyv": (2, "COLOR_YUV2RGB_YUYV"),
    "bayer_rggb8": (1, "COLOR_BayerBG2RGB"),
    "bayer_bggr8": (1, "COLOR_BayerRG2RGB"),
    "bayer_gbrg8": (1, "COLOR_BayerGR2RGB"),
    "bayer_grbg8": (1, "COLOR_BayerGB2RGB"),
}
_DEPTH_ENCODINGS = {"16uc1": np.dtype("<u2"), "mono16": np.dtype("<u2"), "32fc1": np.dtype("<f4")}
# compressed_depth_image_transport's ConfigHeader: the format, then two quantisation parameters.
_COMPRESSED_DEPTH_HEADER = np.dtype([("format", "<i4"), ("quant_a", "<f4"), ("quant_b", "<f4")])


def read_rgb(path: Path) -> np.ndarray:
    import cv2

    image = read_image(path)
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)


def read_rgb_of_size(path: Path, size: tuple[int, int], said_by: str) -> np.ndarray:
    """A folder's colour image, refused naming it and `said_by` (the file its (width, height)
    camera came from) when it has another size: read first, before its depth is checked
    against it."""
    rgb = read_rgb(path)
    if (rgb.shape[1], rgb.shape[0]) != size:
        raise InputError(f"{path}: the colour image is {rgb.shape[1]}x{rgb.shape[0]} but {said_by} says {size[0]}x{size[1]}")
    return rgb


def read_depth_units(path: Path, color_size: tuple[int, int]) -> np.ndarray:
    """A folder's depth PNG, registered to its (width, height) colour: refused naming the file
    when it is not, as the importer's own check of the whole frame would name only the folder."""
    import cv2

    raw = read_image(path, cv2.IMREAD_UNCHANGED)
    if raw.ndim != 2 or raw.dtype != np.uint16:
        raise InputError(f"{path}: a depth image must be single-channel 16-bit, got {raw.dtype} with shape {raw.shape}")
    if (raw.shape[1], raw.shape[0]) != color_size:
        raise InputError(
            f"{path}: depth {raw.shape[1]}x{raw.shape[0]} is said to be registered to the "
            f"{color_size[0]}x{color_size[1]} colour but has another size"
        )
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
    if encoding in _DEPTH_ENCODINGS:
        pixel_bytes = _DEPTH_ENCODINGS[encoding].itemsize
    elif encoding in _COLOR_ENCODINGS:
        pixel_bytes = _COLOR_ENCODINGS[encoding][0]
    else:
        raise InputError(f"{where}: image encoding {message.encoding!r} is neither colour nor depth")
    if step < width * pixel_bytes and len(data) == height * width * pixel_bytes:
        step = width * pixel_bytes  # a writer that left step unset (0): rows unpadded
    if height <= 0 or step < width * pixel_bytes or len(data) < height * step:
        raise InputError(f"{where}: an image message has {len(data)} bytes, {height} rows of {step} expected")
    rows = data[: height * step].reshape(height, step)
    if encoding in _DEPTH_ENCODINGS:
        dtype = _DEPTH_ENCODINGS[encoding]
        if int(message.is_bigendian):
            dtype = dtype.newbyteorder(">")
        image = rows[:, : width * dtype.itemsize].copy().view(dtype).reshape(height, width)
        return image.astype(dtype.newbyteorder("="))
    channels, conversion = _COLOR_ENCODINGS[encoding]
    if channels == 2 and width % 2:  # YUV 4:2:2: a U and V to each pair of pixels
        raise InputError(f"{where}: a {message.encoding} image {width} pixels wide (4:2:2 pairs pixels)")
    image = np.ascontiguousarray(rows[:, : width * channels]).reshape(height, width, channels)
    return image if conversion is None else cv2.cvtColor(image, getattr(cv2, conversion))


def _compressed_depth(data: np.ndarray, form: str, where: str) -> np.ndarray:
    """compressed_depth_image_transport's payload: a 12-byte header (format, two quantisation
    parameters), then a 16-bit PNG (or, from ROS 2 Humble on, RVL: width, height, the codes).
    16UC1 comes back as stored; 32FC1 was quantised as inverse depth, q = A / z + B (0: none)."""
    import cv2

    if len(data) < _COMPRESSED_DEPTH_HEADER.itemsize + 8:
        raise InputError(f"{where}: a compressedDepth image of {len(data)} bytes has no room for its header")
    header = data[: _COMPRESSED_DEPTH_HEADER.itemsize].view(_COMPRESSED_DEPTH_HEADER)[0]
    quant_a, quant_b = float(header["quant_a"]), float(header["quant_b"])
    payload = data[_COMPRESSED_DEPTH_HEADER.itemsize :]
    if "rvl" in form:
        from turntable.recordings.rvl import decode_rvl

        width, height = (int(v) for v in payload[:8].view("<u4"))
        image = decode_rvl(payload[8:], width, height, where)
    else:
        checked_image_size(where, payload.tobytes())  # before decoding: a small PNG can claim gigabytes
        image = cv2.imdecode(payload, cv2.IMREAD_UNCHANGED)
        if image is None or image.ndim != 2 or image.dtype != np.uint16:
            raise InputError(f"{where}: a compressedDepth image ({form!r}) is not a 16-bit PNG after its header")
    if not form.startswith("32fc1"):
        return image
    with np.errstate(divide="ignore"):
        depth = (quant_a / (image.astype(np.float32) - np.float32(quant_b))).astype(np.float32)
    depth[image == 0] = np.nan
    return depth


def decode_compressed_message(message: object, where: str) -> np.ndarray:
    """A sensor_msgs/CompressedImage: JPEG/PNG colour (RGB), a 16-bit PNG depth, or
    compressedDepth (uint16 units, or float32 metres for 32FC1)."""
    import cv2

    data = np.asarray(message.data, dtype=np.uint8)
    form = str(message.format).lower()
    if "compresseddepth" in form:
        return _compressed_depth(data, form, where)
    checked_image_size(where, data.tobytes())  # before decoding: a small PNG or JPEG can claim gigabytes
    image = cv2.imdecode(data, cv2.IMREAD_UNCHANGED)
    if image is None:
        raise InputError(f"{where}: a compressed image ({message.format!r}) does not decode")
    if image.ndim == 2 and image.dtype != np.uint8:
        return image
    if image.ndim == 2:
        return cv2.cvtColor(image, cv2.COLOR_GRAY2RGB)
    code = cv2.COLOR_BGRA2RGB if image.shape[2] == 4 else cv2.COLOR_BGR2RGB
    return cv2.cvtColor(image, code)
