"""Number formatting shared by the exporters, fixed so the same model gives the same bytes."""

from __future__ import annotations

from collections.abc import Iterable


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
