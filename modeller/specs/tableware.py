"""Small household objects to eat and drink from: cups and mugs, glasses, plates, bowls.

Each is one link `body`, a solid of revolution about z standing on z = 0 (origin at the
centre of its base), hollow with the measured wall and bottom thicknesses.
"""

from __future__ import annotations

from typing import ClassVar, Literal

from pydantic import Field, model_validator

from homemodel.core.yaml_specs import FieldError
from modeller.specs.common import _EPS_M, Colour, Length, ObjectSpec, _Spec


class CupHandle(_Spec):
    """A torus segment on the cup's +x side, its ends buried in the middle of the wall."""

    height_m: Length | None = Field(
        None, description="height of the handle's centre above the floor; default: half the cup's height"
    )
    span_m: Length = Field(0.03, description="how far the handle sticks out from the outer wall")
    thickness_m: Length = Field(0.01, description="diameter of the handle's round section")


class CupSpec(ObjectSpec):
    """A hollow cylinder, open at the top, with an optional handle (D3.1's Figure 11)."""

    default_density_kg_m3: ClassVar[float] = 2400.0  # stoneware

    kind: Literal["cup"]
    height_m: Length = Field(0.095, description="floor to the rim")
    outer_diameter_m: Length = Field(0.08, description="outer diameter of the body")
    wall_thickness_m: Length = Field(0.004, description="thickness of the side wall")
    bottom_thickness_m: Length = Field(0.006, description="floor to the inside bottom")
    handle: CupHandle | None = Field(None, description="the handle, or null for a cup without one")
    colour: Colour = Field("white", description="colour: [r, g, b] in 0..1 (linear) or a name from NAMED_COLOURS")

    @property
    def handle_height_m(self) -> float:
        """Height of the handle's centre above the floor."""
        if self.handle is None:
            raise ValueError("cup has no handle")
        return self.height_m / 2 if self.handle.height_m is None else self.handle.height_m

    def handle_ring_m(self) -> tuple[float, float, float]:
        """The handle torus: (x of its centre, major radius, minor radius), centre in the wall."""
        if self.handle is None:
            raise ValueError("cup has no handle")
        centre_x = self.outer_diameter_m / 2 - self.wall_thickness_m / 2
        minor = self.handle.thickness_m / 2
        major = self.outer_diameter_m / 2 + self.handle.span_m - minor - centre_x
        return centre_x, major, minor

    @model_validator(mode="after")
    def _geometry_possible(self) -> CupSpec:
        if self.wall_thickness_m >= self.outer_diameter_m / 2:
            raise FieldError(
                ("wall_thickness_m",),
                f"wall {self.wall_thickness_m} m thick fills a cup {self.outer_diameter_m} m across",
            )
        if self.bottom_thickness_m >= self.height_m:
            raise FieldError(
                ("bottom_thickness_m",), f"bottom {self.bottom_thickness_m} m thick fills a cup {self.height_m} m high"
            )
        if self.handle is not None:
            _, major, minor = self.handle_ring_m()
            if major <= minor:
                raise FieldError(
                    ("handle", "span_m"),
                    f"handle sticking out {self.handle.span_m} m leaves no hole for a "
                    f"{self.handle.thickness_m} m thick handle",
                )
            low, high = self.handle_height_m - major - minor, self.handle_height_m + major + minor
            if low < -_EPS_M or high > self.height_m + _EPS_M:
                raise FieldError(
                    ("handle", "height_m"),
                    f"handle spans {low:.3f}..{high:.3f} m above the floor on a cup {self.height_m} m high",
                )
        return self


class MugSpec(CupSpec):
    """A cup that is a mug: larger, thicker, and with a handle unless told otherwise."""

    kind: Literal["mug"]
    height_m: Length = Field(0.1, description="floor to the rim")
    outer_diameter_m: Length = Field(0.085, description="outer diameter of the body")
    wall_thickness_m: Length = Field(0.005, description="thickness of the side wall")
    bottom_thickness_m: Length = Field(0.008, description="floor to the inside bottom")
    handle: CupHandle | None = Field(
        default_factory=lambda: CupHandle(span_m=0.032, thickness_m=0.012),
        description="the handle, or null for a mug without one",
    )


class GlassSpec(ObjectSpec):
    """A drinking glass: a hollow truncated cone (a tumbler; straight when both diameters agree)
    on a solid base."""

    default_density_kg_m3: ClassVar[float] = 2500.0  # soda-lime glass

    kind: Literal["glass"]
    height_m: Length = Field(0.11, description="floor to the rim")
    top_diameter_m: Length = Field(0.075, description="outer diameter at the rim")
    bottom_diameter_m: Length = Field(0.06, description="outer diameter at the base")
    wall_thickness_m: Length = Field(0.0025, description="the side wall's thickness, measured horizontally")
    base_thickness_m: Length = Field(0.01, description="the solid base under the inside floor")
    colour: Colour = Field(
        (0.75, 0.85, 0.9), description="colour: [r, g, b] in 0..1 (linear) or a name from NAMED_COLOURS"
    )

    @model_validator(mode="after")
    def _geometry_possible(self) -> GlassSpec:
        narrowest = min(self.top_diameter_m, self.bottom_diameter_m)
        if self.wall_thickness_m >= narrowest / 2:
            raise FieldError(
                ("wall_thickness_m",), f"wall {self.wall_thickness_m} m thick fills a glass {narrowest} m across"
            )
        if self.base_thickness_m >= self.height_m:
            raise FieldError(
                ("base_thickness_m",), f"base {self.base_thickness_m} m thick fills a glass {self.height_m} m high"
            )
        return self


class PlateSpec(ObjectSpec):
    """A plate: a flat well (the part it stands on) and a straight sloping rim up to `height_m`,
    of one thickness throughout. `style` only chooses the default height."""

    default_density_kg_m3: ClassVar[float] = 2400.0  # porcelain
    _DEFAULT_HEIGHT_M: ClassVar[dict[str, float]] = {"flat": 0.022, "deep": 0.045}

    kind: Literal["plate"]
    style: Literal["flat", "deep"] = Field("flat", description="a flat (dinner) plate or a deep (soup) plate")
    diameter_m: Length = Field(0.26, description="outer diameter at the rim")
    height_m: Length | None = Field(None, description="floor to the rim's top; default 0.022 flat, 0.045 deep")
    well_diameter_m: Length = Field(0.16, description="diameter of the flat bottom, inside and underneath")
    thickness_m: Length = Field(0.005, description="thickness of the plate, measured vertically")
    colour: Colour = Field("white", description="colour: [r, g, b] in 0..1 (linear) or a name from NAMED_COLOURS")

    @property
    def height_or_default_m(self) -> float:
        return self._DEFAULT_HEIGHT_M[self.style] if self.height_m is None else self.height_m

    @model_validator(mode="after")
    def _geometry_possible(self) -> PlateSpec:
        if self.well_diameter_m >= self.diameter_m:
            raise FieldError(
                ("well_diameter_m",),
                f"well {self.well_diameter_m} m across leaves no rim on a plate {self.diameter_m} m across",
            )
        if self.thickness_m >= self.height_or_default_m:
            raise FieldError(
                ("thickness_m",),
                f"plate {self.thickness_m} m thick is not under its rim {self.height_or_default_m} m high",
            )
        return self


class BowlSpec(ObjectSpec):
    """A bowl: a flat foot and a wall curving up (a quarter ellipse) to a vertical rim."""

    default_density_kg_m3: ClassVar[float] = 2400.0  # stoneware

    kind: Literal["bowl"]
    diameter_m: Length = Field(0.15, description="outer diameter at the rim")
    height_m: Length = Field(0.065, description="floor to the rim")
    foot_diameter_m: Length = Field(0.07, description="diameter of the flat bottom it stands on")
    wall_thickness_m: Length = Field(0.004, description="the wall's thickness at the rim")
    bottom_thickness_m: Length = Field(0.006, description="the bottom's thickness at the centre")
    colour: Colour = Field("white", description="colour: [r, g, b] in 0..1 (linear) or a name from NAMED_COLOURS")

    @model_validator(mode="after")
    def _geometry_possible(self) -> BowlSpec:
        if self.wall_thickness_m >= self.diameter_m / 2:
            raise FieldError(
                ("wall_thickness_m",), f"wall {self.wall_thickness_m} m thick fills a bowl {self.diameter_m} m across"
            )
        if self.foot_diameter_m >= self.diameter_m - 2 * self.wall_thickness_m:
            raise FieldError(
                ("foot_diameter_m",),
                f"foot {self.foot_diameter_m} m across is as wide as the bowl's inside "
                f"({self.diameter_m - 2 * self.wall_thickness_m:.3f} m)",
            )
        if self.bottom_thickness_m >= self.height_m:
            raise FieldError(
                ("bottom_thickness_m",), f"bottom {self.bottom_thickness_m} m thick fills a bowl {self.height_m} m high"
            )
        return self
