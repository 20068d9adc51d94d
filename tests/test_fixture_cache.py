"""The on-disk fixture cache the expensive fixtures share (tests/fixture_cache.py): a key
changes with any input byte or source file, two processes asking at once make the folder
once, and old keys' folders go only when many or long unused."""

from __future__ import annotations

import multiprocessing
import time
from pathlib import Path

import pytest

import fixture_cache
from fixture_cache import cached_folder, content_key


def test_the_key_follows_the_inputs_the_code_and_the_settings(tmp_path: Path) -> None:
    inputs = tmp_path / "inputs"
    (inputs / "sub").mkdir(parents=True)
    (inputs / "sub" / "spec.yaml").write_text("width_m: 0.6\n")
    first = content_key(inputs=[inputs], packages=["semantic_map"], settings="a")
    assert content_key(inputs=[inputs], packages=["semantic_map"], settings="a") == first
    assert content_key(inputs=[inputs], packages=["semantic_map"], settings="b") != first
    assert content_key(inputs=[inputs], packages=["articulation"], settings="a") != first
    (inputs / "sub" / "spec.yaml").write_text("width_m: 0.7\n")
    assert content_key(inputs=[inputs], packages=["semantic_map"], settings="a") != first


def _ask(root: str, key: str, log: str) -> str:
    fixture_cache.CACHE_ROOT = Path(root)

    def make(folder: Path) -> None:
        with open(log, "a") as f:
            f.write("made\n")
        time.sleep(0.5)  # long enough for the other process to ask meanwhile
        (folder / "result.txt").write_text(key)

    return str(cached_folder("shared", key, make))


def test_two_processes_asking_at_once_make_it_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    log = tmp_path / "log.txt"
    with multiprocessing.get_context("spawn").Pool(2) as pool:
        folders = pool.starmap(_ask, [(str(tmp_path / "cache"), "k1", str(log))] * 2)
    assert folders[0] == folders[1] and log.read_text() == "made\n"
    assert (Path(folders[0]) / "result.txt").read_text() == "k1"

    monkeypatch.setattr(fixture_cache, "CACHE_ROOT", tmp_path / "cache")
    again = cached_folder("shared", "k1", lambda folder: pytest.fail("made again"))
    assert str(again) == folders[0]
    # Another checkout state's key: the older entry stays, for a run that may be reading it.
    newer = cached_folder("shared", "k2", lambda folder: (folder / "result.txt").write_text("k2"))
    assert (newer / "result.txt").read_text() == "k2" and Path(folders[0]).is_dir()
    for key in ("k3", "k4"):  # beyond KEEP_ENTRIES the least recently used goes
        cached_folder("shared", key, lambda folder: None)
    assert sorted(p.name for p in (tmp_path / "cache" / "shared").iterdir() if p.is_dir()) == ["k2", "k3", "k4"]
