"""RVL (Wilson, "Fast lossless depth image compression", 2017), as ROS 2's
compressed_depth_image_transport writes it: little-endian 32-bit words of 4-bit codes read
from the high end; a value is 3 bits a code, low bits first, while a code's top bit says more
follow. The values alternate: a run of zero pixels, a run of non-zero pixels, then that many
zigzag-coded differences from the previous non-zero pixel.

A hostile stream is refused, not followed: a value longer than any run of the image's pixels
(a 22-code one overflowed into a negative run, and the runs then looped for ever, memory
growing), and bytes past what an image of its size can hold are not read."""

from __future__ import annotations

import numpy as np

from homemodel.core.errors import InputError

_MAX_PIXELS = 1 << 23  # 8.4 Mpx: above any depth camera's (5 Mpx)
# A value's codes at most: a run of up to _MAX_PIXELS pixels (24 bits); a step's zigzag needs 17.
_MAX_VALUE_CODES = -(-_MAX_PIXELS.bit_length() // 3)
# An image's codes: a pixel's step takes 6 at most and a run of n pixels n at most, so fewer
# than 7 a pixel: under 4 bytes a pixel with the words' padding. The codes' arrays cost about
# 50 bytes a byte read, so no more is read.
_BYTES_PER_PIXEL = 4
_BLOCK_WORDS = 1 << 16  # words whose codes are expanded at once (about 20 MB of arrays)


def _too_long(where: str) -> InputError:
    return InputError(f"{where}: an RVL depth image holds a value longer than any run of its pixels")


def _block_values(codes: np.ndarray, ends: np.ndarray, where: str) -> np.ndarray:
    """The values of `codes`, whose values' last codes are at `ends` (the last code's among them)."""
    first = np.concatenate([[0], ends[:-1] + 1])
    lengths = ends - first + 1
    if lengths.max() > _MAX_VALUE_CODES:
        raise _too_long(where)
    value_of = np.repeat(np.arange(len(ends)), lengths)  # which value each code builds
    place = np.arange(len(codes)) - first[value_of]
    return np.bincount(value_of, weights=(codes & 0x7) << (3 * place), minlength=len(ends)).astype(np.int64)


def _values(words: np.ndarray, where: str) -> np.ndarray:
    """Every complete variable-length value of the stream, in order, a block of words at a time."""
    shifts = np.arange(28, -1, -4, dtype=np.uint32)
    blocks, carried = [], np.zeros(0, np.int64)
    for start in range(0, len(words), _BLOCK_WORDS):
        codes = ((words[start : start + _BLOCK_WORDS, None] >> shifts) & 0xF).ravel().astype(np.int64)
        codes = np.concatenate([carried, codes])  # with a value begun in the block before
        ends = np.flatnonzero((codes & 0x8) == 0)  # a value's last code
        done = int(ends[-1]) + 1 if len(ends) else 0
        if len(codes) - done > _MAX_VALUE_CODES:
            raise _too_long(where)
        if len(ends):
            blocks.append(_block_values(codes[:done], ends, where))
        carried = codes[done:]
    return np.concatenate(blocks) if blocks else np.zeros(0, np.int64)


def decode_rvl(data: np.ndarray, width: int, height: int, where: str) -> np.ndarray:
    """(height, width) uint16 from RVL `data`; raises InputError when it ends early, overruns
    or holds what no encoder writes."""
    pixels = width * height
    if width <= 0 or height <= 0 or pixels > _MAX_PIXELS:
        raise InputError(f"{where}: an RVL depth image of {width}x{height} pixels")
    usable = min(len(data), _BYTES_PER_PIXEL * pixels + 16) // 4 * 4
    values = _values(np.frombuffer(np.asarray(data, np.uint8)[:usable].tobytes(), "<u4"), where)
    # Each run of non-zero pixels: its first pixel, its length, and where its steps start in `values`.
    runs = np.zeros((len(values) // 2 + 1, 3), np.int64)
    at = k = n = 0
    while at < pixels:
        if k + 2 > len(values):
            raise InputError(f"{where}: an RVL depth image ends after {at} of {pixels} pixels")
        zeros, nonzeros = int(values[k]), int(values[k + 1])
        start = at + zeros
        if start + nonzeros > pixels or k + 2 + nonzeros > len(values):
            raise InputError(f"{where}: an RVL depth image's runs do not fit its {width}x{height} pixels")
        runs[n] = start, nonzeros, k + 2
        at, k, n = start + nonzeros, k + 2 + nonzeros, n + 1
    starts, counts, steps = runs[:n].T
    within = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)  # place in its run
    zigzag = values[np.repeat(steps, counts) + within]
    depth = np.cumsum((zigzag >> 1) ^ -(zigzag & 1))
    if depth.min(initial=0) < 0 or depth.max(initial=0) > 65535:
        raise InputError(f"{where}: an RVL depth image decodes outside 16 bits")
    out = np.zeros(pixels, np.uint16)
    out[np.repeat(starts, counts) + within] = depth
    return out.reshape(height, width)
