"""Number formatting shared by the exporters, fixed so the same model gives the same bytes."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from homemodel.transforms import transform_from_xyz_rpy, xyz_rpy_from_transform


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


def rounded(value: float, decimals: int = 6) -> float:
    """The float a reader of `fixed(value)` gets back, so every export format agrees."""
    return float(fixed(value, decimals))


def canonical_xyz_rpy(a_from_b: np.ndarray) -> tuple[list[float], list[float]]:
    """Translation and roll-pitch-yaw of a transform at the precision the URDF stores."""
    xyz, rpy = xyz_rpy_from_transform(a_from_b)
    return [rounded(v) for v in xyz], [rounded(v) for v in rpy]


def canonical_transform(a_from_b: np.ndarray) -> np.ndarray:
    """The transform a reader of the URDF's xyz/rpy gets back."""
    return transform_from_xyz_rpy(*canonical_xyz_rpy(a_from_b))
