"""Small household objects: cups."""

from __future__ import annotations

from typing import ClassVar, Literal

from pydantic import Field, model_validator

from homemodel.yaml_specs import FieldError
from modeller.specs.common import _EPS_M, Colour, Length, ObjectSpec, _Spec


class CupHandle(_Spec):
    """A torus segment on the cup's +x side, its ends buried in the middle of the wall."""

    height_m: Length = Field(description="height of the handle's centre above the floor")
    span_m: Length = Field(description="how far the handle sticks out from the outer wall")
    thickness_m: Length = Field(description="diameter of the handle's round section")


class CupSpec(ObjectSpec):
    default_density_kg_m3: ClassVar[float] = 2400.0  # stoneware

    kind: Literal["cup"]
    height_m: Length
    outer_diameter_m: Length
    wall_thickness_m: Length
    bottom_thickness_m: Length
    handle: CupHandle | None = None
    colour: Colour = "white"

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
            low, high = self.handle.height_m - major - minor, self.handle.height_m + major + minor
            if low < -_EPS_M or high > self.height_m + _EPS_M:
                raise FieldError(
                    ("handle", "height_m"),
                    f"handle spans {low:.3f}..{high:.3f} m above the floor on a cup {self.height_m} m high",
                )
        return self
