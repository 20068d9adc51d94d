"""Read a user's input file safely: a regular file, within a size bound."""

from __future__ import annotations

from pathlib import Path

from homemodel.core.errors import InputError

CHUNK_BYTES = 1024 * 1024


def confined_path(folder: Path, name: str | Path, *, folder_role: str = "folder") -> Path:
    """The file `name` names relative to `folder`, resolved (it may not exist). The one rule for
    every path a file names (a home's `spec:`, a spec's `photo:`, a URDF's meshes): relative to
    the naming file's folder and inside it. Raises InputError, for the caller to prefix with the
    file and field, for URIs, absolute paths, and paths that leave the folder through `..` or a
    symlink; `folder_role` names the folder in the message ("model folder")."""
    text = str(name)
    if "://" in text:
        raise InputError(f"{text!r}: URIs are not allowed; use a path relative to the file")
    if Path(text).is_absolute():
        raise InputError(f"{text!r}: absolute paths are not allowed; use a path relative to the file")
    root = Path(folder).resolve()
    target = (root / text).resolve()
    if not target.is_relative_to(root):
        raise InputError(f"{text!r} lies outside the {folder_role} {root}")
    return target


def read_bounded(path: Path, max_bytes: int) -> bytes:
    """The bytes of `path`; refuses folders, FIFOs and devices (which would hang or never
    end) and files over `max_bytes`, whatever `stat` claims."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file")
    if not path.is_file():
        raise InputError(f"{path}: not a regular file")
    chunks, size = [], 0
    try:
        with path.open("rb") as f:
            # In chunks: f.read(max_bytes + 1) allocates the whole bound before reading a byte.
            while chunk := f.read(min(CHUNK_BYTES, max_bytes + 1 - size)):
                chunks.append(chunk)
                size += len(chunk)
                if size > max_bytes:
                    raise InputError(f"{path}: larger than the {max_bytes}-byte bound for this kind of file")
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror}") from None
    return b"".join(chunks)
