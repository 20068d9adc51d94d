"""`homemodel turntable board`: the grid, board.yaml, and a PDF that prints true to scale.

The scale check reads the PDF back (its page size and every filled rectangle), paints the
rectangles at 8 pixels per millimetre, and detects the tags in that picture: ids, centres and
sizes must be those of board.yaml.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from homemodel.cli import app
from homemodel.core.errors import SpecError
from turntable.board import grid_board, load_board, save_board
from turntable.board_pdf import MARGIN_MM, PAPER_MM, POINTS_PER_MM, write_board_pdf
from turntable.tags import detect_tags

runner = CliRunner()
_NUMBER = r"(-?[\d.]+)"


def pdf_pages(path: Path) -> list[tuple[tuple[float, float], list[tuple[float, float, float, float]]]]:
    """Each page's size (points) and its filled rectangles (x, y, w, h in points)."""
    data = path.read_bytes().decode("latin-1")
    boxes = [tuple(float(v) for v in m) for m in re.findall(rf"/MediaBox \[ 0 0 {_NUMBER} {_NUMBER} \]", data)]
    streams = re.findall(r"stream\r?\n(.*?)endstream", data, flags=re.S)
    pages = []
    for size, stream in zip(boxes, [s for s in streams if " re " in s]):
        rects = [
            tuple(float(v) for v in m) for m in re.findall(rf"n {_NUMBER} {_NUMBER} {_NUMBER} {_NUMBER} re f", stream)
        ]
        pages.append((size, rects))
    return pages


def test_grid_fits_the_table_with_quiet_zones() -> None:
    board = grid_board(table_diameter_m=0.3, tag_size_m=0.025)
    ids = [t.id for t in board.tags]
    assert ids == list(range(len(ids))) and len(ids) > 30
    centers = np.array([t.center_m for t in board.tags])
    reach = np.hypot(np.abs(centers[:, 0]) + 0.025 * 5 / 8, np.abs(centers[:, 1]) + 0.025 * 5 / 8)
    assert reach.max() <= 0.15  # tag plus one white cell inside the disc
    pitch = np.diff(np.unique(centers[:, 0]))
    assert np.allclose(pitch, 0.025 * 10 / 8)


def test_board_yaml_round_trips(tmp_path: Path) -> None:
    board = grid_board(table_diameter_m=0.3, tag_size_m=0.025, first_id=100)
    save_board(board, tmp_path / "board.yaml")
    assert load_board(tmp_path / "board.yaml") == board


def test_duplicate_ids_name_the_field(tmp_path: Path) -> None:
    path = tmp_path / "board.yaml"
    path.write_text(
        yaml.safe_dump(
            {
                "family": "tag36h11",
                "tag_size_m": 0.03,
                "tags": [{"id": 1, "center_m": [0, 0]}, {"id": 1, "center_m": [0.1, 0]}],
            }
        )
    )
    with pytest.raises(SpecError, match=r"board.yaml: tags.1.id: tag id 1 repeats \(also tags.0\)"):
        load_board(path)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"family": "tag25h9"}, "family: only tag36h11 is supported"),
        ({"tag_size_m": -0.03}, "tag_size_m: Input should be greater than 0"),
        (
            {"tags": [{"id": 0, "center_m": [0, 0]}, {"id": 1, "center_m": [0.01, 0]}]},
            "tags.1.center_m: overlaps tag id 0",
        ),
        ({"tags": [{"id": 9999, "center_m": [0, 0]}]}, "tags.0.id: Input should be less than 587"),
    ],
)
def test_impossible_boards_are_refused(tmp_path: Path, change: dict, message: str) -> None:
    path = tmp_path / "board.yaml"
    path.write_text(
        yaml.safe_dump({"family": "tag36h11", "tag_size_m": 0.03, "tags": [{"id": 0, "center_m": [0, 0]}]} | change)
    )
    with pytest.raises(SpecError, match=re.escape(message)):
        load_board(path)


def test_pdf_is_true_to_scale(tmp_path: Path) -> None:
    board = grid_board(table_diameter_m=0.16, tag_size_m=0.025)
    assert write_board_pdf(board, tmp_path / "board.pdf", paper="a4") == 1
    [(size, rects)] = pdf_pages(tmp_path / "board.pdf")
    assert np.allclose(np.array(size) / POINTS_PER_MM, PAPER_MM["a4"], atol=0.01)
    px_per_mm = 8
    page_mm = np.array(PAPER_MM["a4"])
    canvas = np.full((int(page_mm[1] * px_per_mm), int(page_mm[0] * px_per_mm)), 255, np.uint8)
    for x, y, w, h in rects:
        # PDF y runs up from the page's bottom; image rows run down from its top.
        c0, c1 = round(x / POINTS_PER_MM * px_per_mm), round((x + w) / POINTS_PER_MM * px_per_mm)
        r0, r1 = (round(page_mm[1] * px_per_mm - (v / POINTS_PER_MM) * px_per_mm) for v in (y + h, y))
        canvas[r0:r1, c0:c1] = 0
    found = detect_tags(canvas)
    assert sorted(found) == [t.id for t in board.tags]
    # The page's printable area starts at the margin; the board's origin is the table's centre.
    area = page_mm - 2 * MARGIN_MM
    origin_mm = np.array([MARGIN_MM + area[0] / 2, page_mm[1] - MARGIN_MM - area[1] / 2])  # in image mm (y down)
    for tag in board.tags:
        corners_mm = found[tag.id] / px_per_mm
        center_mm = corners_mm.mean(axis=0)
        expected = origin_mm + np.array([tag.center_m[0], -tag.center_m[1]]) * 1000
        assert np.allclose(center_mm, expected, atol=0.1), (tag.id, center_mm, expected)
        side_mm = np.linalg.norm(corners_mm[1] - corners_mm[0])
        assert abs(side_mm - 25.0) < 0.1
        # ArUco order: the first corner is the tag's top-left, i.e. towards -x and +y.
        assert corners_mm[0][0] < center_mm[0] and corners_mm[0][1] < center_mm[1]


@pytest.mark.parametrize(("paper", "pages"), [("a4", 6), ("a3", 4), ("letter", 6)])
def test_large_tables_tile_over_pages(tmp_path: Path, paper: str, pages: int) -> None:
    board = grid_board(table_diameter_m=0.4, tag_size_m=0.03)
    assert write_board_pdf(board, tmp_path / "board.pdf", paper=paper) == pages
    read = pdf_pages(tmp_path / "board.pdf")
    assert len(read) == pages
    for size, rects in read:
        assert sorted(np.round(np.array(size) / POINTS_PER_MM, 1)) == sorted(PAPER_MM[paper])
        assert rects


def test_cli_board(tmp_path: Path) -> None:
    out = tmp_path / "board"
    result = runner.invoke(
        app,
        ["turntable", "board", "--out", str(out), "--diameter-m", "0.3", "--tag-size-m", "0.03", "--paper", "a3"],
        env={"COLUMNS": "200"},
    )
    assert result.exit_code == 0, result.output
    assert "pages" in result.stdout and (out / "board.pdf").is_file()
    board = load_board(out / "board.yaml")
    assert board.table_diameter_m == 0.3 and board.tag_size_m == 0.03


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (["--diameter-m", "-1"], "the table diameter -1 m must be positive"),
        (["--tag-size-m", "0.5", "--diameter-m", "0.3"], "the tag size 0.5 m must be positive and below half"),
        (["--tag-size-m", "-0.03"], "the tag size -0.03 m must be positive"),
        (["--first-id", "580"], "69 tags from the first id 580 exceed tag36h11's 587 ids (0-586)"),
        (["--first-id", "-1"], "the first id -1 must be 0 or more (tag36h11's ids are 0-586)"),
    ],
)
def test_cli_board_refuses_impossible_sizes(tmp_path: Path, args: list[str], said: str) -> None:
    # In the user's words, naming the value given (the first id's was pydantic's validation text).
    out = tmp_path / "board"
    result = runner.invoke(app, ["turntable", "board", "--out", str(out), *args])
    assert result.exit_code == 2 and result.stderr.startswith(f"error: board: {said}"), result.stderr
    assert len(result.stderr.splitlines()) == 1
    assert not out.exists()
