"""`map observe` on views of a second home it has not seen (`unseen_home2_views`, issue 26's
independent check, s17): a kitchen of a fridge-freezer (two doors one above the other over a
freezer drawer), a tall larder, a base unit with a drawer over a door under a glass-fronted wall
cabinet, a cooker with a drop-down door and four knobs, a sideboard with three doors and a chest
of drawers with recessed grips, made apart from the project's makers and the first check's, with
clutter the map does not have; measured with a tape into specs and built by `homemodel build`
into a map whose poses are 2-3.2 cm and 2-3 degrees off. Depth is ray-cast from the real pieces
in camera set-ups neither stand-in uses (a Kinect v2's 512x424 in 0.2 mm units, a RealSense's
848x480 in 0.1 mm units, an Azure Kinect's 640x576 without a colour image). Each test is one
view of the check's set that the command gets right today, asserted against the truth it was
rendered from; the whole set and its faults are the check's report
(`python tests/unseen_home2_views.py OUT`)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
from real_piece_views import built_home
from typer.testing import CliRunner
from unseen_home2_views import DOOR_TOL, DRAWER_TOL, SMALL_TOL, Home, check_view, make_home, views_of, write_specs

from homemodel.cli import app

SEED = 0


@pytest.fixture(scope="module")
def kitchen(tmp_path_factory: pytest.TempPathFactory) -> tuple[Home, Path]:
    """The real kitchen and the map `homemodel build` makes of its installer's specs (once per content)."""
    home = make_home(SEED)
    folder = tmp_path_factory.mktemp("unseen_home2")
    return home, built_home(write_specs(home, folder / "specs"), "unseen_home2", folder / "built")


def _observe_in_process(map_path: Path, obs: Path, out: Path) -> subprocess.CompletedProcess:
    """The issue's command line, run by the CLI in this process (the imports paid once)."""
    args = ["map", "observe", str(map_path), str(obs), "--out", str(out / "new_map.xml"), "--report", str(out / "report.json")]
    result = CliRunner().invoke(app, args)
    return subprocess.CompletedProcess(args, result.exit_code, result.stdout, result.output)


def _checked(kitchen: tuple[Home, Path], index: int, tmp_path: Path) -> dict:
    home, map_path = kitchen
    view = views_of(home, index + 1, SEED)[index]
    return check_view(map_path, home, view, tmp_path / view.name, run=_observe_in_process, visibility=False)


def _nothing_wrong(scored: dict) -> None:
    """No joint or small object written off its truth, no pose written worse than the map's, and
    nothing else in the map changed."""
    assert not [r for r in scored["joints"] if r["class"] == "WRITTEN WRONG"], scored["joints"]
    assert not [p for p in scored["poses"] if p["class"] == "WORSE"], scored["poses"]
    assert not [s for s in scored["small"] if s["class"] == "WRITTEN WRONG"], scored["small"]
    assert scored["other_changes"] == []


def _written_right(scored: dict, joints: list[str]) -> None:
    """Each joint fitted (the report's status: a shut door may be written shut, unchanged) and what
    the map holds within 2 deg / 5 mm of the truth."""
    rows = {row["joint"]: row for row in scored["joints"]}
    for name in joints:
        row = rows[name]
        tol = DRAWER_TOL if name.endswith("_slide") else DOOR_TOL
        assert row["status"] == "fitted" and abs(row["error"]) <= tol, row


def _small(scored: dict, name: str) -> dict:
    return next(s for s in scored["small"] if s["object"] == name)


def test_a_cup_carried_to_the_sideboard_past_a_person(kitchen, tmp_path: Path) -> None:
    """848x480 in 0.1 mm units, a person in front of the sideboard: the cup, carried from the base
    unit onto the sideboard among bottles the map does not have, found there within 1 cm and
    re-parented; the sideboard's pose written better than the map's."""
    scored = _checked(kitchen, 25, tmp_path)
    _nothing_wrong(scored)
    cup = _small(scored, "cup")
    assert cup["class"] == "found right" and cup["parent"] == cup["true_parent"] == "sideboard", cup
    assert cup["error_mm"] <= SMALL_TOL * 1000
    assert {p["object"]: p["class"] for p in scored["poses"] if p["class"] != "kept"} == {"sideboard": "better"}


def test_a_cooker_door_and_a_cup_beside_a_kettle(kitchen, tmp_path: Path) -> None:
    """512x424 in 0.2 mm units: the cooker's drop-down door (a window the sensor sees through)
    written within 2 deg, its pose better than the map's; the cup, in its place beside a kettle
    the map does not have, found within 1 cm."""
    scored = _checked(kitchen, 24, tmp_path)
    _nothing_wrong(scored)
    _written_right(scored, ["cooker/door_0_hinge"])
    assert {p["object"]: p["class"] for p in scored["poses"] if p["class"] != "kept"} == {"cooker": "better"}
    cup = _small(scored, "cup")
    assert cup["class"] == "found right" and cup["parent"] == "base_unit", cup


def test_a_bowl_taken_away_seen_without_a_colour_image(kitchen, tmp_path: Path) -> None:
    """640x576 depth alone (no color.png): the bowl gone from the sideboard is not written anywhere;
    the larder's full-height door, the base unit's door and drawer and the sideboard's middle door
    (pivot hinges on a divider) written within target, the cup found within 1 cm."""
    scored = _checked(kitchen, 14, tmp_path)
    _nothing_wrong(scored)
    assert _small(scored, "bowl")["class"] == "gone, kept"
    _written_right(scored, ["larder/door_0_hinge", "base_unit/door_0_hinge", "base_unit/drawer_0_slide",
                            "sideboard/door_1_hinge"])
    assert _small(scored, "cup")["class"] == "found right"


def test_a_glass_fronted_door_fitted_on_its_frame(kitchen, tmp_path: Path) -> None:
    """640x576 depth alone: the wall cabinet's door, a 60 mm frame round a glass pane the sensor
    sees through or gets no reading from, open 49 deg: written within 2 deg (with the pane's pixels
    scored as a solid door it is left 'ambiguous' here; check26b's run of this view wrote it 92 deg,
    99 % of its points unexplained)."""
    scored = _checked(kitchen, 20, tmp_path)
    _nothing_wrong(scored)
    _written_right(scored, ["glass_cabinet/door_0_hinge"])


def test_a_file_given_as_the_observation_folder_is_named_a_file(tmp_path: Path) -> None:
    """OBS_DIR given as a file (the depth image itself): one line that says it is a file, exit 2,
    nothing written (it said "no such folder" of a file that is there)."""
    depth = tmp_path / "depth.png"
    depth.write_bytes(b"\x89PNG")
    result = CliRunner().invoke(app, ["map", "observe", str(tmp_path / "map.xml"), str(depth), "--out", str(tmp_path / "new.xml")])
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert result.exit_code == 2 and len(lines) == 1, result.output
    assert f"{depth}: not an observation folder (a file)" in lines[0], result.output
    assert not (tmp_path / "new.xml").exists()
