"""File-safe names for exported meshes and textures."""

from __future__ import annotations

import re

from homemodel.core.errors import InputError

_UNSAFE = re.compile(r"[^A-Za-z0-9_.-]+")


def file_stem(name: str) -> str:
    """A name that is safe as a file stem on every platform (no separators, no dots first)."""
    stem = _UNSAFE.sub("_", name).strip("._")
    return stem or "unnamed"


def unique(stem: str, taken: set[str]) -> str:
    """`stem`, or `stem_2`, `stem_3`, ... whichever is not yet in `taken`; records the choice."""
    candidate, n = stem, 2
    while candidate.lower() in taken:
        candidate, n = f"{stem}_{n}", n + 1
    taken.add(candidate.lower())
    return candidate


def check_model_name(name: str, field: str = "name") -> None:
    """Refuse a model name that is not already a safe file stem (the exporters name files after it)."""
    if file_stem(name) != name:
        raise InputError(f"{field}: {name!r}: use letters, digits and underscores")
