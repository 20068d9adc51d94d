"""An image's size read from a PNG's IHDR chunk (`core.images`, without Pillow) agrees with
Pillow's on every kind of PNG Pillow writes, and a header Pillow or libpng refuses is refused
by name, in one line, before anything is decoded."""

from __future__ import annotations

import io
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from homemodel.core.errors import InputError
from homemodel.core.images import read_image, read_image_size


@pytest.mark.parametrize("mode", ["1", "L", "I;16", "P", "LA", "RGB", "RGBA"])
def test_the_header_s_size_is_pillow_s(tmp_path: Path, mode: str) -> None:
    path = tmp_path / f"{mode.replace(';', '')}.png"
    Image.fromarray(np.arange(7 * 5, dtype=np.uint8).reshape(7, 5)).convert(mode).save(path)
    with Image.open(path) as image:
        assert read_image_size(path) == (image.height, image.width) == (7, 5)


@pytest.mark.parametrize("field, value", [("filter", 1), ("crc", 0)])
def test_a_header_pillow_refuses_is_refused_before_decoding(tmp_path: Path, capfd, field: str, value: int) -> None:
    """A filter method libpng does not know (libpng would print its own lines decoding it) or an
    IHDR whose CRC fails: Pillow's one-line refusal, as before the header was read directly."""
    buffer = io.BytesIO()
    Image.fromarray(np.zeros((5, 7, 3), np.uint8)).save(buffer, "PNG")
    data = bytearray(buffer.getvalue())
    if field == "filter":
        data[27] = value  # IHDR's filter method, then its CRC made right again
        data[29:33] = struct.pack(">I", zlib.crc32(bytes(data[12:29])))
    else:
        data[29:33] = struct.pack(">I", value)
    path = tmp_path / "odd.png"
    path.write_bytes(bytes(data))
    for read in (read_image_size, read_image):
        with pytest.raises(InputError, match=r"odd.png: not a readable image \(not an image file, or its header is corrupt\)"):
            read(path)
    assert capfd.readouterr().err == ""


def test_headers_read_on_threads_at_once_leave_pillow_s_bound_as_it_was(tmp_path: Path) -> None:
    """Pillow's pixel bound is turned off while a header is read (the bound checked is ours):
    threads reading a capture's JPEG frames at once must leave it as it was, not off for the
    rest of the process. Thread switches every microsecond make the overlap sure (~0.2 CPU-s)."""
    import sys
    import threading

    path = tmp_path / "frame.jpg"
    Image.fromarray(np.zeros((48, 64, 3), np.uint8)).save(path)
    bound, interval = Image.MAX_IMAGE_PIXELS, sys.getswitchinterval()

    def read_many() -> None:
        for _ in range(300):
            read_image_size(path)

    sys.setswitchinterval(1e-6)
    try:
        threads = [threading.Thread(target=read_many) for _ in range(4)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
    finally:
        sys.setswitchinterval(interval)
        restored, Image.MAX_IMAGE_PIXELS = Image.MAX_IMAGE_PIXELS, bound
    assert restored == bound is not None
