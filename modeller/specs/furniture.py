"""Large furniture without joints: tables, chairs, sofas, beds and open shelving.

Each is one rigid link `body` in the model frame of `modeller.specs.common`: origin at the
centre of the footprint on the floor, +x out of the front (the side a person sits down on,
the foot end of a bed, the open side of a shelf unit), +y to the object's own left, z up.
"""

from __future__ import annotations

import math
from typing import Annotated, ClassVar, Literal

from pydantic import Field, model_validator

from homemodel.core.yaml_specs import FieldError
from modeller.specs.common import _EPS_M, Colour, Length, ObjectSpec, Offset, _Spec


class TableTop(_Spec):
    """The top: a rectangle (`length_m` by `width_m`) or a disc (`diameter_m`)."""

    shape: Literal["rectangular", "round"] = Field("rectangular", description="rectangular or round (a disc)")
    length_m: Length = Field(1.2, description="rectangular top: side to side, seen from the front (along y)")
    width_m: Length = Field(0.8, description="rectangular top: front to back (along x)")
    diameter_m: Length = Field(0.9, description="round top: its diameter")
    thickness_m: Length = Field(0.03, description="thickness of the top slab")

    @model_validator(mode="after")
    def _fields_of_its_shape(self) -> TableTop:
        # A field of the other shape would be silently ignored: refuse it instead.
        if self.shape == "round":
            for name in ("length_m", "width_m"):
                if name in self.model_fields_set:
                    raise FieldError((name,), f"a round top is measured by diameter_m, not {name}")
        elif "diameter_m" in self.model_fields_set:
            raise FieldError(("diameter_m",), "a rectangular top is measured by length_m and width_m, not diameter_m")
        return self

    @property
    def size_xy_m(self) -> tuple[float, float]:
        """The top's extent front to back (x) and side to side (y)."""
        if self.shape == "round":
            return self.diameter_m, self.diameter_m
        return self.width_m, self.length_m


class Legs(_Spec):
    """Four legs, square (`size_m`) or round (`diameter_m`); 5 cm square when neither is given.

    Under a rectangle they stand in its corners; under a disc (a round table top) on its
    diagonals, a square leg turned to face the rim.
    """

    size_m: Length | None = Field(None, description="side of a square leg's section")
    diameter_m: Length | None = Field(None, description="diameter of a round leg")
    inset_m: Offset = Field(0.03, description="from the edge of the top (or seat) to the leg's outer face")

    @model_validator(mode="after")
    def _one_section(self) -> Legs:
        if self.size_m is not None and self.diameter_m is not None:
            raise FieldError(("diameter_m",), "give size_m (square legs) or diameter_m (round legs), not both")
        return self

    @property
    def section_m(self) -> float:
        if self.diameter_m is not None:
            return self.diameter_m
        return self.size_m if self.size_m is not None else 0.05

    def check_fit(self, size_xy_m: tuple[float, float], *, round_top: bool, what: str) -> None:
        """Refuse legs that would touch each other under a top of `size_xy_m`."""
        if round_top:
            # Leg centres on the diagonals: a centre radius of one section keeps the four
            # legs clear of each other and of the middle.
            centre_radius = size_xy_m[0] / 2 - self.inset_m - self.section_m / 2
            fits = centre_radius > self.section_m
        else:
            fits = 2 * (self.inset_m + self.section_m) < min(size_xy_m)
        if not fits:
            raise FieldError(
                ("legs", "inset_m"),
                f"legs {self.section_m} m thick, {self.inset_m} m in from the edges, "
                f"do not fit under {what} {min(size_xy_m)} m across",
            )


class Pedestal(_Spec):
    """One central round column on a round foot, instead of legs."""

    column_diameter_m: Length = Field(0.08, description="diameter of the round column")
    foot_diameter_m: Length = Field(0.5, description="diameter of the disc the column stands on")
    foot_thickness_m: Length = Field(0.03, description="height of the foot disc")


class TableSpec(ObjectSpec):
    """A top slab on four legs or on a pedestal; its top surface is a supporting surface."""

    default_density_kg_m3: ClassVar[float] = 700.0  # wood

    kind: Literal["table"]
    top: TableTop = Field(default_factory=TableTop, description="the top slab; its top surface is at height_m")
    height_m: Length = Field(0.75, description="floor to the top surface")
    legs: Legs | None = Field(None, description="four legs; the default when no pedestal is given")
    pedestal: Pedestal | None = Field(None, description="a central column on a foot instead of legs")
    colour: Colour = Field("oak", description="colour: [r, g, b] in 0..1 (linear) or a name from NAMED_COLOURS")

    @property
    def legs_or_default(self) -> Legs:
        return self.legs if self.legs is not None else Legs()

    @model_validator(mode="after")
    def _geometry_possible(self) -> TableSpec:
        if self.top.thickness_m >= self.height_m:
            raise FieldError(
                ("top", "thickness_m"), f"top {self.top.thickness_m} m thick on a table {self.height_m} m high"
            )
        if self.pedestal is None:
            self.legs_or_default.check_fit(self.top.size_xy_m, round_top=self.top.shape == "round", what="a top")
            return self
        if self.legs is not None:
            raise FieldError(("pedestal",), "give legs or pedestal, not both")
        pedestal = self.pedestal
        if pedestal.column_diameter_m >= pedestal.foot_diameter_m:
            raise FieldError(
                ("pedestal", "column_diameter_m"),
                f"column {pedestal.column_diameter_m} m across on a foot only {pedestal.foot_diameter_m} m across",
            )
        if pedestal.foot_diameter_m > min(self.top.size_xy_m) + _EPS_M:
            raise FieldError(
                ("pedestal", "foot_diameter_m"),
                f"foot {pedestal.foot_diameter_m} m across sticks out under a top {min(self.top.size_xy_m)} m across",
            )
        if pedestal.foot_thickness_m + self.top.thickness_m >= self.height_m:
            raise FieldError(
                ("pedestal", "foot_thickness_m"),
                f"foot {pedestal.foot_thickness_m} m and top {self.top.thickness_m} m thick leave no column "
                f"in a table {self.height_m} m high",
            )
        return self


class ChairSpec(ObjectSpec):
    """A seat on four legs with a backrest standing on the seat's rear edge."""

    default_density_kg_m3: ClassVar[float] = 650.0  # wood

    kind: Literal["chair"]
    seat_width_m: Length = Field(0.44, description="seat side to side (along y)")
    seat_depth_m: Length = Field(0.42, description="seat front to back (along x)")
    seat_height_m: Length = Field(0.46, description="floor to the seat's top surface")
    seat_thickness_m: Length = Field(0.03, description="thickness of the seat board; the legs carry it")
    height_m: Length = Field(0.88, description="floor to the top of the backrest")
    backrest_thickness_m: Length = Field(0.025, description="thickness of the backrest slab")
    backrest_tilt_deg: Annotated[float, Field(ge=0, le=30)] = Field(
        8.0, description="backward lean of the backrest from vertical, about the seat's rear top edge"
    )
    legs: Legs = Field(
        default_factory=lambda: Legs(size_m=0.035, inset_m=0.01), description="four legs under the seat's corners"
    )
    colour: Colour = Field("oak", description="colour: [r, g, b] in 0..1 (linear) or a name from NAMED_COLOURS")

    @property
    def backrest_length_m(self) -> float:
        """Length of the backrest slab along its lean, so its top reaches `height_m`."""
        tilt = math.radians(self.backrest_tilt_deg)
        rise = self.height_m - self.seat_height_m - self.backrest_thickness_m * math.sin(tilt)
        return rise / math.cos(tilt)

    @model_validator(mode="after")
    def _geometry_possible(self) -> ChairSpec:
        if self.seat_thickness_m >= self.seat_height_m:
            raise FieldError(
                ("seat_thickness_m",), f"seat {self.seat_thickness_m} m thick at {self.seat_height_m} m high"
            )
        if self.backrest_thickness_m >= self.seat_depth_m:
            raise FieldError(
                ("backrest_thickness_m",),
                f"backrest {self.backrest_thickness_m} m thick on a seat {self.seat_depth_m} m deep",
            )
        if self.backrest_length_m <= self.backrest_thickness_m:
            raise FieldError(
                ("height_m",),
                f"a chair {self.height_m} m high leaves no backrest above a seat at {self.seat_height_m} m",
            )
        self.legs.check_fit((self.seat_depth_m, self.seat_width_m), round_top=False, what="a seat")
        return self


class SofaArms(_Spec):
    width_m: Length = Field(0.2, description="each arm's thickness side to side (along y)")
    height_m: Length = Field(0.62, description="floor to the top of the arms")


class SofaSpec(ObjectSpec):
    """A base on short legs, seat cushions side by side, a back along the rear, arms at the sides.

    The back runs the whole width behind the cushions; the arms run the whole depth.
    """

    default_density_kg_m3: ClassVar[float] = 80.0  # mostly foam, on a wooden frame

    kind: Literal["sofa"]
    width_m: Length = Field(2.0, description="overall, side to side (along y)")
    depth_m: Length = Field(0.9, description="overall, front to back (along x)")
    height_m: Length = Field(0.85, description="floor to the top of the back")
    seat_height_m: Length = Field(0.45, description="floor to the top of the seat cushions")
    cushions: Annotated[int, Field(ge=1, le=10)] = Field(3, description="seat cushions side by side")
    cushion_thickness_m: Length = Field(0.12, description="height of the seat cushions, lying on the base")
    back_thickness_m: Length = Field(0.2, description="the back's thickness front to back")
    arms: SofaArms | None = Field(default_factory=SofaArms, description="null for a sofa without arms")
    leg_height_m: Offset = Field(0.08, description="floor to the underside of the base; 0 for no legs")
    leg_size_m: Length = Field(0.04, description="side of a square leg's section")
    colour: Colour = Field(
        "grey",
        description="colour: [r, g, b] in 0..1 (linear) or a name from NAMED_COLOURS; base, back, arms and cushions",
    )
    leg_colour: Colour = Field("brown", description="colour: [r, g, b] in 0..1 (linear) or a name from NAMED_COLOURS")

    @property
    def arm_width_m(self) -> float:
        return 0.0 if self.arms is None else self.arms.width_m

    @property
    def base_top_m(self) -> float:
        return self.seat_height_m - self.cushion_thickness_m

    @model_validator(mode="after")
    def _geometry_possible(self) -> SofaSpec:
        if self.base_top_m <= self.leg_height_m + _EPS_M:
            raise FieldError(
                ("cushion_thickness_m",),
                f"cushions {self.cushion_thickness_m} m thick topping out at {self.seat_height_m} m leave no base "
                f"above legs {self.leg_height_m} m high",
            )
        if self.height_m <= self.seat_height_m:
            raise FieldError(
                ("height_m",), f"back top at {self.height_m} m is not above the seat at {self.seat_height_m} m"
            )
        if self.back_thickness_m >= self.depth_m:
            raise FieldError(
                ("back_thickness_m",), f"back {self.back_thickness_m} m thick on a sofa {self.depth_m} m deep"
            )
        if self.arms is not None:
            if 2 * self.arms.width_m >= self.width_m:
                raise FieldError(
                    ("arms", "width_m"), f"two arms {self.arms.width_m} m wide fill a sofa {self.width_m} m wide"
                )
            if not self.seat_height_m < self.arms.height_m <= self.height_m + _EPS_M:
                raise FieldError(
                    ("arms", "height_m"),
                    f"arms {self.arms.height_m} m high must be above the seat ({self.seat_height_m} m) "
                    f"and not above the back ({self.height_m} m)",
                )
        if self.leg_height_m > 0 and 2 * self.leg_size_m >= min(self.width_m, self.depth_m):
            raise FieldError(("leg_size_m",), f"legs {self.leg_size_m} m thick do not fit under the sofa")
        return self


class BedSpec(ObjectSpec):
    """A headboard at the back (-x), a frame on four legs, a mattress on it, an optional footboard."""

    default_density_kg_m3: ClassVar[float] = 90.0  # a wooden frame and a foam mattress

    kind: Literal["bed"]
    length_m: Length = Field(2.1, description="overall, head to foot (along x), headboard and footboard included")
    width_m: Length = Field(1.5, description="overall, side to side (along y)")
    frame_height_m: Length = Field(0.32, description="floor to the top of the frame, where the mattress lies")
    frame_thickness_m: Length = Field(
        0.15, description="height of the frame's sides; legs carry it below; equal to frame_height_m for no legs"
    )
    leg_size_m: Length = Field(0.06, description="side of a square leg's section, in the frame's corners")
    mattress_thickness_m: Length = Field(0.2, description="height of the mattress lying on the frame")
    mattress_inset_m: Offset = Field(0.01, description="from the frame's edges to the mattress's sides")
    headboard_height_m: Length = Field(0.95, description="floor to the top of the headboard")
    headboard_thickness_m: Length = Field(0.05, description="headboard front to back (along x)")
    footboard_height_m: Offset = Field(0.0, description="floor to the top of the footboard; 0 for none")
    footboard_thickness_m: Length = Field(0.04, description="footboard front to back (along x)")
    colour: Colour = Field(
        "oak", description="colour: [r, g, b] in 0..1 (linear) or a name from NAMED_COLOURS; frame, legs and boards"
    )
    mattress_colour: Colour = Field(
        "white", description="colour: [r, g, b] in 0..1 (linear) or a name from NAMED_COLOURS"
    )

    @property
    def frame_length_m(self) -> float:
        foot = self.footboard_thickness_m if self.footboard_height_m > 0 else 0.0
        return self.length_m - self.headboard_thickness_m - foot

    @property
    def surface_height_m(self) -> float:
        return self.frame_height_m + self.mattress_thickness_m

    @model_validator(mode="after")
    def _geometry_possible(self) -> BedSpec:
        if self.frame_thickness_m > self.frame_height_m + _EPS_M:
            raise FieldError(
                ("frame_thickness_m",),
                f"frame {self.frame_thickness_m} m thick reaches below the floor from {self.frame_height_m} m",
            )
        if self.frame_length_m <= 2 * self.mattress_inset_m:
            raise FieldError(("length_m",), f"a bed {self.length_m} m long leaves no frame between its boards")
        if self.width_m <= 2 * self.mattress_inset_m:
            raise FieldError(("mattress_inset_m",), f"mattress inset {self.mattress_inset_m} m leaves no mattress")
        if self.headboard_height_m < self.frame_height_m:
            raise FieldError(
                ("headboard_height_m",), f"headboard top {self.headboard_height_m} m is below the frame's top"
            )
        if 0 < self.footboard_height_m < self.frame_height_m:
            raise FieldError(
                ("footboard_height_m",), f"footboard top {self.footboard_height_m} m is below the frame's top"
            )
        if self.frame_thickness_m < self.frame_height_m and 2 * self.leg_size_m >= min(
            self.frame_length_m, self.width_m
        ):
            raise FieldError(("leg_size_m",), f"legs {self.leg_size_m} m thick do not fit under the frame")
        return self


class ShelvingSpec(ObjectSpec):
    """An open shelf unit: two side panels, a top board, shelves between the sides, an optional back."""

    default_density_kg_m3: ClassVar[float] = 650.0  # chipboard

    kind: Literal["shelving"]
    width_m: Length = Field(0.8, description="overall, side to side (along y)")
    depth_m: Length = Field(0.3, description="overall, front to back (along x), the back panel included")
    height_m: Length = Field(1.8, description="floor to the top board's top surface")
    board_thickness_m: Length = Field(0.018, description="thickness of the sides, the top board and the shelves")
    shelf_heights_m: list[Length] = Field(
        [0.1, 0.5, 0.9, 1.3], description="floor to each shelf's top surface; the top board comes on its own"
    )
    back: bool = Field(True, description="a back panel between the sides")
    back_thickness_m: Length = Field(0.006, description="the back panel's thickness (along x)")
    colour: Colour = Field("white", description="colour: [r, g, b] in 0..1 (linear) or a name from NAMED_COLOURS")

    @property
    def back_thickness_or_zero_m(self) -> float:
        return self.back_thickness_m if self.back else 0.0

    @model_validator(mode="after")
    def _geometry_possible(self) -> ShelvingSpec:
        t = self.board_thickness_m
        if 2 * t >= self.width_m:
            raise FieldError(("board_thickness_m",), f"sides {t} m thick fill a unit {self.width_m} m wide")
        if t >= self.height_m:
            raise FieldError(("board_thickness_m",), f"top board {t} m thick on a unit {self.height_m} m high")
        if self.back_thickness_or_zero_m >= self.depth_m:
            raise FieldError(
                ("back_thickness_m",), f"back {self.back_thickness_m} m thick on a unit {self.depth_m} m deep"
            )
        for i, height in enumerate(self.shelf_heights_m):
            if height < t - _EPS_M:
                raise FieldError(("shelf_heights_m", i), f"shelf at {height} m ({t} m thick) reaches below the floor")
            if height > self.height_m - t + _EPS_M:
                raise FieldError(
                    ("shelf_heights_m", i),
                    f"shelf at {height} m cuts into the top board at {self.height_m - t:.3f}..{self.height_m} m",
                )
            for j, other in enumerate(self.shelf_heights_m[:i]):
                if abs(height - other) < t - _EPS_M:
                    raise FieldError(
                        ("shelf_heights_m", i), f"shelf at {height} m overlaps shelf {j} at {other} m ({t} m thick)"
                    )
        return self
