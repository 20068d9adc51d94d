"""Handles screwed to a door or drawer front."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from homemodel.yaml_specs import FieldError
from modeller.specs.common import Length, Offset, _Spec


class BarHandle(_Spec):
    """A straight bar on two posts, screwed to a door or drawer front."""

    length_m: Length = 0.16
    diameter_m: Length = 0.012
    standoff_m: Length = Field(0.035, description="from the front's outer face to the bar's axis")
    orientation: Literal["vertical", "horizontal"]

    @model_validator(mode="after")
    def _bar_fits(self) -> BarHandle:
        if self.length_m < 3 * self.diameter_m:
            raise FieldError(
                ("length_m",), f"bar of {self.length_m} m is too short for its {self.diameter_m} m diameter"
            )
        if self.standoff_m <= self.diameter_m / 2:
            raise FieldError(
                ("standoff_m",),
                f"bar axis {self.standoff_m} m off the front is inside the front ({self.diameter_m} m bar)",
            )
        return self

    @property
    def half_extent_m(self) -> tuple[float, float]:
        """Half the bar's footprint on the front: (across the front, up the front)."""
        along, across = self.length_m / 2, self.diameter_m / 2
        return (across, along) if self.orientation == "vertical" else (along, across)


class DoorHandle(BarHandle):
    orientation: Literal["vertical", "horizontal"] = "vertical"
    from_free_edge_m: Offset = Field(0.04, description="from the door's free (unhinged) edge to the bar's centre")
    height_m: Offset | None = Field(None, description="bar centre above the door's bottom edge; default: mid-door")


class DrawerHandle(BarHandle):
    orientation: Literal["vertical", "horizontal"] = "horizontal"
    from_left_m: Offset | None = Field(None, description="bar centre from the front's left edge; default: centred")
    height_m: Offset | None = Field(None, description="bar centre above the front's bottom edge; default: centred")
