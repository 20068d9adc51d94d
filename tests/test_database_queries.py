"""`homemodel db find` (names and text in any case, numbers as numbers, ranges) and
`homemodel map add db:ID` (the manifest's category and properties go into the map), through
the real command line on an index written here."""

from __future__ import annotations

from pathlib import Path

import pytest
from sample_house import cup_model
from typer.testing import CliRunner

from homemodel.app.database.index import EntryRow, ModelIndex
from homemodel.app.database.queries import PropertyCondition
from homemodel.cli import app
from homemodel.core.errors import InputError
from homemodel.exchange.model_files import export_model

runner = CliRunner()


def run(*args: object):  # noqa: ANN201
    return runner.invoke(app, [str(a) for a in args], env={"COLUMNS": "200"})


@pytest.fixture
def db(tmp_path: Path) -> Path:
    db = tmp_path / "db"
    widths = {"narrow": "0.6", "mid": "0.75", "wide": "0.8", "odd": "n/a"}
    with ModelIndex(db, create=True) as index:
        for name, width in widths.items():
            properties = {"width_m": width, "Colour": "Blue" if name != "odd" else "red"}
            index.put(EntryRow(id=name, category="Cupboard", source="spec", key="k", status="valid", properties=properties))
        export_model(cup_model(colour="white"), db / "models" / "blue_cup")
        index.put(
            EntryRow(id="blue_cup", category="mug", source="spec", key="k", status="valid", path="models/blue_cup",
                     properties={"colour": "blue", "owner": "anna"})
        )  # fmt: skip
    return db


def found(db: Path, *args: str) -> set[str]:
    result = run("db", "find", "--db", db, *args)
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    body = lines[next(i for i, line in enumerate(lines) if "─" in line) + 1 :]  # the rows under the header
    return {line.split()[0] for line in body if line.strip()}


def test_find_is_case_insensitive_numeric_and_takes_ranges(db: Path) -> None:
    assert found(db, "--property", "width_m=0.80") == {"wide"}
    assert found(db, "--property", "WIDTH_M=.8") == {"wide"}
    assert found(db, "--property", "width_m>=0.7") == {"mid", "wide"}
    assert found(db, "--property", "width_m<0.75") == {"narrow"}
    assert found(db, "--property", "width_m<=0.75", "--property", "width_m>0.6") == {"mid"}
    assert found(db, "--property", "width_m!=0.8") == {"narrow", "mid", "odd"}
    assert found(db, "--property", "colour=BLUE") == {"narrow", "mid", "wide", "blue_cup"}
    assert found(db, "--category", "cupboard", "--property", "colour=blue") == {"narrow", "mid", "wide"}
    assert found(db, "--property", "width_m=N/A") == {"odd"}
    assert found(db, "--property", "depth_m>=0") == set()


def test_a_bad_condition_is_one_line_and_exit_2(db: Path) -> None:
    for text in ("width_m>=wide", "width_m", "=3", "width_m<"):
        with pytest.raises(InputError):
            PropertyCondition.parse(text)
    result = run("db", "find", "--db", db, "--property", "width_m>=wide")
    assert result.exit_code == 2 and "a range needs a number" in result.output and "Traceback" not in result.output


def test_map_add_db_id_carries_the_manifests_category_and_properties(db: Path, tmp_path: Path) -> None:
    from homemodel.exchange.map_xml import load_map, save_map
    from semantic_map import SemanticMap

    smap = SemanticMap.new(apartment_id="flat", name="Flat")
    smap.add_room(room_id="kitchen", name="Kitchen")
    save_map(smap, tmp_path / "map.xml")
    added = run("map", "add", tmp_path / "map.xml", "db:blue_cup", "--db", db, "--id", "cup_1", "--parent", "kitchen",
                "--parking", "1 0 0", "--property", "owner=ben")  # fmt: skip
    assert added.exit_code == 0, added.output
    node = load_map(tmp_path / "map.xml").node("cup_1")
    assert node.type == "mug"  # the manifest's category, not the model's "cup"
    assert node.properties["colour"] == "blue"  # the manifest's, over the model's white
    assert node.properties["owner"] == "ben"  # the command line's, over the manifest's
    # A plain folder keeps the model's own category and properties.
    plain = run("map", "add", tmp_path / "map.xml", db / "models" / "blue_cup", "--id", "cup_2", "--parent", "kitchen",
                "--parking", "1 0 0")
    assert plain.exit_code == 0, plain.output
    other = load_map(tmp_path / "map.xml").node("cup_2")
    assert other.type == "cup" and other.properties["colour"] == "white"
