"""Read a user's input file safely: a regular file, within a size bound."""

from __future__ import annotations

from pathlib import Path

from homemodel.core.errors import InputError


def read_bounded(path: Path, max_bytes: int) -> bytes:
    """The bytes of `path`; refuses folders, FIFOs and devices (which would hang or never
    end) and files over `max_bytes`, whatever `stat` claims."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file")
    if not path.is_file():
        raise InputError(f"{path}: not a regular file")
    try:
        with path.open("rb") as f:
            data = f.read(max_bytes + 1)
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror}") from None
    if len(data) > max_bytes:
        raise InputError(f"{path}: larger than the {max_bytes}-byte bound for this kind of file")
    return data
