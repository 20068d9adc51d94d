"""Every pipeline entry returns one result type (`semantic_map.model_result.ModelResult`: the
summary, the map entry asked for and the registration), and each pipeline's own figures in
summary.json are typed: a model per source, published in the schema."""

from __future__ import annotations

import importlib
import inspect
from pathlib import Path

import pytest

from homemodel.core.model_summary import ModelSummary
from semantic_map.model_result import ModelResult

ENTRIES = [
    ("modeller", "build"),
    ("turntable", "reconstruct"),
    ("photogrammetry", "reconstruct"),
    ("shape_completion", "complete"),
]


@pytest.mark.parametrize("package, entry", ENTRIES)
def test_every_entry_returns_a_model_result(package: str, entry: str) -> None:
    function = getattr(importlib.import_module(package), entry)
    annotation = inspect.signature(function).return_annotation
    result_class = eval(annotation, function.__globals__) if isinstance(annotation, str) else annotation  # noqa: S307
    assert issubclass(result_class, ModelResult)
    names = {f for f in ("summary", "map_entry", "registration") if f in result_class.__dataclass_fields__}
    assert names == {"summary", "map_entry", "registration"}
    assert all(result_class.__dataclass_fields__[n].default is None for n in names)


def test_the_modeller_result_keeps_its_map_entry(tmp_path: Path, house_file: Path, kitchen_dir: Path) -> None:
    from modeller import BuildOptions, build
    from semantic_map import MapEntry

    entry = MapEntry(map_path=house_file, object_id="green_cup", parent_id="table")
    built = build(kitchen_dir / "blue_cup.yaml", tmp_path / "cup", BuildOptions(map_entry=entry))
    assert built.map_entry is entry and built.registration.path[-1] == "green_cup"
    alone = build(kitchen_dir / "blue_cup.yaml", tmp_path / "alone", BuildOptions())
    assert alone.map_entry is None and alone.registration is None and isinstance(alone.summary, ModelSummary)
