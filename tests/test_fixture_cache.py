"""The on-disk fixture cache the expensive fixtures share (tests/fixture_cache.py): a key
changes with any input byte, source file, lower layer or installed version; two processes
asking for one key make it once, two keys are made at once; old keys' folders go only when
many or long unused, and never while another run may read them; the user's cache is the default."""

from __future__ import annotations

import multiprocessing
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

import fixture_cache
from fixture_cache import cached_folder, code_of, content_key

TESTS = Path(__file__).resolve().parent


def test_the_key_follows_the_inputs_the_code_the_settings_and_the_environment(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    inputs = tmp_path / "inputs"
    (inputs / "sub").mkdir(parents=True)
    (inputs / "sub" / "spec.yaml").write_text("width_m: 0.6\n")
    first = content_key(inputs=[inputs], packages=["semantic_map"], settings="a")
    assert content_key(inputs=[inputs], packages=["semantic_map"], settings="a") == first
    assert content_key(inputs=[inputs], packages=["semantic_map"], settings="b") != first
    assert content_key(inputs=[inputs], packages=["tracking"], settings="a") != first
    (inputs / "sub" / "spec.yaml").write_text("width_m: 0.7\n")
    second = content_key(inputs=[inputs], packages=["semantic_map"], settings="a")
    assert second != first
    monkeypatch.setattr(fixture_cache, "environment", lambda: "numpy==0.0")  # another installed version
    assert content_key(inputs=[inputs], packages=["semantic_map"], settings="a") != second


def test_a_package_s_code_is_what_the_layers_let_it_import() -> None:
    """The layers of setup.cfg: a pipeline stands on the model folder, formats, map, joints,
    geometry and core (and on homemodel's __init__, run on their import), never on another
    pipeline; the CLI on all of them."""
    assert code_of("turntable") == ["turntable", "homemodel.model_folder", "homemodel.exchange", "semantic_map", "articulation",
                                    "homemodel.evaluation", "homemodel.geometry", "homemodel.core", "homemodel.__init__"]  # fmt: skip
    assert code_of("homemodel.core") == ["homemodel.core", "homemodel.__init__"]
    assert {"modeller", "photogrammetry", "turntable", "homemodel.app"} <= set(code_of("homemodel.cli"))
    assert {"modeller", "photogrammetry", "turntable", "homemodel.app"} <= set(code_of("homemodel"))
    with pytest.raises(RuntimeError, match="no layer"):
        code_of("numpy")


def _ask(root: str, key: str, log: str, wait_for: str = "") -> str:
    fixture_cache.CACHE_ROOT = Path(root)

    def make(folder: Path) -> None:
        with open(log, "a") as f:
            f.write(f"made {key}\n")
        if wait_for:  # finish only once the other key's make has begun: they overlap
            deadline = time.monotonic() + 60
            while f"made {wait_for}" not in Path(log).read_text():
                assert time.monotonic() < deadline, f"{wait_for} was not made while {key} was"
                time.sleep(0.05)
        else:
            time.sleep(0.5)  # long enough for the other process to ask meanwhile
        (folder / "result.txt").write_text(key)

    return str(cached_folder("shared", key, make))


def test_two_processes_asking_at_once_make_it_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    log = tmp_path / "log.txt"
    with multiprocessing.get_context("spawn").Pool(2) as pool:
        folders = pool.starmap(_ask, [(str(tmp_path / "cache"), "k1", str(log))] * 2)
    assert folders[0] == folders[1] and log.read_text() == "made k1\n"
    assert (Path(folders[0]) / "result.txt").read_text() == "k1"
    monkeypatch.setattr(fixture_cache, "CACHE_ROOT", tmp_path / "cache")
    again = cached_folder("shared", "k1", lambda folder: pytest.fail("made again"))
    assert str(again) == folders[0]


def test_two_checkouts_make_their_own_keys_at_once(tmp_path: Path) -> None:
    log = tmp_path / "log.txt"
    with multiprocessing.get_context("spawn").Pool(2) as pool:
        asked = [(str(tmp_path / "cache"), "k1", str(log), "k2"), (str(tmp_path / "cache"), "k2", str(log), "k1")]
        folders = pool.starmap(_ask, asked)
    assert [(Path(f) / "result.txt").read_text() for f in folders] == ["k1", "k2"]


def test_old_entries_go_when_many_or_long_unused_but_never_while_a_run_may_read_them(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(fixture_cache, "CACHE_ROOT", tmp_path)
    root = tmp_path / "shared"

    def used_hours_ago(key: str, hours: float) -> None:
        stamp = time.time() - hours * 3600
        os.utime(root / key / fixture_cache.DONE, (stamp, stamp))

    for key in ("k1", "k2", "k3", "k4"):  # more than KEEP_ENTRIES, all just used: all stay
        cached_folder("shared", key, lambda folder: None)
    assert sorted(p.name for p in root.iterdir() if p.is_dir()) == ["k1", "k2", "k3", "k4"]
    for key, hours in (("k1", 5), ("k2", 2), ("k3", 4), ("k4", 24 * 8)):
        used_hours_ago(key, hours)
    cached_folder("shared", "k5", lambda folder: None)
    # k4 unused for over a week; k1, the least recently used beyond three; k2 read 2 h ago stays.
    assert sorted(p.name for p in root.iterdir() if p.is_dir()) == ["k2", "k3", "k5"]


def test_the_default_cache_is_the_user_s_and_the_variable_moves_it(tmp_path: Path) -> None:
    env = {k: v for k, v in os.environ.items() if k != "HOMEMODEL_TEST_CACHE"}
    code = "import fixture_cache; print(fixture_cache.CACHE_ROOT)"

    def root(**extra: str) -> str:
        run = subprocess.run([sys.executable, "-c", code], env={**env, **extra}, cwd=TESTS, capture_output=True, text=True)
        assert run.returncode == 0, run.stderr
        return run.stdout.strip()

    assert root(XDG_CACHE_HOME=str(tmp_path / "xdg")) == str(tmp_path / "xdg" / "homemodel" / "test-fixtures")
    assert root(XDG_CACHE_HOME="", HOME=str(tmp_path)) == str(tmp_path / ".cache" / "homemodel" / "test-fixtures")
    assert root(HOMEMODEL_TEST_CACHE=str(tmp_path / "mine")) == str(tmp_path / "mine")
