"""The sRGB transfer curve (IEC 61966-2-1), in one place: images hold encoded values, light
adds up in linear ones. Both functions keep their input's float type, so float32 renders stay
float32 and the results are the same bits as the curve written out where it is used."""

from __future__ import annotations

import numpy as np


def srgb_decode(encoded: np.ndarray) -> np.ndarray:
    """Encoded values in [0, 1] to linear light."""
    return np.where(encoded <= 0.04045, encoded / 12.92, ((encoded + 0.055) / 1.055) ** 2.4)


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """Linear light in [0, 1] to encoded values."""
    return np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * np.power(linear, 1 / 2.4) - 0.055)
