"""A user who skips `turntable import` and gives `turntable reconstruct` the recording itself is
told to import it first, in one line naming it: the capture's own check said `no such capture
folder` of a .bag that exists, and named a missing camera.yaml inside a TUM folder."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import recording_sim as rsim
from homemodel.cli import app

runner = CliRunner()


def _tum_folder(folder: Path) -> Path:
    folder.mkdir()
    (folder / "rgb.txt").write_text("# timestamp filename\n1.0 rgb/1.0.png\n")
    (folder / "depth.txt").write_text("# timestamp filename\n1.0 depth/1.0.png\n")
    return folder


def _ros1_bag(path: Path) -> Path:
    ros = rsim.RosMessages(1)
    image = ros.image(0.0, np.zeros((2, 2, 3), np.uint8), "rgb8", "camera_color_optical_frame")
    rsim.write_bag(path, ros, [(0.0, "/camera/color/image_raw", image)])
    return path


@pytest.mark.parametrize(
    ("make", "said", "also"),
    [
        (lambda tmp: _tum_folder(tmp / "tum_folder"), "a recording (format tum), not a capture folder: import it first", "--camera camera.yaml"),
        (lambda tmp: _ros1_bag(tmp / "recording.bag"), "a recording (format ros1), not a capture folder: import it first", "--board board.yaml --out scan/"),
        (lambda tmp: tmp / "notes.txt", "a file, not a capture folder", "camera.yaml, board.yaml"),
    ],
    ids=["tum folder", "ros1 bag", "other file"],
)
def test_a_recording_given_to_reconstruct_says_import_it_first(tmp_path: Path, make, said: str, also: str) -> None:  # noqa: ANN001
    (tmp_path / "notes.txt").write_text("not a capture\n")
    given, out = make(tmp_path), tmp_path / "model"
    result = runner.invoke(app, ["turntable", "reconstruct", str(given), "--out", str(out)])
    assert result.exit_code == 2, result.output
    assert result.stdout == ""
    assert result.stderr.startswith(f"error: {given}: {said}") and len(result.stderr.splitlines()) == 1, result.stderr
    assert also in result.stderr, result.stderr
    assert not out.exists()
