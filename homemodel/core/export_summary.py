"""export_summary.json: what a simulator export (`homemodel map export`, `homemodel export`)
wrote: its format, the scene file, the objects with their joints' positions, walls, floor and
mesh files, published as `homemodel/schemas/simulator_export.schema.json`."""

from __future__ import annotations

from typing import Literal, get_args

from pydantic import BaseModel, ConfigDict, Field

from homemodel.core.published_schema import PublishedSchema

SCHEMA_VERSION = 1
EXPORT_SUMMARY_FILE = "export_summary.json"

SceneFormat = Literal["urdf", "mjcf", "sdf", "usd", "glb"]
ModelFormat = Literal["mjcf", "sdf", "usd", "urdf-ros"]
SCENE_FORMATS: tuple[str, ...] = get_args(SceneFormat)
MODEL_FORMATS: tuple[str, ...] = get_args(ModelFormat)


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class ExportedObject(_Strict):
    id: str = Field(min_length=1, description="the object's id in the map (the model's name for one model)")
    model: str = Field(description="the model's name")
    free: bool = Field(description="a body the simulator may move (not fixed where the map puts it)")
    links: int = Field(ge=1)
    joints: dict[str, float] = Field(description="each movable joint's name in the scene file and its position (rad or m)")


class ExportSummary(_Strict):
    """What a simulator export's export_summary.json holds."""

    schema_version: Literal[1] = SCHEMA_VERSION
    format: SceneFormat | ModelFormat
    file: str = Field(description="the scene file (a ROS package's URDF), relative to the export folder")
    package: str | None = Field(default=None, description="the ROS 2 package's name (urdf-ros), else null")
    objects: list[ExportedObject]
    walls: int = Field(ge=0)
    floor: bool
    mesh_files: int = Field(ge=0, description="OBJ files under meshes/")
    times_s: dict[str, float]


EXPORT_SUMMARY = PublishedSchema(EXPORT_SUMMARY_FILE, ExportSummary, "simulator_export", SCHEMA_VERSION)
