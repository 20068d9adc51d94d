"""Read a user's image file safely: a regular file within a size bound, whose header is
checked against a pixel bound before anything is decoded (a small file can decode into
gigabytes), and every failure one InputError naming the file."""

from __future__ import annotations

import io
import struct
import threading
import zlib
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from homemodel.core.errors import InputError
from homemodel.core.input_files import read_bounded
from homemodel.core.limits import IMAGE_PIXELS

MAX_IMAGE_BYTES = 256 * 1024 * 1024
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_PNG_BIT_DEPTHS = {0: (1, 2, 4, 8, 16), 2: (8, 16), 3: (1, 2, 4, 8), 4: (8, 16), 6: (8, 16)}  # by colour type
# OpenCV's codecs log what they find wrong with a file to stderr, a line per image, and
# libpng prints its own errors from C ("libpng error: PNG input buffer is incomplete"), which
# no log level stops: PNG chunks are checked here first, the rest of the log is turned off
# while decoding, and the InputError says it once.
_QUIET_LOCK = threading.Lock()
_quiet_users = 0
_loud_level: int | None = None
# Pillow's pixel bound is process-wide: threads reading headers at once (a capture's JPEG frames)
# would each save another's None as the bound to restore, leaving Pillow's check off for good.
_PILLOW_BOUND_LOCK = threading.Lock()


def read_image(path: Path, flags: int | None = None) -> np.ndarray:
    """The image decoded by OpenCV with `flags` (a cv2.IMREAD_* value; by default
    IMREAD_COLOR: 8-bit BGR, turned upright by its EXIF orientation)."""
    import cv2

    path = Path(path)
    data = read_bounded(path, MAX_IMAGE_BYTES)
    checked_image_size(path, data)
    if data.startswith(PNG_SIGNATURE) and (problem := _png_problem(data)):
        raise InputError(f"{path}: not a readable image: {problem}")
    try:
        with _opencv_silenced(cv2):
            image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR if flags is None else flags)
    except cv2.error:
        image = None
    if image is None or image.size == 0:
        raise InputError(f"{path}: not a readable image: cannot decode it (truncated or corrupt)")
    return image


def _png_problem(data: bytes) -> str | None:
    """What is wrong with a PNG's chunk stream (a cut, a chunk whose CRC fails, no IEND), or None."""
    offset = len(PNG_SIGNATURE)
    while offset + 12 <= len(data):
        length, kind = struct.unpack_from(">I4s", data, offset)
        end = offset + 12 + length
        if end > len(data):
            break
        critical = not kind[0] & 0x20  # libpng only warns about an ancillary chunk's CRC
        if critical and zlib.crc32(data[offset + 4 : end - 4]) != struct.unpack_from(">I", data, end - 4)[0]:
            return f"the {kind.decode('latin-1')!r} chunk at byte {offset} fails its CRC (corrupt)"
        if kind == b"IEND":
            return None
        offset = end
    return f"truncated: it ends at byte {len(data)} before its IEND chunk"


@contextmanager
def _opencv_silenced(cv2) -> Iterator[None]:
    """OpenCV's log off while any thread decodes, back to its level when the last one ends
    (the level is process-wide, so threads share one count)."""
    global _quiet_users, _loud_level
    with _QUIET_LOCK:
        if _quiet_users == 0:
            _loud_level = cv2.setLogLevel(0)  # 0 is LOG_LEVEL_SILENT; it returns the old level
        _quiet_users += 1
    try:
        yield
    finally:
        with _QUIET_LOCK:
            _quiet_users -= 1
            if _quiet_users == 0:
                cv2.setLogLevel(_loud_level)


def read_image_size(path: Path) -> tuple[int, int]:
    """(height, width) of an image file as stored (before any EXIF turn), from its header."""
    path = Path(path)
    return checked_image_size(path, read_bounded(path, MAX_IMAGE_BYTES))


def checked_image_size(source: Path | str, data: bytes) -> tuple[int, int]:
    """(height, width) from an encoded image's header, refused (naming `source`: a file, or
    where in a recording the bytes came from) when it claims more than IMAGE_PIXELS."""
    size = _png_size(data)
    if size is None:
        size = _pillow_size(source, data)
    height, width = size
    check_pixel_count(source, width, height)
    return height, width


def _png_size(data: bytes) -> tuple[int, int] | None:
    """(height, width) from a PNG's IHDR chunk when it leads the file whole, CRC and all (a
    tenth of Pillow's time, which reading a capture's frames felt); None for anything else."""
    ihdr = len(PNG_SIGNATURE)
    if not data.startswith(PNG_SIGNATURE) or len(data) < ihdr + 25:
        return None
    length, kind, width, height, bits, colour_type, compression, filtering, interlace, crc = struct.unpack_from(
        ">I4sIIBBBBBI", data, ihdr
    )
    if length != 13 or kind != b"IHDR" or zlib.crc32(data[ihdr + 4 : ihdr + 21]) != crc:
        return None
    if not width or not height or bits not in _PNG_BIT_DEPTHS.get(colour_type, ()):
        return None  # Pillow's judgement, and its message
    if compression or filtering or interlace > 1:  # methods libpng does not know: Pillow judges them
        return None
    return height, width


def _pillow_size(source: Path | str, data: bytes) -> tuple[int, int]:
    from PIL import Image

    with _PILLOW_BOUND_LOCK:
        bound = Image.MAX_IMAGE_PIXELS
        try:
            # Only the header is read here, and the bound below is ours (which a user can raise
            # past Pillow's): Pillow's own check is off for this call.
            Image.MAX_IMAGE_PIXELS = None
            with Image.open(io.BytesIO(data)) as header:
                width, height = header.size
        except Exception:  # Pillow's format plugins raise many types on corrupt headers
            raise InputError(f"{source}: not a readable image (not an image file, or its header is corrupt)") from None
        finally:
            Image.MAX_IMAGE_PIXELS = bound
    return height, width


def check_pixel_count(path: Path | str, width: int, height: int) -> None:
    """Refuse an image whose header claims more than IMAGE_PIXELS (for readers of other formats)."""
    IMAGE_PIXELS.check(f"{path}: {width}x{height}", width * height)
