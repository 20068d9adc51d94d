"""Cutlery lying flat on a table: spoons, forks and knives.

Frame: the object lies on z = 0 with its length along x, the working end (bowl, tines,
blade) towards +x and the handle's end at x = -length_m / 2; origin at the centre of the
footprint. A spoon's or fork's handle narrows from `handle_width_m` at its end to
`neck_width_m` where it meets the working end; a knife's handle is one width.
"""

from __future__ import annotations

from typing import Annotated, ClassVar, Literal

from pydantic import Field, model_validator

from homemodel.core.yaml_specs import FieldError
from modeller.specs.common import Colour, Length, ObjectSpec


class _Cutlery(ObjectSpec):
    default_density_kg_m3: ClassVar[float] = 7900.0  # stainless steel

    handle_width_m: Length = Field(0.012, description="width of the handle at its end")
    handle_thickness_m: Length = Field(0.0025, description="thickness of the handle (vertically, lying flat)")
    colour: Colour = Field("silver", description="colour: [r, g, b] in 0..1 (linear) or a name from NAMED_COLOURS")

    def _check_handle_left(self, end_length_m: float, end_field: str) -> None:
        length_m = self.length_m  # type: ignore[attr-defined]
        if end_length_m >= length_m:
            raise FieldError((end_field,), f"{end_length_m} m long on a piece {length_m} m long leaves no handle")


class _TaperedCutlery(_Cutlery):
    neck_width_m: Length = Field(0.006, description="width of the handle where it meets the working end")

    def _check_neck(self, end_width_m: float) -> None:
        if self.neck_width_m > min(end_width_m, self.handle_width_m):
            raise FieldError(
                ("neck_width_m",),
                f"neck {self.neck_width_m} m wide is wider than the handle ({self.handle_width_m} m) "
                f"or the end it holds ({end_width_m} m)",
            )


class SpoonSpec(_TaperedCutlery):
    """A bowl (an elliptic dish) and a handle rising from the table to the bowl's back rim."""

    kind: Literal["spoon"]
    length_m: Length = Field(0.17, description="overall, tip of the bowl to the end of the handle")
    bowl_length_m: Length = Field(0.055, description="the bowl's length along the spoon (x)")
    bowl_width_m: Length = Field(0.038, description="the bowl's width across (y)")
    bowl_depth_m: Length = Field(0.01, description="table to the bowl's rim")
    bowl_thickness_m: Length = Field(0.0015, description="thickness of the bowl's metal")

    @model_validator(mode="after")
    def _geometry_possible(self) -> SpoonSpec:
        self._check_handle_left(self.bowl_length_m, "bowl_length_m")
        self._check_neck(self.bowl_width_m)
        if self.bowl_thickness_m >= self.bowl_depth_m:
            raise FieldError(
                ("bowl_thickness_m",), f"bowl {self.bowl_thickness_m} m thick fills a bowl {self.bowl_depth_m} m deep"
            )
        if self.bowl_thickness_m * 2 >= min(self.bowl_width_m, self.bowl_length_m):
            raise FieldError(("bowl_thickness_m",), f"bowl {self.bowl_thickness_m} m thick leaves no hollow")
        if self.handle_thickness_m > self.bowl_depth_m:
            raise FieldError(
                ("handle_thickness_m",),
                f"handle {self.handle_thickness_m} m thick rises above the bowl's rim ({self.bowl_depth_m} m)",
            )
        return self


class ForkSpec(_TaperedCutlery):
    """A flat head: a plate widening from the neck, then straight tines to the tip."""

    kind: Literal["fork"]
    length_m: Length = Field(0.19, description="overall, tips of the tines to the end of the handle")
    head_length_m: Length = Field(0.058, description="tips of the tines to the neck")
    head_width_m: Length = Field(0.025, description="across the tines")
    tine_length_m: Length = Field(0.035, description="tips to the tines' roots")
    tines: Annotated[int, Field(ge=2, le=6)] = Field(4, description="how many tines; tines and gaps are equally wide")
    thickness_m: Length = Field(0.002, description="thickness of the head and tines")

    @model_validator(mode="after")
    def _geometry_possible(self) -> ForkSpec:
        self._check_handle_left(self.head_length_m, "head_length_m")
        self._check_neck(self.head_width_m)
        if self.tine_length_m >= self.head_length_m:
            raise FieldError(
                ("tine_length_m",), f"tines {self.tine_length_m} m long in a head {self.head_length_m} m long"
            )
        return self

    @property
    def tine_width_m(self) -> float:
        """Tines and the gaps between them are equally wide."""
        return self.head_width_m / (2 * self.tines - 1)


class KnifeSpec(_Cutlery):
    """A flat blade with a round tip on a handle of one width (a table knife)."""

    kind: Literal["knife"]
    length_m: Length = Field(0.22, description="overall, tip of the blade to the end of the handle")
    blade_length_m: Length = Field(0.115, description="tip to where the blade meets the handle")
    blade_width_m: Length = Field(
        0.02, description="the blade's width across (y); its tip is a half disc of this diameter"
    )
    blade_thickness_m: Length = Field(0.0015, description="the blade's thickness, lying flat")
    handle_width_m: Length = Field(0.016, description="width of the handle, end to end")
    handle_thickness_m: Length = Field(0.009, description="thickness of the handle (vertically, lying flat)")

    @model_validator(mode="after")
    def _geometry_possible(self) -> KnifeSpec:
        self._check_handle_left(self.blade_length_m, "blade_length_m")
        if self.blade_length_m < self.blade_width_m / 2:
            raise FieldError(("blade_length_m",), f"blade {self.blade_length_m} m long is shorter than its round tip")
        if self.blade_thickness_m > self.handle_thickness_m:
            raise FieldError(
                ("blade_thickness_m",),
                f"blade {self.blade_thickness_m} m thick is thicker than the handle ({self.handle_thickness_m} m)",
            )
        return self
