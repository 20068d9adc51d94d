"""Small devices: a remote control."""

from __future__ import annotations

from typing import Annotated, ClassVar, Literal

from pydantic import Field, model_validator

from homemodel.core.yaml_specs import FieldError
from modeller.specs.common import _EPS_M, Colour, Length, ObjectSpec, _Spec


class ButtonGrid(_Spec):
    """Round buttons in a grid on the top face, centred side to side."""

    rows: Annotated[int, Field(ge=0, le=40)] = Field(6, description="rows along the length; 0 for no buttons")
    columns: Annotated[int, Field(ge=1, le=10)] = Field(3, description="buttons in each row, side to side")
    diameter_m: Length = Field(0.008, description="diameter of each round button")
    height_m: Length = Field(0.002, description="how far the buttons stand out of the top face")
    pitch_m: Length = Field(0.013, description="centre to centre, along rows and columns alike")
    from_front_m: Length = Field(0.025, description="from the front end (+x) to the first row's centres")


class RemoteControlSpec(ObjectSpec):
    """A flat box with rounded corners (seen from above), lying on its back, buttons up.

    Its length runs along x with the end pointed at the television towards +x.
    """

    default_density_kg_m3: ClassVar[float] = 850.0  # plastic shell with batteries

    kind: Literal["remote_control"]
    length_m: Length = Field(0.18, description="front end to back end (along x)")
    width_m: Length = Field(0.045, description="side to side (along y)")
    thickness_m: Length = Field(0.018, description="the body's height, buttons not included")
    corner_radius_m: Length = Field(0.01, description="radius of the rounded corners, seen from above")
    buttons: ButtonGrid = Field(default_factory=ButtonGrid, description="the grid of buttons on the top face")
    colour: Colour = Field("black", description="colour: [r, g, b] in 0..1 (linear) or a name from NAMED_COLOURS")
    button_colour: Colour = Field("grey", description="colour: [r, g, b] in 0..1 (linear) or a name from NAMED_COLOURS")

    @model_validator(mode="after")
    def _geometry_possible(self) -> RemoteControlSpec:
        if self.corner_radius_m * 2 > min(self.width_m, self.length_m) + _EPS_M:
            raise FieldError(
                ("corner_radius_m",), f"corners {self.corner_radius_m} m round do not fit a {self.width_m} m wide body"
            )
        grid = self.buttons
        if grid.rows == 0:
            return self
        if grid.pitch_m < grid.diameter_m:
            raise FieldError(
                ("buttons", "pitch_m"), f"buttons {grid.diameter_m} m across {grid.pitch_m} m apart overlap"
            )
        across = (grid.columns - 1) * grid.pitch_m + grid.diameter_m
        if across > self.width_m + _EPS_M:
            raise FieldError(
                ("buttons", "columns"),
                f"{grid.columns} buttons span {across:.3f} m across a body {self.width_m} m wide",
            )
        if grid.from_front_m < grid.diameter_m / 2:
            raise FieldError(("buttons", "from_front_m"), "the first row sticks out over the front end")
        back = grid.from_front_m + (grid.rows - 1) * grid.pitch_m + grid.diameter_m / 2
        if back > self.length_m + _EPS_M:
            raise FieldError(
                ("buttons", "rows"),
                f"{grid.rows} rows reach {back:.3f} m from the front of a body {self.length_m} m long",
            )
        return self
