"""RVL (Wilson, "Fast lossless depth image compression", 2017), as ROS 2's
compressed_depth_image_transport writes it: little-endian 32-bit words of 4-bit codes read
from the high end; a value is 3 bits a code, low bits first, while a code's top bit says more
follow. The values alternate: a run of zero pixels, a run of non-zero pixels, then that many
zigzag-coded differences from the previous non-zero pixel."""

from __future__ import annotations

import numpy as np

from homemodel.core.errors import InputError


def _values(words: np.ndarray) -> np.ndarray:
    """Every variable-length value of the stream, in order."""
    shifts = np.arange(28, -1, -4, dtype=np.uint32)
    codes = ((words[:, None] >> shifts) & 0xF).ravel().astype(np.int64)
    last = (codes & 0x8) == 0  # a value's final code
    ends = np.flatnonzero(last)
    if len(ends) == 0:
        return np.zeros(0, np.int64)
    codes = codes[: ends[-1] + 1]
    value_of = np.concatenate([[0], np.cumsum(last[: ends[-1]])])  # which value each code builds
    first = np.concatenate([[0], ends[:-1] + 1])
    place = np.arange(len(codes)) - first[value_of]
    return np.bincount(value_of, weights=(codes & 0x7) << (3 * place), minlength=len(ends)).astype(np.int64)


def decode_rvl(data: np.ndarray, width: int, height: int, where: str) -> np.ndarray:
    """(height, width) uint16 from RVL `data`; raises InputError when it ends early or overruns."""
    pixels = width * height
    if width <= 0 or height <= 0 or pixels > 1 << 26:
        raise InputError(f"{where}: an RVL depth image of {width}x{height} pixels")
    usable = len(data) // 4 * 4
    values = _values(np.frombuffer(np.asarray(data, np.uint8)[:usable].tobytes(), "<u4"))
    out = np.zeros(pixels, np.int64)
    deltas = []
    at = k = 0
    while at < pixels:
        if k + 2 > len(values):
            raise InputError(f"{where}: an RVL depth image ends after {at} of {pixels} pixels")
        zeros, nonzeros = int(values[k]), int(values[k + 1])
        start = at + zeros
        if start + nonzeros > pixels or k + 2 + nonzeros > len(values):
            raise InputError(f"{where}: an RVL depth image's runs do not fit its {width}x{height} pixels")
        deltas.append((start, values[k + 2 : k + 2 + nonzeros]))
        at, k = start + nonzeros, k + 2 + nonzeros
    if deltas:
        positions = np.concatenate([np.arange(s, s + len(d)) for s, d in deltas])
        zigzag = np.concatenate([d for _, d in deltas])
        out[positions] = np.cumsum((zigzag >> 1) ^ -(zigzag & 1))
    if out.min(initial=0) < 0 or out.max(initial=0) > 65535:
        raise InputError(f"{where}: an RVL depth image decodes outside 16 bits")
    return out.astype(np.uint16).reshape(height, width)
