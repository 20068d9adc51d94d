"""`map observe`'s output files as a user mistypes them: refused in one line before any work,
the map left as it was."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from homemodel.cli import app

runner = CliRunner()


@pytest.mark.parametrize(("report", "said"), [("map.xml", "MAP.xml"), ("now.xml", "--out")])
def test_a_report_named_as_a_map_is_refused_and_the_map_kept(tmp_path: Path, report: str, said: str) -> None:
    # The check runs before the map is read: a stand-in file shows it is left byte for byte.
    map_path = tmp_path / "map.xml"
    map_path.write_text("<apartment/>")
    obs = tmp_path / "obs"
    obs.mkdir()
    result = runner.invoke(
        app, ["map", "observe", str(map_path), str(obs), "--out", str(tmp_path / "now.xml"), "--report", str(tmp_path / report)]
    )
    assert result.exit_code == 2, result.output
    assert result.stderr.startswith(f"error: --report {tmp_path / report}: the same file as {said}")
    assert len(result.stderr.splitlines()) == 1
    assert map_path.read_text() == "<apartment/>" and not (tmp_path / "now.xml").exists()
