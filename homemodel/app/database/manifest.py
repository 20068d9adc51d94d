"""The manifest of a model-database build (`homemodel db build MANIFEST.yaml`): which
entries to build, from what source, with what options, and what the map should know of them.

```yaml
entries:
  - {id: cup_white, source: spec, path: ../catalogue/cup.yaml, properties: {colour: white}}
  - id: cupboard                    # a sweep: one entry per combination, ids cupboard_0 ...
    source: spec
    path: ../catalogue/cupboard.yaml
    sweep: {width_m: [1.0, 1.2], doors: [[...], [...]]}
  - {id: mug_scan, source: turntable, path: captures/mug, options: {texture_size_px: 512}}
  - {id: kermit, source: photos, path: /data/kermit, marker_size_m: 0.05}
  - {id: cup_query, source: completion, path: query/depth.png, camera: query/camera.yaml,
     completion_model: completer.npz}
  - {id: cabinet_46037, source: urdf, path: partnet/46037}   # a model folder, a .urdf or a mesh file
  - {id: arm, source: urdf, path: ros/arm_description/urdf/arm.urdf,
     options: {package_paths: [ros]}}   # where package://NAME/... finds other ROS packages
  - {id: cabinet_7128, source: urdf, path: partnet/7128, repair: true}   # see RepairSpec
```

Paths are relative to the manifest's folder. `options` mirrors the source's options class
(`modeller.BuildOptions`, `turntable.ReconstructOptions`, `photogrammetry.ReconstructOptions`,
`shape_completion.CompletionOptions`, `homemodel.model_folder.asset_import.ImportOptions`), nested ones
included (`options: {sfm: {max_num_features: 8192}}` sets that one field of the sfm options);
it is checked field by field when the manifest is read (`entries.3.options.sfm...: problem`).
The fields the entry itself decides (the model's name is its id; a photos entry's
`marker_size_m`, a completion entry's `camera`) are not options. A swept field is a top-level
field of the spec, and its values are recorded as the entry's properties.
"""

from __future__ import annotations

import itertools
import json
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from homemodel.core.errors import InputError, SpecError
from homemodel.core.options_data import options_from_dict
from homemodel.core.yaml_specs import load_yaml_spec

# An entry's id names its folder, its model and its map object: a safe file stem.
ENTRY_ID_PATTERN = r"^[A-Za-z_][A-Za-z0-9_]*$"
Source = Literal["spec", "turntable", "photos", "completion", "urdf"]
SOURCES: tuple[str, ...] = ("spec", "turntable", "photos", "completion", "urdf")
MAX_SWEEP_ENTRIES = 10_000


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class EntrySpec(_Strict):
    id: str = Field(pattern=ENTRY_ID_PATTERN)
    source: Source
    path: str = Field(min_length=1, description="spec file, capture folder, photo folder, depth image, URDF or model folder")
    camera: str | None = None  # completion: the query's camera.yaml (default: beside the depth image)
    completion_model: str | None = None  # completion: a model file from `homemodel completion train`
    marker_size_m: float | None = Field(default=None, gt=0)  # photos: the markers' black-square edge
    repair: bool = False  # urdf: fill in what the gate needs (the manifest's `repair` settings), as --repair does
    options: dict[str, Any] = Field(default_factory=dict)
    sweep: dict[str, list[Any]] = Field(default_factory=dict)
    category: str | None = None  # over the model's own
    properties: dict[str, str] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _fields_of_source(self) -> EntrySpec:
        if self.source == "completion" and self.completion_model is None:
            raise ValueError("a completion entry needs completion_model (a model file from `homemodel completion train`)")
        if self.source != "completion" and (self.completion_model is not None or self.camera is not None):
            raise ValueError("camera and completion_model belong to completion entries")
        if self.source != "photos" and self.marker_size_m is not None:
            raise ValueError("marker_size_m belongs to photos entries")
        if self.repair and self.source != "urdf":
            raise ValueError("repair belongs to urdf entries (imported assets)")
        if self.sweep and self.source != "spec":
            raise ValueError("only spec entries can sweep values")
        if any(not values for values in self.sweep.values()):
            raise ValueError("every swept field needs at least one value")
        return self


class RepairSpec(_Strict):
    """What `--repair` fills in, stated here so every repair says what it assumed."""

    density_kg_m3: float = Field(default=500.0, gt=0)
    voxel_size_m: float = Field(default=0.01, gt=0)  # open sheets voxel-filled at this size, so this thick
    default_mass_kg: float = Field(default=1.0, gt=0)  # a link with no surface to measure
    default_size_m: float = Field(default=0.1, gt=0)
    effort: float = Field(default=10.0, gt=0)
    velocity: float = Field(default=1.0, gt=0)


class ManifestSpec(_Strict):
    entries: list[EntrySpec] = Field(min_length=1)
    repair: RepairSpec = RepairSpec()


@dataclass(kw_only=True)
class Job:
    """One entry to build, as a worker gets it: paths absolute, a sweep's values applied."""

    id: str
    source: str
    inputs: dict[str, Path]  # role -> file or folder: path, camera, completion_model
    options: dict[str, Any] = field(default_factory=dict)
    overrides: dict[str, Any] = field(default_factory=dict)  # spec fields a sweep sets
    marker_size_m: float | None = None
    repair: bool = False  # the manifest asks to repair this imported asset
    category: str | None = None
    properties: dict[str, str] = field(default_factory=dict)

    def settings(self) -> str:
        """Everything but the input files that decides what is built, as canonical JSON."""
        return json.dumps(
            {"source": self.source, "options": self.options, "overrides": self.overrides, "marker_size_m": self.marker_size_m},
            sort_keys=True,
            default=str,
        )


def _inputs(entry: EntrySpec, folder: Path, manifest: Path, index: int) -> dict[str, Path]:
    roles = {"path": entry.path, "camera": entry.camera, "completion_model": entry.completion_model}
    inputs = {}
    for role, value in roles.items():
        if value is None:
            continue
        path = (folder / value).resolve()
        if not path.exists():
            raise SpecError(f"{manifest}: entries.{index}.{role}: no such file or folder {value!r}")
        inputs[role] = path
    if entry.source == "completion" and "camera" not in inputs:
        inputs["camera"] = inputs["path"].parent / "camera.yaml"
    return inputs


# source -> (module, options class); imported only when an entry of that source sets options.
OPTIONS_CLASSES = {
    "spec": ("modeller.build", "BuildOptions"),
    "turntable": ("turntable.reconstruct", "ReconstructOptions"),
    "photos": ("photogrammetry.pipeline", "ReconstructOptions"),
    "completion": ("shape_completion.model_export", "CompletionOptions"),
    "urdf": ("homemodel.model_folder.asset_import", "ImportOptions"),
}
# Options fields the entry decides: the build sets them, so `options` may not.
ENTRY_FIELDS = {
    "name": "the entry's id names the model",
    "workers": "the database gives each entry one worker process",
    "camera_path": "set by the entry's `camera`",
    "map_entry": "add models to a map with `homemodel map add db:ID`",
}


def options_class(source: str) -> type:
    import importlib

    module, name = OPTIONS_CLASSES[source]
    return getattr(importlib.import_module(module), name)


def _checked_options(entry: EntrySpec, where: str) -> None:
    """Refuse what the source's options class would not take, field by field (before any
    build starts), and the fields the entry decides."""
    for name, why in ENTRY_FIELDS.items():
        if name in entry.options:
            raise InputError(f"{where}.{name}: not an option here ({why})")
    if entry.marker_size_m is not None and "marker_size_m" in entry.options:
        raise InputError(f"{where}.marker_size_m: given twice (the entry's marker_size_m and its options')")
    options_from_dict(options_class(entry.source), entry.options, where=where)


def _options_with_paths(entry: EntrySpec, folder: Path) -> dict[str, Any]:
    """The entry's options with an import's package paths made absolute (relative to the
    manifest's folder, as every path in it is)."""
    options = dict(entry.options)
    if entry.source == "urdf" and isinstance(options.get("package_paths"), list):
        options["package_paths"] = [str((folder / p).resolve()) for p in options["package_paths"]]
    return options


def _sweep_combinations(sweep: dict[str, list[Any]]) -> list[dict[str, Any]]:
    names = sorted(sweep)
    return [dict(zip(names, values)) for values in itertools.product(*(sweep[n] for n in names))]


def _property_text(value: Any) -> str:
    return value if isinstance(value, str) else json.dumps(value, sort_keys=True)


def load_manifest(path: Path) -> tuple[list[Job], RepairSpec]:
    """The jobs of the manifest at `path` (sweeps expanded) and its repair settings; raises
    SpecError naming the file and the field for a bad manifest, a missing input or an id
    given twice."""
    path = Path(path)
    spec = load_yaml_spec(path, ManifestSpec)
    folder = path.resolve().parent
    jobs: list[Job] = []
    for index, entry in enumerate(spec.entries):
        inputs = _inputs(entry, folder, path, index)
        if entry.options:
            try:
                _checked_options(entry, f"entries.{index}.options")
            except InputError as exc:
                raise SpecError(f"{path}: {exc}") from None
        combinations = _sweep_combinations(entry.sweep) if entry.sweep else [{}]
        if len(jobs) + len(combinations) > MAX_SWEEP_ENTRIES:
            raise SpecError(f"{path}: entries.{index}.sweep: over {MAX_SWEEP_ENTRIES} entries in one manifest")
        for n, overrides in enumerate(combinations):
            jobs.append(
                Job(
                    id=f"{entry.id}_{n}" if entry.sweep else entry.id,
                    source=entry.source,
                    inputs=inputs,
                    options=_options_with_paths(entry, folder),
                    overrides=overrides,
                    marker_size_m=entry.marker_size_m,
                    repair=entry.repair,
                    category=entry.category,
                    properties={**entry.properties, **{k: _property_text(v) for k, v in overrides.items()}},
                )
            )
    repeated = sorted(i for i, n in Counter(job.id for job in jobs).items() if n > 1)
    if repeated:
        raise SpecError(f"{path}: entries: ids must be unique (sweeps add _0, _1, ...), repeated: {repeated}")
    return jobs, spec.repair
