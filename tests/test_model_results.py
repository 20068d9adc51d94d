"""Every pipeline entry returns one result type (`homemodel.model_folder.result.ModelResult`: the
summary, the map entry asked for and the registration; tests/test_cli_options.py checks each
entry's annotation), and each pipeline's own figures in summary.json are typed: a model per
source, published in the schema."""

from __future__ import annotations

import json
from pathlib import Path

from homemodel.core.model_summary import SOURCES, ModelSummary, schema_path, summary_schema
from homemodel.model_folder.result import ModelResult


def test_a_result_without_a_map_entry_registers_nothing(tmp_path: Path) -> None:
    result = ModelResult()
    result.register(tmp_path / "not_a_model_folder", None)  # no map asked for: nothing read or written
    assert result.map_entry is None and result.registration is None and not any(tmp_path.iterdir())


def test_each_source_has_its_figures_model_in_the_published_schema() -> None:
    schema = json.loads(schema_path().read_text())
    assert schema == summary_schema()
    for source in SOURCES:
        ref = next(option["$ref"] for option in schema["properties"][source]["anyOf"] if "$ref" in option)
        figures = schema["$defs"][ref.rsplit("/", 1)[1]]
        assert figures["type"] == "object" and figures["additionalProperties"] is False, source
    assert {"frames_used", "orbit", "tags_per_frame"} <= set(schema["$defs"]["TurntableFigures"]["properties"])
    assert "class" in schema["$defs"]["CompletionFigures"]["properties"]


def test_a_summary_keeps_exactly_the_figures_its_pipeline_gave() -> None:
    """Figures left out stay out of summary.json; those given as null stay null."""
    common = {
        "name": "cup", "kind": "", "source": "turntable", "units": "m", "metric": True, "extents_m": [0.1, 0.1, 0.1],
        "links": 1, "joints": 0, "triangles": 12, "mass_kg": 0.1,
        "gate": {"valid": True, "failed_checks": [], "checks": []}, "times_s": {}, "inputs": [],
    }  # fmt: skip
    figures = {"frames_used": 3, "turntable_refinement": None, "orbit": {"radius_m": 0.2, "circle_rms_m": 0.001,
               "axis_xy_m": [0.0, 0.01], "axis_tilt_deg": 0.3, "axis_spread_m": 0.002}}  # fmt: skip
    summary = ModelSummary.model_validate({**common, "turntable": figures})
    assert summary.turntable.orbit.axis_xy_m == [0.0, 0.01] and summary.turntable.frames_total is None
    assert summary.to_json()["turntable"] == figures
    assert ModelSummary.model_validate(summary.to_json()) == summary
