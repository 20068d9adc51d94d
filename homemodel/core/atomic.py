"""Atomic writes: a crash never leaves a half-written file or folder behind.

What "atomic" guarantees: an output file or folder appears whole, in one rename, or not at
all; an output folder is only put where there was none or an empty one, in that same rename
(two runs racing for one `--out` cannot both win); with `force` the old and new folders swap
in one step where the kernel offers it (renameat2 RENAME_EXCHANGE). Temporaries are hidden
siblings named after their process (`.NAME.PID.XXXX.tmp`); one left by a killed process
(kill -9, a power cut) is removed by the next run that writes beside it.

A file written inside an `atomic_dir` is flushed to disk by a thread while the writer goes on,
and the folder's rename waits for every such flush: the rename is what must not reach the disk
before the files (a crash could otherwise publish a folder of empty files), so each file's
own rename need not wait for its flush.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import json
import os
import re
import shutil
import tempfile
import threading
from collections.abc import Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from contextvars import ContextVar
from pathlib import Path

from homemodel.core.errors import WRITE_ERRNOS, InputError, OutputError, OutputExistsError
from homemodel.core.interrupts import interrupts_deferred, raise_if_interrupted

RENAME_EXCHANGE = 2  # linux/fs.h
_TEMPORARY = re.compile(r"\.(?P<name>.+)\.(?P<pid>\d+)\.[^.]+\.(tmp|old)")


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # another user's process
    return True


def remove_stale_temporaries(folder: Path, name: str) -> None:
    """Remove `folder`'s temporaries for `name` whose process is gone (killed mid-write). One
    whose process id is alive is kept, even if that id was reused: removal must never race
    a running writer."""
    with contextlib.suppress(OSError):
        for entry in os.scandir(folder):
            match = _TEMPORARY.fullmatch(entry.name)
            if match and match["name"] == name and not _alive(int(match["pid"])):
                if entry.is_dir(follow_symlinks=False):
                    shutil.rmtree(entry.path, ignore_errors=True)
                else:
                    with contextlib.suppress(OSError):
                        os.unlink(entry.path)


class _FolderFlush:
    """The flushes of the files written into one `atomic_dir`'s temporary folder, run by a
    thread beside the writer (37 files of a completed cup's folder: their fsyncs took 0.08-0.2 s
    of wall in turn, time the gate's CPU work now covers)."""

    # At most this many files wait for their flush, each holding an open descriptor.
    PENDING = 64

    def __init__(self, folder: Path, outer: _FolderFlush | None) -> None:
        self.folder = os.path.abspath(folder)
        self.outer = outer
        self._pool: ThreadPoolExecutor | None = None
        self._flushes: list[Future[None]] = []
        self._slots = threading.BoundedSemaphore(self.PENDING)
        self._adding = threading.Lock()  # a writer's threads that share its context may add at once
        self._owner = os.getpid()  # a forked child has no flush thread: it flushes its own files

    def holding(self, path: Path) -> _FolderFlush | None:
        """The innermost atomic folder that `path` is written into, or None."""
        if os.getpid() != self._owner:
            return None
        where = os.path.abspath(path)
        if os.path.commonpath([where, self.folder]) == self.folder:
            return self
        return self.outer.holding(path) if self.outer is not None else None

    def add(self, fd: int) -> None:
        """Flush the open file `fd` (a descriptor of its own: closed once flushed)."""
        try:
            self._slots.acquire()
        except BaseException:  # Ctrl-C while waiting for a slot
            os.close(fd)
            raise
        # Ctrl-C is held over the hand-over: one landing inside `submit` after it queued the
        # flush closed `fd` here and again in the flush thread (EBADF in CI).
        with interrupts_deferred():
            try:
                with self._adding:
                    if self._pool is None:
                        self._pool = ThreadPoolExecutor(1, thread_name_prefix="homemodel-fsync")
                    self._flushes.append(self._pool.submit(self._flush, fd))
            except BaseException:  # a pool already shut (a writer outliving its folder): no leaked fd or slot
                os.close(fd)
                self._slots.release()
                raise

    def _flush(self, fd: int) -> None:
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
            self._slots.release()

    def wait(self, *, report: bool = True) -> None:
        """Wait for every flush; with `report`, raise the first one's error."""
        with self._adding:
            pool = self._pool
        if pool is not None:
            pool.shutdown(wait=True)
        for flush in self._flushes if report else ():
            flush.result()


_OPEN_FOLDER: ContextVar[_FolderFlush | None] = ContextVar("homemodel_atomic_folder", default=None)


def _prefix(path: Path) -> str:
    return f".{path.name}.{os.getpid()}."


def write_bytes_atomic(path: Path, data: bytes, *, overwrite: bool = True) -> None:
    """Write `data` to a temporary file in the same folder, then rename it over `path`; with
    `overwrite=False` it is linked into place instead, which fails if `path` exists by then."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        remove_stale_temporaries(path.parent, path.name)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=_prefix(path), suffix=".tmp")
    except OSError as exc:
        raise OutputError(f"{path}: cannot write: {exc.strerror}") from None
    try:
        # mkstemp makes 0600 files; outputs are read by other users' tools (ROS, viewers).
        os.fchmod(fd, 0o666 & ~_umask())
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            folder = _OPEN_FOLDER.get()
            folder = folder.holding(path) if folder is not None else None
            if folder is None:
                os.fsync(f.fileno())
            else:
                folder.add(os.dup(f.fileno()))
        raise_if_interrupted()  # a Ctrl-C swallowed by a library still writes nothing
        if overwrite:
            os.replace(tmp, path)
        else:
            try:
                os.link(tmp, path)
            except FileExistsError:
                raise OutputExistsError(f"{path}: exists (use --force to replace it)") from None
            os.unlink(tmp)
    except BaseException as exc:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        if isinstance(exc, OSError) and exc.errno in WRITE_ERRNOS:  # a full disk, a read-only or immutable folder
            raise OutputError(f"{path}: cannot write: {exc.strerror}") from None
        raise


def write_text_atomic(path: Path, text: str, *, overwrite: bool = True) -> None:
    write_bytes_atomic(path, text.encode("utf-8"), overwrite=overwrite)


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


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths in one step (Linux renameat2 RENAME_EXCHANGE); False where unsupported."""
    try:
        renameat2 = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd = -100
    if renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), RENAME_EXCHANGE) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.ENOSYS, errno.EINVAL):
        return False  # an old kernel or a file system without exchange
    raise OSError(code, os.strerror(code), str(b))


def _replace_folder(tmp: Path, out_dir: Path) -> None:
    """Put `tmp` at `out_dir`, swapping out whatever is there (the `force` case)."""
    if _exchange(tmp, out_dir):
        shutil.rmtree(tmp, ignore_errors=True)  # now the previous output
        return
    old = Path(tempfile.mkdtemp(dir=out_dir.parent, prefix=_prefix(out_dir), suffix=".old"))
    os.replace(out_dir, old / "previous")
    try:
        os.replace(tmp, out_dir)
    except BaseException:
        os.replace(old / "previous", out_dir)  # put the previous output back
        os.rmdir(old)
        raise
    shutil.rmtree(old, ignore_errors=True)


@contextlib.contextmanager
def atomic_dir(out_dir: Path, *, force: bool = False, inputs: Sequence[Path] = ()) -> Iterator[Path]:
    """Yield a temporary sibling folder; on success it becomes `out_dir` in one rename.

    Without `force` that rename is also the check that `out_dir` is still absent or empty: the
    kernel refuses to rename a folder over a non-empty one, so of two runs racing for one
    `out_dir` the second fails instead of replacing the first's output. On an exception the
    temporary folder is removed and `out_dir` is left as it was.
    """
    out_dir = Path(out_dir)
    prepare_out_dir(out_dir, force=force, inputs=inputs)
    try:
        out_dir.parent.mkdir(parents=True, exist_ok=True)
        remove_stale_temporaries(out_dir.parent, out_dir.name)
        tmp = Path(tempfile.mkdtemp(dir=out_dir.parent, prefix=_prefix(out_dir), suffix=".tmp"))
        os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp makes 0700 folders
    except OSError as exc:
        raise InputError(f"{out_dir}: cannot create the output folder: {exc.strerror}") from None
    flush = _FolderFlush(tmp, _OPEN_FOLDER.get())
    opened = _OPEN_FOLDER.set(flush)
    try:
        try:
            yield tmp
        except BaseException:
            flush.wait(report=False)  # no flush outlives the folder it writes into
            raise
        finally:
            _OPEN_FOLDER.reset(opened)
        flush.wait()
        raise_if_interrupted()  # a Ctrl-C swallowed by a library still writes nothing
        if force and out_dir.exists():
            _replace_folder(tmp, out_dir)
        else:
            try:
                os.rename(tmp, out_dir)
            except OSError as exc:
                if exc.errno in (errno.ENOTEMPTY, errno.EEXIST, errno.ENOTDIR, errno.EISDIR):
                    raise OutputExistsError(
                        f"{out_dir}: another run wrote this folder meanwhile; its output is kept"
                        " (use --force to replace it)"
                    ) from None
                raise OutputError(f"{out_dir}: cannot create the output folder: {exc.strerror}") from None
    except OutputError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        raise OutputError(str(exc).replace(str(tmp), str(out_dir))) from None
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        if exc.errno not in WRITE_ERRNOS:
            raise
        where = str(exc.filename).replace(str(tmp), str(out_dir)) if exc.filename else str(out_dir)
        raise OutputError(f"{where}: cannot write: {exc.strerror}") from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
