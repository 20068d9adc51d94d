"""Large furniture without joints: tables."""

from __future__ import annotations

from typing import ClassVar, Literal

from pydantic import Field, model_validator

from homemodel.yaml_specs import FieldError
from modeller.specs.common import Colour, Length, ObjectSpec, Offset, _Spec


class TableTop(_Spec):
    length_m: Length = Field(description="side to side, seen from the front (along y)")
    width_m: Length = Field(description="front to back (along x)")
    thickness_m: Length = 0.03


class TableLegs(_Spec):
    """Four legs, square (`size_m`) or round (`diameter_m`); 5 cm square when neither is given."""

    size_m: Length | None = None
    diameter_m: Length | None = None
    inset_m: Offset = Field(0.03, description="from the top's edge to the leg's outer face")

    @model_validator(mode="after")
    def _one_section(self) -> TableLegs:
        if self.size_m is not None and self.diameter_m is not None:
            raise FieldError(("diameter_m",), "give size_m (square legs) or diameter_m (round legs), not both")
        return self

    @property
    def section_m(self) -> float:
        if self.diameter_m is not None:
            return self.diameter_m
        return self.size_m if self.size_m is not None else 0.05


class TableSpec(ObjectSpec):
    default_density_kg_m3: ClassVar[float] = 700.0  # wood

    kind: Literal["table"]
    top: TableTop
    height_m: Length = Field(description="floor to the top surface")
    legs: TableLegs = Field(default_factory=TableLegs)
    colour: Colour = "oak"

    @model_validator(mode="after")
    def _geometry_possible(self) -> TableSpec:
        if self.top.thickness_m >= self.height_m:
            raise FieldError(
                ("top", "thickness_m"), f"top {self.top.thickness_m} m thick on a table {self.height_m} m high"
            )
        footprint = 2 * (self.legs.inset_m + self.legs.section_m)
        narrowest = min(self.top.length_m, self.top.width_m)
        if footprint >= narrowest:
            raise FieldError(
                ("legs", "inset_m"),
                f"legs {self.legs.section_m} m thick, {self.legs.inset_m} m in from the edges, "
                f"do not fit under a top {narrowest} m across",
            )
        return self
