"""Atomic writes: a crash never leaves a half-written file or folder behind."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path

from homemodel.core.errors import InputError, OutputExistsError


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_bytes_atomic(path: Path, data: bytes) -> None:
    """Write `data` to a temporary file in the same folder, then rename it over `path`."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        # mkstemp makes 0600 files; outputs are read by other users' tools (ROS, viewers).
        os.fchmod(fd, 0o666 & ~_umask())
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def write_text_atomic(path: Path, text: str) -> None:
    write_bytes_atomic(path, text.encode("utf-8"))


def write_json(path: Path, data: object) -> None:
    """The one way homemodel writes JSON (summaries, poses, cameras, results): atomic, keys in
    the order given (the order a reader meets the figures in), indented by 2, a final newline."""
    write_text_atomic(path, json.dumps(data, indent=2) + "\n")


def prepare_out_dir(out_dir: Path, *, force: bool, inputs: Sequence[Path] = ()) -> None:
    """Refuse a non-empty output folder unless `force`, and any output folder that is,
    holds or lies inside an input (replacing it would delete the input)."""
    out_dir = Path(out_dir)
    resolved = out_dir.resolve()
    for source in inputs:
        source = Path(source).resolve()
        if source.is_relative_to(resolved) or resolved.is_relative_to(source):
            raise OutputExistsError(f"{out_dir}: the output folder must lie outside the input {source}")
    if out_dir.exists() and not out_dir.is_dir():
        raise OutputExistsError(f"{out_dir}: exists and is not a folder")
    if out_dir.is_dir() and any(out_dir.iterdir()) and not force:
        raise OutputExistsError(f"{out_dir}: folder is not empty (use --force to replace its contents)")


@contextlib.contextmanager
def atomic_dir(out_dir: Path, *, force: bool = False, inputs: Sequence[Path] = ()) -> Iterator[Path]:
    """Yield a temporary sibling folder; on success it replaces `out_dir` in one rename.

    On an exception the temporary folder is removed and `out_dir` is left as it was.
    """
    out_dir = Path(out_dir)
    prepare_out_dir(out_dir, force=force, inputs=inputs)
    try:
        out_dir.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(dir=out_dir.parent, prefix=f".{out_dir.name}.", suffix=".tmp"))
        os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp makes 0700 folders
    except OSError as exc:
        raise InputError(f"{out_dir}: cannot create the output folder: {exc.strerror}") from None
    try:
        yield tmp
        if out_dir.exists():
            old = Path(tempfile.mkdtemp(dir=out_dir.parent, prefix=f".{out_dir.name}.", suffix=".old"))
            os.replace(out_dir, old / "previous")
            try:
                os.replace(tmp, out_dir)
            except BaseException:
                os.replace(old / "previous", out_dir)  # put the previous output back
                os.rmdir(old)
                raise
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, out_dir)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
