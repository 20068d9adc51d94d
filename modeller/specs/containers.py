"""Small closed containers: bottles, boxes (food packets), jars and canisters, pill boxes.

Origin at the centre of the base on z = 0. A box's `depth_m` runs front to back (x) and its
`width_m` side to side (y), seen from its front (+x), as for furniture.
"""

from __future__ import annotations

from typing import Annotated, ClassVar, Literal

from pydantic import Field, model_validator

from homemodel.core.yaml_specs import FieldError
from modeller.specs.common import _EPS_M, Colour, Length, ObjectSpec, Offset

# A map label: one token, no spaces (the semantic map's object types and property names).
Label = Annotated[str, Field(pattern=r"^[A-Za-z][A-Za-z0-9_]*$", max_length=64)]


class _FoodContainer(ObjectSpec):
    contents: Label | None = Field(
        None, description="what it holds (sugar, cereal, ...): a `contents` property in the map"
    )


class BottleSpec(_FoodContainer):
    """A closed bottle: a cylindrical body, a shoulder narrowing smoothly to a cylindrical neck, a cap."""

    # The solid's volume at water's density: a full bottle. Give mass_kg for an empty one.
    default_density_kg_m3: ClassVar[float] = 1000.0

    kind: Literal["bottle"]
    height_m: Length = Field(0.3, description="floor to the top of the cap")
    diameter_m: Length = Field(0.08, description="diameter of the body")
    shoulder_height_m: Length = Field(0.19, description="floor to where the body starts to narrow")
    neck_height_m: Length = Field(0.24, description="floor to where the shoulder has narrowed to the neck")
    neck_diameter_m: Length = Field(0.028, description="outer diameter of the straight neck")
    cap_height_m: Length = Field(0.02, description="height of the cap, from its lower edge to the top")
    cap_diameter_m: Length = Field(0.032, description="outer diameter of the cap")
    colour: Colour = Field(
        (0.15, 0.45, 0.25), description="colour: [r, g, b] in 0..1 (linear) or a name from NAMED_COLOURS"
    )
    cap_colour: Colour = Field("white", description="colour: [r, g, b] in 0..1 (linear) or a name from NAMED_COLOURS")

    @model_validator(mode="after")
    def _geometry_possible(self) -> BottleSpec:
        if self.neck_diameter_m >= self.diameter_m:
            raise FieldError(
                ("neck_diameter_m",), f"neck {self.neck_diameter_m} m across on a body {self.diameter_m} m across"
            )
        if not self.neck_diameter_m <= self.cap_diameter_m <= self.diameter_m:
            raise FieldError(
                ("cap_diameter_m",),
                f"cap {self.cap_diameter_m} m across must fit over the neck ({self.neck_diameter_m} m) "
                f"and within the body ({self.diameter_m} m)",
            )
        if self.cap_height_m >= self.height_m:
            raise FieldError(("cap_height_m",), f"cap {self.cap_height_m} m high on a bottle {self.height_m} m high")
        if self.neck_height_m >= self.height_m - self.cap_height_m:
            raise FieldError(
                ("neck_height_m",),
                f"neck starting at {self.neck_height_m} m leaves no neck below the cap at "
                f"{self.height_m - self.cap_height_m:.3f} m",
            )
        if self.shoulder_height_m >= self.neck_height_m:
            raise FieldError(
                ("shoulder_height_m",),
                f"shoulder at {self.shoulder_height_m} m is not below the neck at {self.neck_height_m} m",
            )
        return self


class BoxSpec(_FoodContainer):
    """A closed cuboid: a food packet (cereal, pasta, tea)."""

    default_density_kg_m3: ClassVar[float] = 150.0  # a packet of cereal

    kind: Literal["box"]
    width_m: Length = Field(0.19, description="side to side, seen from its front (along y)")
    depth_m: Length = Field(0.065, description="front to back (along x)")
    height_m: Length = Field(0.28, description="floor to the top")
    colour: Colour = Field("yellow", description="colour: [r, g, b] in 0..1 (linear) or a name from NAMED_COLOURS")


class JarSpec(_FoodContainer):
    """A jar or canister (a sugar container): a hollow cylinder with a flat lid and a knob on it.

    The lid is its own link `lid` resting on the body on a prismatic joint `lid_lift` along
    +z, so it lifts off, and its pose and its knob reach the map.
    """

    default_density_kg_m3: ClassVar[float] = 2400.0  # stoneware

    kind: Literal["jar"]
    category: Label = Field("jar", description="the object's type in the map, e.g. sugar_container")
    height_m: Length = Field(0.14, description="floor to the top of the lid's knob")
    diameter_m: Length = Field(0.1, description="outer diameter of the body")
    wall_thickness_m: Length = Field(0.004, description="thickness of the body's side wall")
    bottom_thickness_m: Length = Field(0.006, description="floor to the inside bottom")
    lid_diameter_m: Length | None = Field(None, description="the lid's diameter; default: the body's")
    lid_thickness_m: Length = Field(0.015, description="height of the lid disc, resting on the body's rim")
    knob_diameter_m: Length = Field(0.025, description="diameter of the round knob on the lid")
    knob_height_m: Offset = Field(0.012, description="the knob's height above the lid; 0 for none")
    colour: Colour = Field("white", description="colour: [r, g, b] in 0..1 (linear) or a name from NAMED_COLOURS")
    lid_colour: Colour = Field("silver", description="colour: [r, g, b] in 0..1 (linear) or a name from NAMED_COLOURS")

    @property
    def lid_diameter_or_default_m(self) -> float:
        return self.diameter_m if self.lid_diameter_m is None else self.lid_diameter_m

    @property
    def body_height_m(self) -> float:
        return self.height_m - self.lid_thickness_m - self.knob_height_m

    @model_validator(mode="after")
    def _geometry_possible(self) -> JarSpec:
        if self.wall_thickness_m >= self.diameter_m / 2:
            raise FieldError(
                ("wall_thickness_m",), f"wall {self.wall_thickness_m} m thick fills a jar {self.diameter_m} m across"
            )
        if self.body_height_m <= self.bottom_thickness_m:
            raise FieldError(
                ("height_m",),
                f"a jar {self.height_m} m high with a lid {self.lid_thickness_m} m and a knob {self.knob_height_m} m "
                f"high leaves no body above its {self.bottom_thickness_m} m bottom",
            )
        if self.lid_diameter_or_default_m < self.diameter_m - 2 * self.wall_thickness_m:
            raise FieldError(
                ("lid_diameter_m",), f"lid {self.lid_diameter_m} m across does not cover the jar's opening"
            )
        if self.knob_height_m > 0 and self.knob_diameter_m >= self.lid_diameter_or_default_m:
            raise FieldError(
                ("knob_diameter_m",),
                f"knob {self.knob_diameter_m} m across on a lid {self.lid_diameter_or_default_m} m across",
            )
        return self


class PillBoxSpec(ObjectSpec):
    """A box open at the top, split into compartments side by side, with one lid hinged along
    its back top edge (joint `lid_hinge`, opening upwards). Closed, the lid covers the body."""

    default_density_kg_m3: ClassVar[float] = 1050.0  # polystyrene

    kind: Literal["pill_box"]
    width_m: Length = Field(0.1, description="side to side (along y)")
    depth_m: Length = Field(0.05, description="front to back (along x)")
    height_m: Length = Field(0.025, description="floor to the top of the closed lid")
    wall_thickness_m: Length = Field(0.0015, description="walls, floor and dividers")
    lid_thickness_m: Length = Field(0.003, description="thickness of the lid, lying on the body's walls")
    compartments: Annotated[int, Field(ge=1, le=31)] = Field(1, description="compartments side by side (along y)")
    opening_limit_deg: Annotated[float, Field(gt=0, le=180)] = Field(
        110.0, description="how far the lid opens, from closed"
    )
    colour: Colour = Field("purple", description="colour: [r, g, b] in 0..1 (linear) or a name from NAMED_COLOURS")
    lid_colour: Colour | None = Field(None, description="default: the body's colour")

    @property
    def body_height_m(self) -> float:
        return self.height_m - self.lid_thickness_m

    @property
    def compartment_width_m(self) -> float:
        inner = self.width_m - 2 * self.wall_thickness_m
        return (inner - (self.compartments - 1) * self.wall_thickness_m) / self.compartments

    @model_validator(mode="after")
    def _geometry_possible(self) -> PillBoxSpec:
        t = self.wall_thickness_m
        if 2 * t >= min(self.width_m, self.depth_m):
            raise FieldError(("wall_thickness_m",), f"walls {t} m thick leave no room inside the box")
        if self.body_height_m <= t + _EPS_M:
            raise FieldError(
                ("lid_thickness_m",),
                f"lid {self.lid_thickness_m} m thick on a box {self.height_m} m high leaves no room under it",
            )
        if self.compartment_width_m <= t:
            raise FieldError(
                ("compartments",),
                f"{self.compartments} compartments leave each {self.compartment_width_m:.4f} m wide",
            )
        return self
