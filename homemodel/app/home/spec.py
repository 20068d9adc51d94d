"""The home file (`home.yaml`) of an example folder: the apartment, its rooms, and which
measurement spec stands where, on or in what, with the robot's parking positions.

Frames: a large object's pose and its parking positions are in the map frame; a small
object's pose is in its parent object's frame (origin at the centre of the parent's
footprint on the floor, z up), so a cup on a 0.75 m table has z = 0.75.
"""

from __future__ import annotations

from collections import Counter
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from homemodel.core.transforms import transform_from_xyz_rpy
from semantic_map.nodes import ID_PATTERN

# Every id in the home becomes an id in the semantic map, so it follows the map's rule.
MapId = Annotated[str, Field(pattern=ID_PATTERN)]
# Bounds a home cannot exceed: they keep 1e300 from overflowing the transforms.
Coordinate = Annotated[float, Field(ge=-10_000.0, le=10_000.0)]  # metres
Degrees = Annotated[float, Field(ge=-3600.0, le=3600.0)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class PoseSpec(_Strict):
    xyz: tuple[Coordinate, Coordinate, Coordinate] = (0.0, 0.0, 0.0)
    rpy_deg: tuple[Degrees, Degrees, Degrees] = (0.0, 0.0, 0.0)

    def matrix(self) -> np.ndarray:
        return transform_from_xyz_rpy(self.xyz, np.radians(self.rpy_deg))


class ParkingSpec(_Strict):
    """Where the robot's base stands (on the floor) to observe or reach the object."""

    name: str = Field(min_length=1)
    xy: tuple[Coordinate, Coordinate]
    yaw_deg: Degrees = 0.0
    default: bool = False

    def matrix(self) -> np.ndarray:
        return transform_from_xyz_rpy((self.xy[0], self.xy[1], 0.0), (0.0, 0.0, np.radians(self.yaw_deg)))


class SmallObjectSpec(_Strict):
    id: MapId
    spec: str = Field(min_length=1, description="measurement spec file, relative to home.yaml")
    relation: Literal["on", "in", "under"] = "on"
    pose: PoseSpec = PoseSpec()
    properties: dict[str, str] = Field(default_factory=dict)

    @field_validator("relation", mode="before")
    @classmethod
    def _yaml_on(cls, value: object) -> object:
        # YAML 1.1 reads an unquoted `on` as true; an installer writing `relation: on` means "on".
        return "on" if value is True else value


class LargeObjectSpec(_Strict):
    id: MapId
    spec: str = Field(min_length=1, description="measurement spec file, relative to home.yaml")
    pose: PoseSpec = PoseSpec()
    parking: list[ParkingSpec] = Field(min_length=1)
    properties: dict[str, str] = Field(default_factory=dict)
    objects: list[SmallObjectSpec] = Field(default_factory=list)

    @field_validator("parking")
    @classmethod
    def _one_default(cls, parking: list[ParkingSpec]) -> list[ParkingSpec]:
        defaults = [p.name for p in parking if p.default]
        if len(defaults) > 1:
            raise ValueError(f"only one parking position may be the default, got {defaults}")
        return parking


class RunSpec(_Strict):
    """Base units side by side against a wall, under one worktop, placed for the installer.

    The run's frame (`pose`, in the map frame): origin on the floor at the wall behind the
    run's left end (seen from in front), +x out of the fronts, +y along the run to the right.
    Units stand left to right from `left_m`, `gap_m` apart, backs to the wall; the worktop's
    back edge is at the wall and its left end at `worktop_left_m`. Their poses in the map are
    worked out from their specs' widths and depths, so `pose` is not given for them.
    """

    pose: PoseSpec = PoseSpec()
    left_m: float = Field(0.0, description="from the run's origin to the first unit's left side")
    gap_m: float = Field(0.0, ge=0, description="between neighbouring units")
    units: list[LargeObjectSpec] = Field(min_length=1)
    worktop: LargeObjectSpec | None = None
    worktop_left_m: float = Field(0.0, description="from the run's origin to the worktop's left end")

    @model_validator(mode="after")
    def _placed_by_the_run(self) -> RunSpec:
        for large in [*self.units, *([self.worktop] if self.worktop else [])]:
            if large.pose != PoseSpec():
                raise ValueError(f"{large.id}: a unit in a run is placed by the run; give the run's pose instead")
        return self


class RoomSpec(_Strict):
    id: MapId
    name: str = Field(min_length=1)
    point_cloud: str | None = None
    outline: list[tuple[float, float]] | None = Field(
        default=None, min_length=3, description="floor plan: polygon corners [x, y] in the map frame, metres"
    )
    objects: list[LargeObjectSpec] = Field(default_factory=list)
    runs: list[RunSpec] = Field(default_factory=list)


class ApartmentSpec(_Strict):
    id: MapId
    name: str = Field(min_length=1)


class HomeSpec(_Strict):
    apartment: ApartmentSpec
    rooms: list[RoomSpec] = Field(min_length=1)

    @model_validator(mode="after")
    def _unique_ids(self) -> HomeSpec:
        ids = [self.apartment.id]
        for room in self.rooms:
            ids.append(room.id)
            runs = [large for run in room.runs for large in [*run.units, *([run.worktop] if run.worktop else [])]]
            for large in [*room.objects, *runs]:
                ids.append(large.id)
                ids.extend(small.id for small in large.objects)
        dupes = sorted(i for i, n in Counter(ids).items() if n > 1)  # linear: a home file may be large
        if dupes:
            raise ValueError(f"ids must be unique in the home, repeated: {dupes}")
        return self
