"""How an entry's own records (thumbnail, entry.json, the swept spec) reach its folder: written
whole, flushed to disk together before the folder's rename, an fsync's failure never lost in
the threads that make them, and a folder interrupted there never put in place."""

from __future__ import annotations

import errno
import os

import pytest

from homemodel.app.database import entry_build
from homemodel.app.database.entry_build import _store_together
from homemodel.core.atomic import atomic_dir


def test_records_are_written_whole_with_the_users_umask(tmp_path) -> None:
    files = {"thumbnail.png": os.urandom(70_000), "entry.json": b'{"id": "cup"}\n', "spec.yaml": b"kind: cup\n"}
    _store_together(tmp_path, files)
    mask = os.umask(0)
    os.umask(mask)
    for name, data in files.items():
        assert (tmp_path / name).read_bytes() == data
        assert (tmp_path / name).stat().st_mode & 0o777 == 0o666 & ~mask


def test_an_existing_record_is_refused_not_overwritten(tmp_path) -> None:
    (tmp_path / "entry.json").write_text("kept")
    with pytest.raises(FileExistsError):
        _store_together(tmp_path, {"entry.json": b"new"})
    assert (tmp_path / "entry.json").read_text() == "kept"


def test_a_failed_fsync_in_any_thread_fails_the_store_and_the_folder_stays_out(tmp_path, monkeypatch) -> None:
    real_fsync = os.fsync
    synced = []

    def fsync(fd: int) -> None:
        synced.append(fd)
        if len(synced) == 2:  # the second file's: on a pool thread
            raise OSError(errno.EIO, "Input/output error")
        real_fsync(fd)

    monkeypatch.setattr(entry_build.os, "fsync", fsync)
    final = tmp_path / "models" / "cup"
    with pytest.raises(OSError, match="Input/output"), atomic_dir(final, force=True) as folder:
        _store_together(folder, {"a": b"1", "b": b"2", "c": b"3"})
    # Every fsync is waited for before the files close, the failed one among them.
    assert len(synced) == 3 and not final.exists()
    assert not [p for p in (tmp_path / "models").iterdir()]  # no temporary folder left either
