"""Build a home: every measurement spec of an example folder becomes a validated model
folder, and all of them are registered into one semantic map.

Output layout (all written atomically: the folder appears whole or not at all):
    OUT/map.xml                       the hierarchical semantic map
    OUT/home_summary.json             one row per object, the figures the CLI prints
    OUT/models/<id>/model.urdf|.glb   the exports, meshes/ beside them
    OUT/models/<id>/model.blend       the Blender scene, for an installer to refine
    OUT/models/<id>/summary.json      that object's figures and validation report

Each object is built by the modeller's entry, `modeller.build`. A rebuild over an earlier
output (`--force`) reuses each object whose content key (the model database's: its spec's
bytes, its name and the code that builds it) is unchanged, as `homemodel db build` does.
"""

from __future__ import annotations

import logging
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from homemodel.app.database.content_key import spec_content_key
from homemodel.app.home.spec import (
    HomeSpec,
    LargeObjectSpec,
    PoseSpec,
    RunSpec,
    SmallObjectSpec,
)
from homemodel.core.atomic import atomic_dir, write_text_atomic
from homemodel.core.errors import InputError, SpecError
from homemodel.core.home_summary import ObjectRow, object_row, write_home_summary
from homemodel.core.input_files import confined_path
from homemodel.core.interrupts import raise_if_interrupted
from homemodel.core.limits import HOME_OBJECTS
from homemodel.core.model_summary import read_summary
from homemodel.core.progress import Progress
from homemodel.core.yaml_specs import load_yaml_spec

log = logging.getLogger(__name__)

HOME_FILE = "home.yaml"
# A small object "on" a surface must stand on it: its base within this of the parent's top.
ON_SURFACE_TOLERANCE_M = 0.005
KEY_FILE = "content_key.txt"


@dataclass(kw_only=True)
class BuildResult:
    out_dir: Path
    map_path: Path
    rows: list[ObjectRow]

    @property
    def ok(self) -> bool:
        return all(row.valid for row in self.rows)


def load_home(example_dir: Path) -> HomeSpec:
    example_dir = Path(example_dir)
    if not example_dir.is_dir():
        raise SpecError(f"{example_dir}: no such folder")
    return load_yaml_spec(example_dir / HOME_FILE, HomeSpec)


def _placements(home: HomeSpec, example_dir: Path):
    """(field path, room, large object, small object or None) for every object, in build
    order; the units and worktops of runs come placed (see `_placed_run`)."""
    for r, room in enumerate(home.rooms):
        larges = [(f"rooms.{r}.objects.{o}", large) for o, large in enumerate(room.objects)]
        for k, run in enumerate(room.runs):
            larges += _placed_run(run, f"rooms.{r}.runs.{k}", example_dir)
        for field_path, large in larges:
            yield field_path, room, large, None
            for s, small in enumerate(large.objects):
                yield f"{field_path}.objects.{s}", room, large, small


def _placed_run(run: RunSpec, field_path: str, example_dir: Path) -> list[tuple[str, LargeObjectSpec]]:
    """The run's units (cabinet kinds) and worktop with their poses in the map frame, from
    their specs' sizes; a unit standing higher than the worktop's underside is refused."""
    from modeller import load_spec
    from modeller.specs import WorktopSpec
    from modeller.specs.cabinets import CabinetSpec

    home_file = example_dir / HOME_FILE
    world_from_run = run.pose.matrix()
    placed, left, tops = [], run.left_m, []

    def place(member_path: str, large: LargeObjectSpec, centre: tuple[float, float, float]) -> None:
        xyz = world_from_run @ np.array([*centre, 1.0])
        pose = PoseSpec(xyz=tuple(float(v) for v in xyz[:3]), rpy_deg=run.pose.rpy_deg)
        placed.append((member_path, large.model_copy(update={"pose": pose})))

    for u, unit in enumerate(run.units):
        unit_path = f"{field_path}.units.{u}"
        spec = load_spec(_spec_path(example_dir, home_file, unit_path, unit.spec))
        if not isinstance(spec, CabinetSpec):
            raise SpecError(f"{home_file}: {unit_path}.spec: a {spec.kind} is not a unit to stand in a run")
        place(unit_path, unit, (spec.depth_m / 2, left + spec.width_m / 2, 0.0))
        left += spec.width_m + run.gap_m
        tops.append((unit_path, spec.top_m))
    if run.worktop is not None:
        top_path = f"{field_path}.worktop"
        spec = load_spec(_spec_path(example_dir, home_file, top_path, run.worktop.spec))
        if not isinstance(spec, WorktopSpec):
            raise SpecError(f"{home_file}: {top_path}.spec: a {spec.kind} is not a worktop")
        underside = spec.height_m - spec.thickness_m
        for unit_path, top in tops:
            if top > underside + ON_SURFACE_TOLERANCE_M:
                raise SpecError(
                    f"{home_file}: {unit_path}: the unit's top at {top:.3f} m is above the worktop's "
                    f"underside at {underside:.3f} m"
                )
        place(top_path, run.worktop, (spec.depth_m / 2, run.worktop_left_m + spec.width_m / 2, 0.0))
    return placed


def _spec_path(example_dir: Path, home_file: Path, field_path: str, spec: str) -> Path:
    try:
        path = confined_path(example_dir, spec, folder_role="example folder")
    except InputError as exc:
        raise SpecError(f"{home_file}: {field_path}.spec: {exc}") from None
    if not path.is_file():
        raise SpecError(f"{home_file}: {field_path}.spec: no such file {spec!r}")
    return path


def _check_on_surface(home_file: Path, field_path: str, small: SmallObjectSpec, parent_top_m: float) -> None:
    if small.relation == "on" and abs(small.pose.xyz[2] - parent_top_m) > ON_SURFACE_TOLERANCE_M:
        raise SpecError(
            f"{home_file}: {field_path}.pose.xyz: z = {small.pose.xyz[2]:.3f} m but its parent's top "
            f"is at {parent_top_m:.3f} m; an object 'on' a surface must stand on it"
        )


def _parking_positions(large: LargeObjectSpec, parking_type: type) -> list:
    """The spec's parking positions; the first is the default unless one says it is."""
    default = next((p.name for p in large.parking if p.default), large.parking[0].name)
    return [parking_type(name=p.name, world_from_base=p.matrix(), default=p.name == default) for p in large.parking]


def _cached_object(previous: Path, key: str, folder: Path):  # noqa: ANN202 (a Model and its summary, or None)
    """The earlier output's model of this object, copied into `folder`, if its key matches."""
    from homemodel.exchange.urdf.read import load_urdf

    key_file = previous / KEY_FILE
    if not (key_file.is_file() and key_file.read_text() == key):
        return None
    try:
        summary = read_summary(previous)
    except InputError:  # absent, or written before the summary's schema: build it again
        return None
    shutil.copytree(previous, folder)
    return load_urdf(folder / "model.urdf"), summary


def build_home(example_dir: Path, out_dir: Path, *, force: bool = False, progress: Progress | None = None) -> BuildResult:
    """Build, export, validate and register every object of `example_dir/home.yaml`."""
    from homemodel.exchange.map_xml import save_map
    from modeller import BuildOptions, build, load_spec
    from semantic_map import ParkingPosition, SemanticMap

    example_dir = Path(example_dir)
    home_file = example_dir / HOME_FILE
    home = load_home(example_dir)
    placements = list(_placements(home, example_dir))
    HOME_OBJECTS.check(home_file, len(placements))
    # Every spec is checked before anything is built, so a typo fails in a second, not a minute.
    spec_paths = {}
    for field_path, _, large, small in placements:
        obj = small or large
        spec_paths[obj.id] = _spec_path(example_dir, home_file, field_path, obj.spec)
        load_spec(spec_paths[obj.id])

    for r, room in enumerate(home.rooms):
        if room.point_cloud is not None:
            try:
                confined_path(example_dir, room.point_cloud, folder_role="example folder")
            except InputError as exc:
                raise SpecError(f"{home_file}: rooms.{r}.point_cloud: {exc}") from None
    smap = SemanticMap.new(apartment_id=home.apartment.id, name=home.apartment.name)
    for room in home.rooms:
        smap.add_room(room_id=room.id, name=room.name, point_cloud=room.point_cloud, outline=room.outline)

    rows: list[ObjectRow] = []
    tops: dict[str, float] = {}
    with atomic_dir(Path(out_dir), force=force, inputs=[example_dir]) as tmp:
        for index, (field_path, room, large, small) in enumerate(placements):
            obj: LargeObjectSpec | SmallObjectSpec = small or large
            raise_if_interrupted()
            if progress:
                progress(obj.id, index, len(placements))
            if small is not None:
                _check_on_surface(home_file, field_path, small, tops[large.id])
            key = spec_content_key(obj.id, spec_paths[obj.id])
            cached = _cached_object(Path(out_dir) / "models" / obj.id, key, tmp / "models" / obj.id)
            if cached is None:
                built = build(spec_paths[obj.id], tmp / "models" / obj.id, BuildOptions(name=obj.id))
                write_text_atomic(tmp / "models" / obj.id / KEY_FILE, key)
                model, summary = built.model, built.summary
            else:
                model, summary = cached
            if small is None:
                tops[large.id] = float(model.world_mesh().bounds[1][2])
                smap.register_model(
                    model,
                    object_id=large.id,
                    parent_id=room.id,
                    parent_from_object=large.pose.matrix(),
                    model_ref=f"models/{large.id}/model.urdf",
                    parking_positions=_parking_positions(large, ParkingPosition),
                    properties=large.properties or None,
                )
            else:
                smap.register_model(
                    model,
                    object_id=small.id,
                    parent_id=large.id,
                    relation=small.relation,
                    parent_from_object=small.pose.matrix(),
                    model_ref=f"models/{small.id}/model.urdf",
                    properties=small.properties or None,
                )
            row = object_row(
                summary,
                id=obj.id,
                spec=str(spec_paths[obj.id].relative_to(example_dir.resolve())),
                parent=large.id if small else room.id,
                grasp_points=len(model.grasp_points),
                cached=cached is not None,
            )
            rows.append(row)
            log.info("built %s in %.2f s, valid=%s", obj.id, sum(row.times_s.values()), row.valid)
        save_map(smap, tmp / "map.xml")
        write_home_summary(tmp, rows)
        if progress:
            progress("done", len(placements), len(placements))
    out_dir = Path(out_dir)
    return BuildResult(out_dir=out_dir, map_path=out_dir / "map.xml", rows=rows)
