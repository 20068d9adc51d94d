"""Read a user's image file safely: a regular file within a size bound, whose header is
checked against a pixel bound before anything is decoded (a small file can decode into
gigabytes), and every failure one InputError naming the file."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from homemodel.core.errors import InputError
from homemodel.core.input_files import read_bounded
from homemodel.core.limits import IMAGE_PIXELS

MAX_IMAGE_BYTES = 256 * 1024 * 1024


def read_image(path: Path, flags: int | None = None) -> np.ndarray:
    """The image decoded by OpenCV with `flags` (a cv2.IMREAD_* value; by default
    IMREAD_COLOR: 8-bit BGR, turned upright by its EXIF orientation)."""
    import cv2

    path = Path(path)
    data = read_bounded(path, MAX_IMAGE_BYTES)
    _checked_size(path, data)
    try:
        image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR if flags is None else flags)
    except cv2.error:
        image = None
    if image is None or image.size == 0:
        raise InputError(f"{path}: not a readable image: cannot decode it (truncated or corrupt)")
    return image


def read_image_size(path: Path) -> tuple[int, int]:
    """(height, width) of an image file as stored (before any EXIF turn), from its header."""
    path = Path(path)
    return _checked_size(path, read_bounded(path, MAX_IMAGE_BYTES))


def _checked_size(path: Path, data: bytes) -> tuple[int, int]:
    from PIL import Image

    bound = Image.MAX_IMAGE_PIXELS
    try:
        # Only the header is read here, and the bound below is ours (which a user can raise
        # past Pillow's): Pillow's own check is off for this call.
        Image.MAX_IMAGE_PIXELS = None
        with Image.open(io.BytesIO(data)) as header:
            width, height = header.size
    except Exception:  # Pillow's format plugins raise many types on corrupt headers
        raise InputError(f"{path}: not a readable image (not an image file, or its header is corrupt)") from None
    finally:
        Image.MAX_IMAGE_PIXELS = bound
    check_pixel_count(path, width, height)
    return height, width


def check_pixel_count(path: Path, width: int, height: int) -> None:
    """Refuse an image whose header claims more than IMAGE_PIXELS (for readers of other formats)."""
    IMAGE_PIXELS.check(f"{path}: {width}x{height}", width * height)
