"""Number formatting shared by the exporters, fixed so the same model gives the same bytes."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from homemodel.core.transforms import transform_from_xyz_rpy, xyz_rpy_from_transform


def fixed(value: float, decimals: int = 6) -> str:
    """Metres and radians to `decimals` places (1 µm, 1 µrad), trailing zeros dropped, never "-0"."""
    text = f"{float(value):.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def significant(value: float, digits: int = 6) -> str:
    """Masses and inertias, which span many orders of magnitude, to `digits` significant digits."""
    text = f"{float(value):.{digits}g}"
    return "0" if text == "-0" else text


def fixed_list(values: Iterable[float], decimals: int = 6) -> str:
    return " ".join(fixed(v, decimals) for v in values)


_PI_ROUNDED = 3.141593


def rounded(value: float, decimals: int = 6) -> float:
    """The float a reader of `fixed(value)` gets back, so every export format agrees."""
    return float(fixed(value, decimals))


def canonical_xyz_rpy(a_from_b: np.ndarray) -> tuple[list[float], list[float]]:
    """Translation and roll-pitch-yaw of a transform at the precision the URDF stores."""
    xyz, rpy = xyz_rpy_from_transform(a_from_b)
    # Rounded, pi becomes 3.141593 > pi, which reads back as -3.141592: write every angle
    # within a rounding step of +-pi as +pi, so a re-export gives the same text.
    angles = [rounded(v) for v in rpy]
    angles = [_PI_ROUNDED if abs(v) >= _PI_ROUNDED - 1e-6 else v for v in angles]
    return [rounded(v) for v in xyz], angles


def canonical_transform(a_from_b: np.ndarray) -> np.ndarray:
    """The transform a reader of the URDF's xyz/rpy gets back."""
    return transform_from_xyz_rpy(*canonical_xyz_rpy(a_from_b))
