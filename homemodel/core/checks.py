"""What the options classes' `check()` methods share: an InputError naming the field.

Every options class of a pipeline has `check()`, called by the pipeline's entry function
before any work; nested options are checked with their field's name in front
(`sfm.max_num_features: ...`).
"""

from __future__ import annotations

import math
from collections.abc import Collection
from typing import Protocol

from homemodel.core.errors import InputError


class Checked(Protocol):
    def check(self) -> None: ...


def _number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def require_positive(field: str, value: float) -> None:
    if not (_number(value) and value > 0):
        raise InputError(f"{field}: must be positive, got {value!r}")


def require_at_least(field: str, value: float, low: float) -> None:
    if not (_number(value) and value >= low):
        raise InputError(f"{field}: must be at least {low}, got {value!r}")


def require_between(field: str, value: float, low: float, high: float) -> None:
    """`low <= value <= high`."""
    if not (_number(value) and low <= value <= high):
        raise InputError(f"{field}: must lie in [{low}, {high}], got {value!r}")


def require_choice(field: str, value: object, choices: Collection[object]) -> None:
    if value not in choices:
        raise InputError(f"{field}: {value!r} is not one of {', '.join(map(str, choices))}")


def check_nested(field: str, options: Checked) -> None:
    """`options.check()`, its message prefixed with `field.`."""
    try:
        options.check()
    except InputError as exc:
        raise InputError(f"{field}.{exc}") from None
