"""home_summary.json: a home's table of objects, one row per model folder under `models/`,
written by `homemodel build` and by the add-on's home export (`homemodel addon export-home`)
in this one shape, published as `homemodel/schemas/home_summary.schema.json`. Each object's
own figures are in its model folder's summary.json (`homemodel.core.model_summary`)."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from homemodel.core.atomic import write_json
from homemodel.core.model_summary import ModelSummary
from homemodel.core.published_schema import PublishedSchema

SCHEMA_VERSION = 1
HOME_SUMMARY_FILE = "home_summary.json"


class ObjectRow(BaseModel):
    """One object of the home: the figures the CLI's table prints."""

    model_config = ConfigDict(extra="forbid")

    id: str = Field(min_length=1, description="the object's id in map.xml and its folder under models/")
    category: str = Field(description="the model's kind (cabinet, mug, ...); empty when unknown")
    spec: str = Field(description="the file it was built from, relative to the input: a measurement spec or the add-on's model document")
    parent: str = Field(description="the room of a large object, the large object a small one is in or on")
    links: int = Field(ge=1)
    joints: int = Field(ge=0, description="movable joints")
    grasp_points: int = Field(ge=0)
    triangles: int = Field(ge=0, description="of the visual meshes")
    valid: bool = Field(description="the gate's verdict on the written model folder")
    times_s: dict[str, float] = Field(description="seconds per stage (build, export, validate)")
    failed_checks: list[str] = Field(default_factory=list, description="`name: detail` of every failed gate check")
    warnings: list[str] = Field(default_factory=list, description="what its build and its gate doubt without failing")
    cached: bool = Field(default=False, description="reused from the earlier output: its input and the code are unchanged")


class HomeSummary(BaseModel):
    """What a home's home_summary.json holds."""

    model_config = ConfigDict(extra="forbid")

    schema_version: Literal[1] = SCHEMA_VERSION
    objects: list[ObjectRow]


HOME_SUMMARY = PublishedSchema(HOME_SUMMARY_FILE, HomeSummary, "home_summary", SCHEMA_VERSION)


def _warnings(summary: ModelSummary) -> list[str]:
    """The build's warnings (a door's readings against its thickness) and each gate check's
    (a hinge line rubbing within its tolerance), which a check appends as "; WARNING ..."."""
    said = list(summary.gate.warnings)
    for check in summary.gate.checks:
        said += [f"{check.name}: {part}" for part in check.detail.split("; WARNING ")[1:]]
    return said


def object_row(summary: ModelSummary, *, id: str, spec: str, parent: str, grasp_points: int, cached: bool = False) -> ObjectRow:  # noqa: A002 (the row's field)
    """The row of the object whose model folder's summary is `summary`."""
    return ObjectRow(
        id=id,
        category=summary.kind,
        spec=spec,
        parent=parent,
        links=summary.links,
        joints=summary.joints,
        grasp_points=grasp_points,
        triangles=summary.triangles,
        valid=summary.gate.valid,
        times_s={stage: round(seconds, 3) for stage, seconds in summary.times_s.items()},
        failed_checks=summary.gate.failed_checks,
        warnings=_warnings(summary),
        cached=cached,
    )


def write_home_summary(out_dir: Path, rows: list[ObjectRow]) -> Path:
    """`out_dir/home_summary.json` (atomically, as every file of the output folder)."""
    path = Path(out_dir) / HOME_SUMMARY_FILE
    write_json(path, HomeSummary(objects=rows).model_dump(mode="json"))
    return path
