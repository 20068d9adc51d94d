"""The model contract: one summary schema (published as JSON Schema, kept in step with the
pydantic model) and one model-folder writer (export, gate, summary.json, atomically); the other
summary files (a home's, a simulator export's) have names and published schemas of their own."""

from __future__ import annotations

import hashlib
import json
import runpy
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
import trimesh
from model_summaries import schema_problems, unchecked_summary_problems, validator

from articulation.scan_model import scan_model
from homemodel.core.errors import InputError, OutputExistsError
from homemodel.core.home_summary import object_row, write_home_summary
from homemodel.core.model_summary import ModelSummary, read_summary
from homemodel.core.summary_files import SUMMARY_SCHEMAS
from homemodel.model_folder.write import PipelineSummary, report_from_summary, write_model_folder

REPO = Path(__file__).resolve().parents[1]


def _box_model(name: str = "box"):
    return scan_model(trimesh.creation.box(extents=(0.2, 0.1, 0.3)), name=name, density_kg_m3=500.0, category="box")


@pytest.fixture
def outside_basetemp() -> Iterator[Path]:
    """A folder the suite's net (conftest) does not look in, for a summary broken on purpose."""
    with tempfile.TemporaryDirectory() as folder:
        yield Path(folder)


def test_the_published_schemas_are_the_ones_the_models_generate():
    schema_text = runpy.run_path(str(REPO / "tools" / "write_summary_schema.py"))["schema_text"]
    assert [p.file_name for p in SUMMARY_SCHEMAS] == ["summary.json", "home_summary.json", "export_summary.json"]
    assert len({p.path() for p in SUMMARY_SCHEMAS}) == len({p.schema()["$id"] for p in SUMMARY_SCHEMAS}) == 3
    for published in SUMMARY_SCHEMAS:
        assert published.path().read_text() == schema_text(published), "stale: run .venv/bin/python tools/write_summary_schema.py"


def test_a_written_folder_holds_the_model_its_gate_result_and_figures_from_ground_truth(tmp_path: Path):
    spec = tmp_path / "input.yaml"
    spec.write_text("kind: box\n")
    out = tmp_path / "out"
    written = write_model_folder(
        _box_model(),
        out,
        PipelineSummary(source="turntable", figures={"frames_used": 3}, times_s={"merge": 1.5}, inputs={"capture": spec}),
    )
    assert {"model.urdf", "model.glb", "summary.json"} <= {p.name for p in out.iterdir()}
    data = json.loads((out / "summary.json").read_text())
    assert schema_problems(out / "summary.json") == []
    assert data["name"] == "box" and data["kind"] == "box" and data["source"] == "turntable"
    assert data["metric"] is True and data["units"] == "m"
    assert data["extents_m"] == pytest.approx([0.2, 0.1, 0.3], abs=1e-6)
    assert data["mass_kg"] == pytest.approx(500.0 * 0.2 * 0.1 * 0.3, rel=1e-3)
    assert data["triangles"] == 12 and data["links"] == 1 and data["joints"] == 0
    assert data["gate"]["valid"] is True and data["gate"]["failed_checks"] == [] and len(data["gate"]["checks"]) >= 5
    assert set(data["times_s"]) == {"merge", "export", "validate"} and data["times_s"]["merge"] == 1.5
    assert data["inputs"] == [{"role": "capture", "path": str(spec), "sha256": hashlib.sha256(b"kind: box\n").hexdigest()}]
    assert data["turntable"] == {"frames_used": 3} and "modeller" not in data
    assert read_summary(out) == written.summary
    assert report_from_summary(written.summary, out).format() == written.validation.format()


def test_an_unscaled_model_has_no_size_or_mass(tmp_path: Path):
    written = write_model_folder(_box_model(), tmp_path / "out", PipelineSummary(source="photogrammetry", metric=False))
    assert written.summary.units == "unscaled" and written.summary.extents_m is None and written.summary.mass_kg is None
    assert schema_problems(tmp_path / "out" / "summary.json") == []


def test_the_folder_appears_whole_or_not_at_all(tmp_path: Path):
    out = tmp_path / "out"

    def fail(folder: Path) -> None:
        (folder / "half.txt").write_text("half")
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError):
        write_model_folder(_box_model(), out, PipelineSummary(source="blender"), add_files=fail)
    assert not out.exists() and list(tmp_path.iterdir()) == []
    write_model_folder(_box_model(), out, PipelineSummary(source="blender"))
    with pytest.raises(OutputExistsError):
        write_model_folder(_box_model(), out, PipelineSummary(source="blender"))


def _good() -> dict:
    return {
        "schema_version": 1, "name": "mug", "kind": "mug", "source": "completion", "units": "m", "metric": True,
        "extents_m": [0.1, 0.1, 0.12], "links": 1, "joints": 0, "triangles": 100, "mass_kg": 0.3,
        "gate": {"valid": True, "failed_checks": [], "checks": [], "warnings": []},
        "times_s": {"export": 0.1}, "inputs": [], "completion": {"class": "mug"},
    }  # fmt: skip


@pytest.mark.parametrize(
    "change",
    [
        {"metric": False, "units": "unscaled"},  # an unscaled model with a size and a mass
        {"units": "unscaled"},
        {"turntable": {"frames_used": 3}},  # figures under another source's key
        {"extent_m": [1, 1, 1]},  # the old spellings are refused
        {"completion": {"class": "mug", "klass": "mug"}},  # a figure the source's model does not name
        {"completion": {"class": "mug", "query_points": "many"}},  # a figure of the wrong type
        {"completion": {"class": "mug", "revolution_axis": {"point_m": [0, 0]}}},  # a nested figure's shape
        {"schema_version": 2},
        {"links": 0},
    ],
)
def test_both_the_json_schema_and_the_model_refuse_drifted_summaries(outside_basetemp: Path, change: dict):
    assert list(validator().iter_errors(_good())) == [] and ModelSummary.model_validate(_good())
    bad = {**_good(), **change}
    assert list(validator().iter_errors(bad)), f"the JSON Schema accepts {change}"
    path = outside_basetemp / "summary.json"
    path.write_text(json.dumps(bad))
    with pytest.raises(InputError, match=r"summary\.json: "):
        read_summary(outside_basetemp)


def test_a_figure_written_as_nan_is_not_json(outside_basetemp: Path):
    path = outside_basetemp / "summary.json"
    path.write_text(json.dumps({**_good(), "completion": {"class": "mug", "fit_distance_m": float("nan")}}))
    (problem,) = schema_problems(path)
    assert "NaN is not JSON" in problem and list(validator().iter_errors(json.loads(path.read_text()))) == []  # the schema alone passes it


def test_the_suite_s_net_checks_each_folder_once_session_fixtures_included():
    """conftest's module fixture checks every new basetemp folder, also one a session fixture made
    before the module's first test (a difference taken around the module missed those)."""
    with tempfile.TemporaryDirectory() as base:  # not under basetemp: the net would see the broken file
        made_by_a_session_fixture = Path(base) / "kitchen0" / "models" / "cup"
        write_model_folder(_box_model("cup"), made_by_a_session_fixture, PipelineSummary(source="modeller"))
        summary = made_by_a_session_fixture / "summary.json"
        summary.write_text(summary.read_text().replace('"source": "modeller"', '"source": "modeler"'))
        (Path(base) / "kitchencurrent").symlink_to(Path(base) / "kitchen0")  # pytest's link to the newest
        assert [p.split(": ", 2)[1] for p in unchecked_summary_problems(Path(base))] == ["source"]
        (Path(base) / "test_x0").mkdir()
        assert unchecked_summary_problems(Path(base)) == []  # the kitchen is not reported again


def test_the_suite_s_net_checks_each_summary_file_against_the_schema_of_its_name(outside_basetemp: Path):
    """summary.json is a model folder's wherever it is: a home's table of objects under that name
    (what `homemodel build` wrote before home_summary.json) is refused; home_summary.json and
    export_summary.json are checked against their own schemas."""
    box = write_model_folder(_box_model("cup"), outside_basetemp / "models" / "cup", PipelineSummary(source="modeller"))
    home = outside_basetemp / "home0"
    write_home_summary(home, [object_row(box.summary, id="cup", spec="cup.yaml", parent="kitchen", grasp_points=2)])
    rows = json.loads((home / "home_summary.json").read_text())
    assert rows["objects"][0]["triangles"] == 12 and rows["objects"][0]["category"] == "box"
    (home / "summary.json").write_text(json.dumps(rows["objects"]))
    (home / "export_summary.json").write_text(json.dumps({**rows, "format": "glb"}))
    problems = unchecked_summary_problems(outside_basetemp)
    assert {p.split(": ", 1)[0] for p in problems} == {str(home / "summary.json"), str(home / "export_summary.json")}
    (not_a_model,) = [p for p in problems if p.startswith(f"{home / 'summary.json'}: ")]
    assert not_a_model.startswith(f"{home / 'summary.json'}: summary: [{{'id': 'cup'") and not_a_model.endswith("is not of type 'object'")
    assert f"{home / 'export_summary.json'}: summary: 'file' is a required property" in problems
    assert schema_problems(home / "home_summary.json") == []
