"""Handles on door and drawer fronts (bar, knob, recessed, or none: push to open), appliance
control knobs and push buttons."""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import Field, model_validator

from homemodel.core.yaml_specs import FieldError
from modeller.specs.common import Colour, Length, Offset, _Spec
from modeller.specs.joint_dynamics import JointDynamicsSpec

Orientation = Literal["vertical", "horizontal"]
# A button in a pocket keeps at least this much of itself above the pocket's floor, pressed.
_MIN_BUTTON_BODY_M = 0.001
# What readings to the millimetre may be off by, added up.
_TAPE_M = 0.001 + 1e-9


class Handle(_Spec):
    """A handle on a front. `type` picks its shape; each shape reads only its own fields.

    - `bar`: a straight bar (`length_m`, `diameter_m`) on two posts, its axis `standoff_m`
      in front of the front's outer face, along `orientation`.
    - `knob`: a round knob (`knob_diameter_m`) on a stem, its outer face
      `knob_projection_m` in front of the front's outer face.
    - `recessed`: a finger pocket cut into the front, `length_m` along `orientation`,
      `recess_width_m` across, `recess_depth_m` deep.
    - `none`: no handle (push to open); the front gets a `push` grasp point where its
      handle would be.
    - `channel`: no handle, a grip channel above the front (a handleless kitchen's rail):
      fingers hook over the front's top edge; a `handle` grasp point there, approached from
      above. Side-hinged doors and drawers only.
    """

    type: Literal["bar", "knob", "recessed", "none", "channel"] = "bar"
    orientation: Orientation | None = Field(
        None, description="bar or pocket direction on the front; default: along the front's free edge"
    )
    length_m: Length = Field(0.16, description="bar: bar length; recessed: pocket length")
    diameter_m: Length = Field(0.012, description="bar: bar diameter")
    standoff_m: Length = Field(0.035, description="bar: from the front's outer face to the bar's axis")
    knob_diameter_m: Length = Field(0.032, description="knob: diameter of the knob")
    knob_projection_m: Length = Field(0.028, description="knob: from the front's outer face to the knob's outer face")
    recess_width_m: Length = Field(0.03, description="recessed: pocket width, across its length")
    recess_depth_m: Length = Field(0.012, description="recessed: how deep the pocket goes into the front")

    @model_validator(mode="after")
    def _shape_possible(self) -> Handle:
        if self.type == "bar":
            if self.length_m < 3 * self.diameter_m:
                raise FieldError(
                    ("length_m",), f"bar of {self.length_m} m is too short for its {self.diameter_m} m diameter"
                )
            if self.standoff_m <= self.diameter_m / 2:
                raise FieldError(
                    ("standoff_m",),
                    f"bar axis {self.standoff_m} m off the front is inside the front ({self.diameter_m} m bar)",
                )
        if self.type == "recessed" and self.recess_width_m >= self.length_m:
            raise FieldError(
                ("recess_width_m",), f"pocket {self.recess_width_m} m wide is not shorter than its {self.length_m} m"
            )
        return self

    def direction(self, default: Orientation) -> Orientation:
        return self.orientation or default

    def half_extent_m(self, default: Orientation) -> tuple[float, float]:
        """Half the handle's footprint on the front: (across the front, up the front)."""
        if self.type == "knob":
            return self.knob_diameter_m / 2, self.knob_diameter_m / 2
        if self.type in ("none", "channel"):
            return 0.0, 0.0
        along = self.length_m / 2
        across = self.diameter_m / 2 if self.type == "bar" else self.recess_width_m / 2
        return (across, along) if self.direction(default) == "vertical" else (along, across)


class DoorHandle(Handle):
    """A door's handle, placed from the door's free (unhinged) edge."""

    from_free_edge_m: Offset = Field(0.04, description="from the door's free (unhinged) edge to the handle's centre")
    height_m: Offset | None = Field(
        None, description="side-hinged door: handle centre above the door's bottom edge; default: mid-door"
    )
    from_left_m: Offset | None = Field(
        None, description="top- or bottom-hinged door: handle centre from the door's left edge; default: centred"
    )


class DrawerHandle(Handle):
    """A drawer's handle, placed on the drawer front."""

    from_left_m: Offset | None = Field(None, description="handle centre from the front's left edge; default: centred")
    height_m: Offset | None = Field(None, description="handle centre above the front's bottom edge; default: centred")


class Pocket(_Spec):
    """A pocket cut into the panel round a knob or button: it sits in it."""

    depth_m: Length = Field(description="from the panel's outer face to the pocket's floor")
    margin_m: Offset = Field(0.002, description="gap between the knob or button and the pocket's side, all round")


class ControlKnob(_Spec):
    """A turning knob on an appliance's front panel (oven, hob, washing machine): a revolute link.

    Positions are named `states` (first = off) `step_deg` apart; the joint's limits are the
    first and the last state. A marker line on the knob's face points up at the first state.
    """

    left_m: Offset = Field(description="knob centre from the body's left edge, seen from in front")
    height_m: Offset = Field(description="knob centre above the floor")
    diameter_m: Length = 0.04
    projection_m: Length = Field(0.025, description="from the panel's outer face to the knob's outer face")
    states: Annotated[list[str], Field(min_length=2)] = ["off", "1", "2", "3", "4", "5", "6"]
    step_deg: Annotated[float, Field(gt=0, le=180)] = Field(40.0, description="turn between neighbouring states")
    turns: Literal["clockwise", "counterclockwise"] = Field(
        "clockwise", description="direction from off to the later states, seen from in front"
    )
    colour: Colour = "black"
    marker_colour: Colour = "white"
    dynamics: JointDynamicsSpec | None = Field(None, description="the knob's damping and friction; default: by its kind")
    stops: bool = Field(True, description="false: the knob turns round and round (a continuous joint)")
    pocket: Pocket | None = Field(None, description="a round pocket in the panel the knob sits in")

    @property
    def half_size_m(self) -> tuple[float, float]:
        """Half its extent across and up, pocket included (for the panel's rules)."""
        r = self.diameter_m / 2 + (0.0 if self.pocket is None else self.pocket.margin_m)
        return r, r

    @model_validator(mode="after")
    def _states_fit(self) -> ControlKnob:
        if len(set(self.states)) != len(self.states):
            raise FieldError(("states",), f"state names repeat: {self.states}")
        if self.stops and (len(self.states) - 1) * self.step_deg > 360:
            raise FieldError(
                ("step_deg",), f"{len(self.states)} states {self.step_deg} degrees apart turn more than once round"
            )
        return self


class PushButton(_Spec):
    """A push button on a front panel (a microwave's door release), round or rectangular: a
    prismatic link pressed straight in (-x) by up to `travel_m`. In a pocket it may stand
    level with the panel's face or below it (projection zero or negative) and press in
    further than it stands out, down to the pocket's floor."""

    left_m: Offset = Field(description="button centre from the body's left edge, seen from in front")
    height_m: Offset = Field(description="button centre above the floor")
    shape: Literal["round", "rectangle"] = "round"
    diameter_m: Length = Field(0.02, description="a round button's diameter")
    width_m: Length | None = Field(None, description="a rectangular button's width, seen from in front")
    button_height_m: Length | None = Field(None, description="a rectangular button's height, seen from in front")
    projection_m: float = Field(
        0.006, description="from the panel's outer face to the button's face (negative: below it, in a pocket)"
    )
    travel_m: Length = Field(0.004, description="how far the button presses in")
    pocket: Pocket | None = Field(None, description="a pocket in the panel the button sits in")
    body_depth_m: Length | None = Field(
        None,
        description="in a pocket: from the button's face back to its back (the button pulled out, or seen "
        "pressed); default: down to where, pressed fully, it meets the pocket's floor",
    )
    colour: Colour = "grey"

    @property
    def half_size_m(self) -> tuple[float, float]:
        """Half its extent across and up, pocket included (for the panel's rules)."""
        margin = 0.0 if self.pocket is None else self.pocket.margin_m
        if self.shape == "round":
            return self.diameter_m / 2 + margin, self.diameter_m / 2 + margin
        assert self.width_m is not None and self.button_height_m is not None
        return self.width_m / 2 + margin, self.button_height_m / 2 + margin

    @model_validator(mode="after")
    def _travel_fits(self) -> PushButton:
        if not (math.isfinite(self.projection_m) and abs(self.projection_m) <= 1.0):
            raise FieldError(("projection_m",), f"{self.projection_m} m is not a button's projection")
        if self.shape == "rectangle" and (self.width_m is None or self.button_height_m is None):
            raise FieldError(("width_m",), "a rectangular button needs width_m and button_height_m")
        if self.pocket is None:
            if self.body_depth_m is not None:
                raise FieldError(("body_depth_m",), "a button out of its panel's face is as deep as it stands out; give a pocket")
            if self.projection_m <= 0:
                raise FieldError(
                    ("projection_m",), f"a button {self.projection_m} m out of the panel's face needs a pocket to sit in"
                )
            if self.travel_m >= self.projection_m:
                raise FieldError(
                    ("travel_m",), f"a button standing {self.projection_m} m out cannot press in {self.travel_m} m"
                )
            return self
        floor = self.pocket.depth_m
        if self.projection_m <= -floor:
            raise FieldError(("projection_m",), f"a button {-self.projection_m} m down a {floor} m deep pocket is not in it")
        if self.projection_m - self.travel_m <= -floor + _MIN_BUTTON_BODY_M:
            raise FieldError(
                ("travel_m",),
                f"a button {self.projection_m} m out pressed in {self.travel_m} m goes through its pocket's floor "
                f"{floor} m down",
            )
        # Four readings to the millimetre may add up 1 mm past the floor: built as deep as fits.
        if self.body_depth_m is not None and self.projection_m - self.travel_m - self.body_depth_m < -floor - _TAPE_M:
            raise FieldError(
                ("body_depth_m",),
                f"a button {self.body_depth_m} m deep, {self.projection_m} m out, pressed in {self.travel_m} m goes "
                f"through its pocket's floor {floor} m down",
            )
        return self
