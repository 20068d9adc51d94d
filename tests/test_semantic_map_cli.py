"""`homemodel map show|find|add|validate`, through a throwaway Typer app holding `map_app`."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import typer
from sample_house import HOSTILE, box_model, cup_model
from typer.testing import CliRunner

from articulation.model import Model
from homemodel.cli.map_commands import map_app
from homemodel.exchange.map_xml import load_map
from homemodel.exchange.urdf import read as urdf_read
from semantic_map import LargeObject, SmallObject

app = typer.Typer()
app.add_typer(map_app, name="map")
runner = CliRunner()


def run(*args: str | Path) -> typer.testing.Result:
    # A wide terminal, so rich does not wrap the tree's lines.
    return runner.invoke(app, ["map", *(str(a) for a in args)], env={"COLUMNS": "200"})


def test_show_prints_the_hierarchy(house_file: Path) -> None:
    result = run("show", house_file)
    assert result.exit_code == 0, result.output
    out = result.stdout
    for label in ("house (House)", "kitchen (Kitchen)", "bathroom (Bathroom)", "kitchen_light: rotational switch",
                  "table: table", "blue_cup: cup, on table [colour=blue, material=ceramic]",
                  "cupboard: cupboard, joints door_hinge revolute at 0, lock continuous at 0"):
        assert label in out
    assert out.index("house") < out.index("kitchen") < out.index("table") < out.index("blue_cup") < out.index("bathroom")


def test_find_replays_the_blue_cup_walk(house_file: Path) -> None:
    result = run("find", house_file, "--type", "cup", "--property", "colour=blue")
    assert result.exit_code == 0, result.output
    assert result.stdout.splitlines() == [
        "path: house > kitchen > table > blue_cup",
        "parent: table: table",
        "parking positions of table:",
        "  1. front (default): x=2.000 m, y=0.000 m, yaw=1.571 rad",
        "  2. left: x=1.000 m, y=1.000 m, yaw=0.000 rad",
        "  3. right: x=3.000 m, y=1.000 m, yaw=3.142 rad",
    ]


def test_find_a_large_object_lists_its_own_parking(house_file: Path) -> None:
    result = run("find", house_file, "--type", "fridge")
    assert result.exit_code == 0, result.output
    assert "path: house > kitchen > fridge" in result.stdout and "parking positions of fridge:" in result.stdout


def test_find_without_a_match_exits_1(house_file: Path) -> None:
    result = run("find", house_file, "--type", "cup", "--property", "colour=green")
    assert result.exit_code == 1
    assert result.stderr.strip() == f"no object in {house_file} matches type=cup colour=green"


def test_validate(house_file: Path) -> None:
    result = run("validate", house_file)
    assert (result.exit_code, result.stdout.strip()) == (0, f"{house_file}: valid (2 rooms, 7 objects)")
    house_file.write_text(house_file.read_text().replace('type="revolute"', 'type="screw"'))
    result = run("validate", house_file)
    assert result.exit_code == 2
    assert len(result.stderr.splitlines()) == 1 and result.stderr.startswith(f"error: {house_file}: line ")


@pytest.mark.parametrize("name", sorted(HOSTILE))
def test_hostile_xml_is_one_line_error(tmp_path: Path, name: str) -> None:
    path = tmp_path / "map.xml"
    path.write_bytes(HOSTILE[name])
    for command in ("validate", "show"):
        result = run(command, path)
        assert result.exit_code == 2 and result.stdout == ""
        assert result.stderr == f"error: {path}: DOCTYPE or entity declarations are not allowed\n"


@pytest.fixture
def urdf_reads(monkeypatch: pytest.MonkeyPatch) -> list[Path]:
    """The URDF reader replaced by one returning a green cup; the paths it was asked to read."""
    reads: list[Path] = []

    def load_urdf(path: Path, *, package_paths: tuple = ()) -> Model:
        reads.append(Path(path))
        return cup_model(colour="green")

    monkeypatch.setattr(urdf_read, "load_urdf", load_urdf)
    return reads


@pytest.fixture
def model_dir(tmp_path: Path, urdf_reads: list[Path]) -> Path:
    folder = tmp_path / "models" / "green_cup"
    folder.mkdir(parents=True)
    (folder / "model.urdf").write_text("<robot/>")
    return folder


def test_add_small_object_to_a_new_file(
    house_file: Path, model_dir: Path, tmp_path: Path, urdf_reads: list[Path]
) -> None:
    before = house_file.read_bytes()
    out = tmp_path / "map2.xml"
    result = run("add", house_file, model_dir, "--id", "green_cup", "--parent", "table", "--relation", "on",
                 "--xyz", "0.1", "0.3", "0.75", "--rpy", "0", "0", "1.0", "--property", "owner=anna", "--out", out)
    assert result.exit_code == 0, result.output
    assert result.stdout.strip() == f"added green_cup (cup) at house > kitchen > table > green_cup to {out}"
    assert house_file.read_bytes() == before
    assert urdf_reads == [model_dir / "model.urdf"]
    smap = load_map(out)
    cup = smap.node("green_cup")
    assert isinstance(cup, SmallObject)
    assert (cup.parent, cup.relation, cup.model_ref) == ("table", "on", "models/green_cup/model.urdf")
    assert cup.properties == {"colour": "green", "material": "ceramic", "owner": "anna"}
    np.testing.assert_allclose(cup.parent_from_object.xyz, (0.1, 0.3, 0.75))
    assert [c.id for c in smap.find(type="cup", properties={"colour": "green"})] == ["green_cup"]


def test_add_large_object_in_place(house_file: Path, model_dir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(urdf_read, "load_urdf", lambda path, package_paths=(): box_model("chair", (0.4, 0.4, 0.9)))
    result = run("add", house_file, model_dir, "--id", "chair", "--parent", "kitchen", "--xyz", "1", "2", "0",
                 "--parking", "front=1 1 1.5", "--parking", "0 2 0")
    assert result.exit_code == 0, result.output
    chair = load_map(house_file).node("chair")
    assert isinstance(chair, LargeObject)
    assert [(p.name, p.default) for p in chair.parking_positions] == [("front", True), ("parking_2", False)]
    assert chair.parking_positions[0].world_from_base.rpy == (0.0, 0.0, 1.5)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--id", "chair", "--parent", "kitchen"], "exactly one default parking position, got 0"),
        (["--id", "red_cup", "--parent", "table"], "'red_cup' is already in the map"),
        (["--id", "cup_2", "--parent", "nowhere"], "no node with id 'nowhere'"),
    ],
)
def test_add_refuses_with_one_line(house_file: Path, model_dir: Path, args: list[str], message: str) -> None:
    before = house_file.read_bytes()
    result = run("add", house_file, model_dir, *args)
    assert result.exit_code == 2
    assert len(result.stderr.splitlines()) == 1 and result.stderr.startswith("error: ") and message in result.stderr
    assert house_file.read_bytes() == before


def test_add_needs_a_model_urdf(house_file: Path, tmp_path: Path) -> None:
    result = run("add", house_file, tmp_path, "--id", "cup_2", "--parent", "table")
    expected = f"error: {tmp_path}: a model folder must contain model.urdf or mobility.urdf\n"
    assert result.exit_code == 2 and result.stderr == expected


def test_bad_option_values_are_usage_errors(house_file: Path, model_dir: Path) -> None:
    result = run("add", house_file, model_dir, "--id", "c", "--parent", "table", "--parking", "1 2")
    assert result.exit_code == 2 and "'1 2' is not 'x y yaw'" in result.output
    result = run("find", house_file, "--property", "colour")
    assert result.exit_code == 2 and "'colour' is not key=value" in result.output
