"""A long command piped into a file or a script that fails on its input writes its one error
line on stderr and nothing on stdout: its progress bars, only for a terminal, left a blank line
there (rich ends a bar on a non-terminal with an empty line)."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from homemodel.cli import app

runner = CliRunner()


@pytest.mark.parametrize(
    "command",
    [
        ["turntable", "import", "{missing}", "--board", "{missing}", "--out", "{out}"],
        ["turntable", "reconstruct", "{missing}", "--out", "{out}"],
        ["completion", "run", "{missing}", "{missing}", "--camera", "{missing}", "--out", "{out}"],
    ],
    ids=lambda command: " ".join(command[:2]),
)
def test_a_missing_input_is_one_line_on_stderr_and_nothing_on_stdout(tmp_path: Path, command: list[str]) -> None:
    missing, out = tmp_path / "no_such_input", tmp_path / "out"
    result = runner.invoke(app, [word.format(missing=missing, out=out) for word in command])
    assert result.exit_code == 2, result.output
    assert result.stdout == ""
    assert result.stderr.startswith(f"error: {missing}") and len(result.stderr.splitlines()) == 1, result.stderr
    assert not out.exists()
