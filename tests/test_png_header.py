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
