"""Inputs that are not plain files, or too big, are refused in one line instead of hanging."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest
from typer.testing import CliRunner

from homemodel.core.atomic import write_text_atomic
from homemodel.cli import app
from homemodel.core.errors import InputError, SpecError
from homemodel.core.input_files import read_bounded
from homemodel.core.yaml_specs import read_yaml_mapping

runner = CliRunner()


def test_a_fifo_map_is_refused_without_blocking(tmp_path: Path) -> None:
    fifo = tmp_path / "map.xml"
    os.mkfifo(fifo)
    result = runner.invoke(app, ["map", "validate", str(fifo)])
    assert result.exit_code == 2
    assert result.output.strip() == f"error: {fifo}: not a regular file"


def test_a_device_is_refused_and_an_oversize_file_is_cut_short(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not a regular file"):
        read_bounded(Path("/dev/zero"), 1024)
    big = tmp_path / "big.yaml"
    big.write_bytes(b"a: 1\n" * 2000)
    with pytest.raises(InputError, match="larger than the 1000-byte bound"):
        read_bounded(big, 1000)


def test_yaml_errors_name_the_file(tmp_path: Path) -> None:
    bad = tmp_path / "spec.yaml"
    bad.write_text("kind: [unclosed\n")
    with pytest.raises(SpecError, match=r"spec.yaml: invalid YAML at line 2"):
        read_yaml_mapping(bad)
    with pytest.raises(SpecError, match="no such file"):
        read_yaml_mapping(tmp_path / "missing.yaml")


def test_atomic_writes_honour_the_umask(tmp_path: Path) -> None:
    old = os.umask(0o022)
    try:
        write_text_atomic(tmp_path / "out.txt", "x")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "out.txt").stat().st_mode) == 0o644
