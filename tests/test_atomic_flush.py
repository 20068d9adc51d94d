"""Files written into an atomic folder are flushed by a thread beside the writer: every one of
them reaches the disk before the folder's rename, a failed flush keeps the folder out, and a
file written elsewhere is flushed before its own write returns."""

from __future__ import annotations

import errno
import os
import signal
import threading
from pathlib import Path

import pytest

from homemodel.core import atomic, interrupts
from homemodel.core.atomic import atomic_dir, write_bytes_atomic


def _recording_fsync(monkeypatch: pytest.MonkeyPatch, flushed: set[int], fail: bool = False) -> None:
    real_fsync = os.fsync

    def fsync(fd: int) -> None:
        flushed.add(os.fstat(fd).st_ino)
        if fail:
            raise OSError(errno.EIO, os.strerror(errno.EIO))
        real_fsync(fd)

    monkeypatch.setattr(atomic.os, "fsync", fsync)


def test_every_file_of_an_atomic_folder_is_flushed_before_its_rename(tmp_path: Path, monkeypatch) -> None:
    flushed: set[int] = set()
    _recording_fsync(monkeypatch, flushed)
    out = tmp_path / "out"
    real_rename = os.rename
    seen_at_rename: list[tuple[set[int], set[int]]] = []

    def rename(source, target) -> None:
        if Path(target) == out:
            files = {p.stat().st_ino for p in Path(source).rglob("*") if p.is_file()}
            seen_at_rename.append((files, set(flushed)))
        real_rename(source, target)

    monkeypatch.setattr(atomic.os, "rename", rename)
    with atomic_dir(out) as tmp:
        for i in range(100):  # more than the files allowed to wait at once
            write_bytes_atomic(tmp / "meshes" / f"part_{i}.obj", b"v 0 0 0\n" * 1000)
        write_bytes_atomic(tmp / "model.urdf", b"<robot/>")
    [(files, done)] = seen_at_rename
    assert len(files) == 101 and files <= done
    assert not any(t.name.startswith("homemodel-fsync") for t in threading.enumerate())


def test_a_failed_flush_keeps_the_folder_out(tmp_path: Path, monkeypatch) -> None:
    _recording_fsync(monkeypatch, set(), fail=True)
    out = tmp_path / "out"
    with pytest.raises(OSError, match="Input/output"), atomic_dir(out) as tmp:
        write_bytes_atomic(tmp / "model.urdf", b"<robot/>")  # returns: its flush fails later
    assert list(tmp_path.iterdir()) == []


def test_a_file_outside_an_atomic_folder_is_flushed_before_the_write_returns(tmp_path: Path, monkeypatch) -> None:
    flushed: set[int] = set()
    _recording_fsync(monkeypatch, flushed)
    with atomic_dir(tmp_path / "out"):
        write_bytes_atomic(tmp_path / "map.xml", b"<map/>")
        assert (tmp_path / "map.xml").stat().st_ino in flushed


def test_a_forked_child_flushes_its_own_files(tmp_path: Path, monkeypatch) -> None:
    """A child forked inside an atomic folder has no flush thread: its writes flush before they return."""
    flushed: set[int] = set()
    _recording_fsync(monkeypatch, flushed)
    with atomic_dir(tmp_path / "out") as tmp:
        write_bytes_atomic(tmp / "parent.txt", b"parent")  # the parent's flush thread runs: not the child's
        child = os.fork()
        if child == 0:  # the child: its exit code says what it found
            write_bytes_atomic(tmp / "child.txt", b"child")
            os._exit(0 if (tmp / "child.txt").stat().st_ino in flushed else 1)
        _, status = os.waitpid(child, 0)
    assert os.waitstatus_to_exitcode(status) == 0


def test_ctrl_c_while_a_flush_is_handed_over_closes_its_descriptor_once(tmp_path: Path, monkeypatch) -> None:
    """A SIGINT landing inside the pool's `submit`, after it queued the flush, used to close the
    file's descriptor there and again in the flush thread (EBADF: CI's Ctrl-C test)."""
    # A descriptor closed twice fails the second close with EBADF (in whichever thread): counted
    # here, since a flush thread's error is not raised once Ctrl-C is already on its way. (The
    # numbers themselves may repeat: rmtree reopens freed ones.)
    closed_twice: list[int] = []
    real_close = os.close

    def close(fd: int) -> None:
        try:
            real_close(fd)
        except OSError as exc:
            if exc.errno == errno.EBADF:
                closed_twice.append(fd)
            raise

    monkeypatch.setattr(atomic.os, "close", close)
    real_submit = atomic.ThreadPoolExecutor.submit

    def submit(pool, *args, **kwargs):
        future = real_submit(pool, *args, **kwargs)
        os.kill(os.getpid(), signal.SIGINT)  # Python runs the handler at the next bytecode
        return future

    monkeypatch.setattr(atomic.ThreadPoolExecutor, "submit", submit)
    # Set before the SIGINT, so that the teardown puts back the flag as it was (False), not as the
    # handler left it: a flag left set stops the worker's next atomic write (xdist: node down).
    monkeypatch.setattr(interrupts, "_interrupted", False)
    previous = signal.getsignal(signal.SIGINT)
    interrupts.remember_interrupts()
    try:
        with pytest.raises(KeyboardInterrupt), atomic_dir(tmp_path / "out") as tmp:
            write_bytes_atomic(tmp / "model.urdf", b"<robot/>")
    finally:
        signal.signal(signal.SIGINT, previous)
    assert closed_twice == []
    assert list(tmp_path.iterdir()) == []
