"""The one way a model becomes a model folder: export (model.urdf, model.glb, meshes/), the
validation gate on what was written, and summary.json (`homemodel.core.model_summary`), all
in one atomic folder. Every pipeline, the add-on, the home builds and the database use it."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from articulation.model import Model
from articulation.scan_meshes import warnings as mesh_warnings
from homemodel.core.atomic import atomic_dir, write_json
from homemodel.core.content_hash import content_sha256
from homemodel.core.model_summary import (
    SUMMARY_FILE,
    GateCheck,
    GateResult,
    InputFile,
    ModelSummary,
    ScanMeshes,
    Source,
    failed_check_lines,
)
from homemodel.core.progress import Progress, StageClock
from homemodel.model_folder.gate.report import Check, ValidationReport


@dataclass(kw_only=True)
class PipelineSummary:
    """What the pipeline knows of its model; `write_model_folder` adds what the model and the
    gate say (extents, triangles, mass, the gate's result, export and validate times)."""

    source: Source
    figures: dict[str, Any] = field(default_factory=dict)  # the source's own, under its key
    metric: bool = True  # False: arbitrary units (no mass, no extents_m)
    times_s: dict[str, float] = field(default_factory=dict)
    inputs: Mapping[str, Path] = field(default_factory=dict)  # role -> file or folder
    warnings: list[str] = field(default_factory=list)
    meshes: ScanMeshes | None = None  # a scan's visual and collision meshes (`articulation.scan_meshes`)


@dataclass(kw_only=True)
class ModelFolder:
    path: Path
    model: Model
    validation: ValidationReport
    summary: ModelSummary

    @property
    def valid(self) -> bool:
        return self.validation.ok


def failed_checks(report: ValidationReport) -> list[str]:
    """`name: detail` of every check the model failed."""
    return failed_check_lines((c.name, c.passed, c.detail) for c in report.checks)


def report_from_summary(summary: ModelSummary, path: Path) -> ValidationReport:
    """The gate's report as summary.json recorded it (no second run of the gate)."""
    return ValidationReport(path=Path(path), checks=[Check(c.name, c.passed, c.detail) for c in summary.gate.checks])


def model_extents_m(model: Model) -> list[float]:
    """The axis-aligned size of the model's visual meshes at its zero joint configuration."""
    world_from_links = model.world_from_links()
    lows, highs = [], []
    for link in model.links:
        for visual in link.visuals:
            world_from_visual = world_from_links[link.name] @ visual.link_from_visual
            points = visual.mesh.vertices @ world_from_visual[:3, :3].T + world_from_visual[:3, 3]
            lows.append(points.min(axis=0))
            highs.append(points.max(axis=0))
    return [round(float(v), 6) for v in np.max(highs, axis=0) - np.min(lows, axis=0)]


def model_summary(model: Model, report: ValidationReport, pipeline: PipelineSummary) -> ModelSummary:
    """The summary of `model` as written and gated (`report`), with what `pipeline` adds."""
    metric = pipeline.metric
    return ModelSummary(
        name=model.name,
        kind=model.category or "",
        source=pipeline.source,
        units="m" if metric else "unscaled",
        metric=metric,
        extents_m=model_extents_m(model) if metric else None,
        links=len(model.links),
        joints=len(model.movable_joints),
        triangles=sum(len(v.mesh.faces) for link in model.links for v in link.visuals),
        # Without a scale the volume is in cubed arbitrary units: a mass from it would be made up.
        mass_kg=round(sum(link.inertial.mass_kg for link in model.links if link.inertial), 6) if metric else None,
        meshes=pipeline.meshes,
        gate=GateResult(
            valid=report.ok,
            failed_checks=failed_checks(report),
            checks=[GateCheck(name=c.name, passed=c.passed, detail=c.detail) for c in report.checks],
            warnings=[*pipeline.warnings, *(mesh_warnings(pipeline.meshes) if pipeline.meshes else [])],
        ),
        times_s={stage: round(float(s), 4) for stage, s in pipeline.times_s.items()},
        inputs=[InputFile(role=role, path=str(path), sha256=content_sha256(path)) for role, path in pipeline.inputs.items()],
        **{pipeline.source: pipeline.figures},
    )


def write_model_folder(
    model: Model,
    out_dir: Path,
    summary: PipelineSummary,
    *,
    force: bool = False,
    add_files: Callable[[Path], None] | None = None,
    progress: Progress | None = None,
) -> ModelFolder:
    """Export `model` into `out_dir`, run the gate on the written files and write summary.json,
    atomically: the folder appears whole or not at all (a model that fails the gate is still
    written, with `gate.valid` false). `add_files(tmp)` writes the pipeline's other files into
    the temporary folder after the gate and before summary.json (it may add to
    `summary.figures` and `summary.times_s`). Refuses a non-empty `out_dir` unless `force`,
    and an `out_dir` inside one of `summary.inputs`. Progress stages: export, validate."""
    from homemodel.exchange.model_files import write_model_files
    from homemodel.model_folder.gate.validate import validate_path

    out_dir = Path(out_dir)
    with atomic_dir(out_dir, force=force, inputs=list(summary.inputs.values())) as tmp:
        clock = StageClock(progress)
        clock.start("export", 1)
        write_model_files(model, tmp)
        clock.start("validate", 1)
        report = validate_path(tmp)
        report.path = out_dir  # where the files will be, not the temporary folder
        clock.stop()
        for stage, seconds in clock.times_s.items():
            summary.times_s[stage] = summary.times_s.get(stage, 0.0) + seconds
        if add_files is not None:
            add_files(tmp)
        written = model_summary(model, report, summary)
        write_json(tmp / SUMMARY_FILE, written.to_json())
    return ModelFolder(path=out_dir, model=model, validation=report, summary=written)
