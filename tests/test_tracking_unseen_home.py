"""`map observe` on views of a home it has not seen (`unseen_home_views`, the independent check of
issue 26): a wardrobe, a chest of drawers, a bedside table on legs, a washing machine and a
dishwasher under a worktop, a microwave on it and a wall cupboard's flap above, made apart from
the project's makers, measured with a tape
into specs, built by `homemodel build` into a map whose poses are 2-3 cm and 1.5-3 degrees off;
depth and colour ray-cast from the real pieces with the issue's noise, in camera set-ups the
project's own views do not use. Each test is one view of the check's set that the command gets
right today, asserted against the truth it was rendered from; the whole set and its faults are
the check's report (`python tests/unseen_home_views.py OUT`)."""

from __future__ import annotations

import json
import math
import subprocess
from pathlib import Path

import pytest
import yaml
from real_piece_views import built_home
from typer.testing import CliRunner
from unseen_home_views import DOOR_TOL_RAD, DRAWER_TOL_M, SMALL_TOL_M, Home, check_view, make_home, views_of, write_specs

from homemodel.cli import app

SEED = 0


def _built(home: Home, folder: Path, name: str, *, legs: bool = True) -> Path:
    """The map `homemodel build` makes of the home's installer's specs (once per content);
    without `legs`, the bedside table's legs are written as its plinth alone."""
    specs = write_specs(home, folder / "specs")
    if not legs:
        bedside = yaml.safe_load((specs / "bedside.yaml").read_text())
        del bedside["legs"]
        (specs / "bedside.yaml").write_text(yaml.safe_dump(bedside, sort_keys=False))
    return built_home(specs, name, folder / "built")


@pytest.fixture(scope="module")
def unseen_home(tmp_path_factory: pytest.TempPathFactory) -> tuple[Home, Path]:
    """The real home and the map `homemodel build` makes of its installer's specs."""
    home = make_home(SEED)
    return home, _built(home, tmp_path_factory.mktemp("unseen_home"), "unseen_home")


@pytest.fixture(scope="module")
def home_1_on_a_plinth(tmp_path_factory: pytest.TempPathFactory) -> tuple[Home, Path]:
    """Home 1, its installer having read the bedside table's legs as a plinth."""
    home = make_home(1)
    return home, _built(home, tmp_path_factory.mktemp("home_1"), "unseen_home_plinth", legs=False)


def _observe_in_process(map_path: Path, obs: Path, out: Path) -> subprocess.CompletedProcess:
    """The issue's command line, run by the CLI in this process (the imports paid once)."""
    args = ["map", "observe", str(map_path), str(obs), "--out", str(out / "new_map.xml"), "--report", str(out / "report.json")]
    result = CliRunner().invoke(app, args)
    return subprocess.CompletedProcess(args, result.exit_code, result.stdout, result.output)


def _checked(unseen_home: tuple[Home, Path], index: int, tmp_path: Path, seed: int = SEED) -> dict:
    home, map_path = unseen_home
    view = views_of(home, index + 1, seed)[index]
    return check_view(map_path, home, view, tmp_path / view.name, run=_observe_in_process, visibility=False)


def _written_within_target(scored: dict, joints: list[str]) -> None:
    rows = {row["joint"]: row for row in scored["joints"]}
    for name in joints:
        row = rows[name]
        tol = DRAWER_TOL_M if name.endswith("_slide") else DOOR_TOL_RAD
        assert row["class"] == "written right", row
        assert abs(row["written"] - row["truth"]) <= tol, row


def _nothing_wrong(scored: dict) -> None:
    """No joint or small object written off its truth, no pose written worse than the map's."""
    assert not [r for r in scored["joints"] if r["class"] == "WRITTEN WRONG"], scored["joints"]
    assert not [p for p in scored["poses"] if p["class"] == "WORSE"], scored["poses"]
    assert not [s for s in scored["small"] if s["class"] == "WRITTEN WRONG"], scored["small"]


def test_a_round_door_a_dishwasher_flap_and_a_microwave_behind_a_chair(unseen_home, tmp_path: Path) -> None:
    """The utility corner, 512x424, a chair in front: the washing machine's round door (its hinge
    off the rim, its glass seen through or not at all) and detergent drawer, the dishwasher's
    bottom-hinged flap and the microwave's door (a dark window) written within target; the four
    poses written better than the map's."""
    scored = _checked(unseen_home, 3, tmp_path)
    _nothing_wrong(scored)
    _written_within_target(scored, ["washer/door_0_hinge", "washer/drawer_0_slide", "dishwasher/door_0_hinge",
                                    "microwave/door_0_hinge"])
    assert {p["object"]: p["class"] for p in scored["poses"] if p["class"] != "kept"} == {
        "washer": "better", "worktop": "better", "dishwasher": "better", "microwave": "better"}


def test_a_mug_carried_from_the_bedside_table_to_the_chest(unseen_home, tmp_path: Path) -> None:
    """The bedroom, a chair in front: the mug, moved from the bedside table onto the chest of
    drawers, found there within 1 cm and re-parented; the bedside table's drawer written within
    5 mm; no pose written worse than the map's."""
    scored = _checked(unseen_home, 7, tmp_path)
    _nothing_wrong(scored)
    _written_within_target(scored, ["bedside/drawer_0_slide"])
    mug = next(s for s in scored["small"] if s["object"] == "mug")
    assert mug["class"] == "found right" and mug["parent"] == mug["true_parent"] == "chest", mug
    assert mug["error_mm"] <= SMALL_TOL_M * 1000


def test_a_plate_moved_on_the_worktop(unseen_home, tmp_path: Path) -> None:
    """The utility corner, 640x480 with depth in quarter millimetres: the plate, moved on the
    worktop, found within 1 cm; the microwave's shut door written shut; nothing written off its
    truth."""
    scored = _checked(unseen_home, 16, tmp_path)
    _nothing_wrong(scored)
    _written_within_target(scored, ["microwave/door_0_hinge"])
    plate = next(s for s in scored["small"] if s["object"] == "plate")
    assert plate["class"] == "found right" and plate["parent"] == "worktop", plate
    assert math.isfinite(plate["error_mm"]) and plate["error_mm"] <= SMALL_TOL_M * 1000


def test_a_dishwasher_flap_open_below_the_image_is_not_written(unseen_home, tmp_path: Path) -> None:
    """The utility corner, 640x480, no occluder: the dishwasher's flap open 80 deg lies below the
    image, its opening in view; shut, the flap would leave 0.91 of its points unexplained, and
    out of the image it explains them no worse: the view cannot tell, so it is "ambiguous" and
    the map's shut flap stays (it was written shut)."""
    scored = _checked(unseen_home, 10, tmp_path)
    _nothing_wrong(scored)
    flap = next(r for r in scored["joints"] if r["joint"] == "dishwasher/door_0_hinge")
    assert flap["truth"] > 1.2 and flap["class"] == "rightly not written", flap
    report = json.loads((tmp_path / "v10" / "result" / "report.json").read_text())
    dishwasher = next(o for o in report["objects"] if o["id"] == "dishwasher")
    assert next(j for j in dishwasher["joints"] if j["name"] == "door_0_hinge")["status"] == "ambiguous"


def test_a_drawer_read_against_a_body_the_view_put_elsewhere_is_not_written(home_1_on_a_plinth, tmp_path: Path) -> None:
    """Home 1's bedroom, a chair in front, the bedside table's drawer 26 cm out, its legs in the
    map as a plinth: the table's refined pose is refused (turned 6.9 deg, past the map's doubt)
    and the map's, 24 mm off, kept. Read against that body the drawer came out 29 mm short and
    was written; a body moved along the slide with the drawer held where it was seen explains
    the view as well, so it is "ambiguous" and the map's position stays."""
    scored = _checked(home_1_on_a_plinth, 1, tmp_path, seed=1)
    _nothing_wrong(scored)
    report = json.loads((tmp_path / "v01" / "result" / "report.json").read_text())
    bedside = next(o for o in report["objects"] if o["id"] == "bedside")
    assert not bedside["pose_refined"] and "turned" in bedside["pose_note"], bedside["pose_note"]
    assert next(j for j in bedside["joints"] if j["name"] == "drawer_0_slide")["status"] == "ambiguous"
