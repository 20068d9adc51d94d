"""A kitchen worktop: one slab laid over a run of base units, with cut-outs for a hob and a
sink (a sink's basin hangs in its cut-out). EN 1116 sizes: worktops 600 mm deep (or more),
their top 850 to 950 mm above the floor (900 mm is the common height), 28 to 40 mm thick.

The frame is every model's: origin at the centre of the slab's footprint on the floor, +x
out of its front edge; `left_m` from the slab's left end seen from in front.
"""

from __future__ import annotations

from typing import ClassVar, Literal

from pydantic import Field, model_validator

from homemodel.core.yaml_specs import FieldError
from modeller.specs.common import _EPS_M, Colour, Length, ObjectSpec, Offset, _Spec


class Cutout(_Spec):
    """A rectangular hole through the slab; a `sink` has a basin `basin_depth_m` deep under it."""

    kind: Literal["hob", "sink"]
    left_m: Offset = Field(description="from the slab's left end to the cut-out's left edge, seen from in front")
    from_front_m: Offset = Field(description="from the slab's front edge back to the cut-out's front edge")
    width_m: Length = Field(description="side to side")
    depth_m: Length = Field(description="front to back")
    basin_depth_m: Length = Field(0.18, description="sink: from the slab's top down to the basin's floor")


class WorktopSpec(ObjectSpec):
    """A worktop slab at `height_m` (its top surface) above the floor."""

    kind_label: ClassVar[str] = "worktop"
    default_density_kg_m3: ClassVar[float] = 700.0  # laminated chipboard

    kind: Literal["worktop"]
    width_m: Length = Field(1.8, description="length of the slab, left to right")
    depth_m: Length = Field(0.6, description="front edge to the wall")
    thickness_m: Length = 0.038
    height_m: Length = Field(0.9, description="floor to the slab's top surface")
    cutouts: list[Cutout] = []
    colour: Colour = "grey"
    basin_colour: Colour = "silver"

    @model_validator(mode="after")
    def _cutouts_fit(self) -> WorktopSpec:
        if self.thickness_m >= self.height_m:
            raise FieldError(("thickness_m",), f"a slab {self.thickness_m} m thick with its top {self.height_m} m up")
        for i, cut in enumerate(self.cutouts):
            # A cut-out's rim must leave the slab whole round it.
            if cut.left_m < _EPS_M or cut.left_m + cut.width_m > self.width_m - _EPS_M:
                raise FieldError(("cutouts", i, "left_m"), f"cut-out runs off the slab's {self.width_m} m length")
            if cut.from_front_m < _EPS_M or cut.from_front_m + cut.depth_m > self.depth_m - _EPS_M:
                raise FieldError(("cutouts", i, "from_front_m"), f"cut-out runs off the slab's {self.depth_m} m depth")
            if cut.kind == "sink" and cut.basin_depth_m >= self.height_m:
                raise FieldError(("cutouts", i, "basin_depth_m"), "the basin reaches the floor")
            for j, other in enumerate(self.cutouts[:i]):
                across = min(cut.left_m + cut.width_m, other.left_m + other.width_m) - max(cut.left_m, other.left_m)
                back = min(cut.from_front_m + cut.depth_m, other.from_front_m + other.depth_m) - max(
                    cut.from_front_m, other.from_front_m
                )
                if across > -_EPS_M and back > -_EPS_M:
                    raise FieldError(("cutouts", i), f"cut-out {i} meets cut-out {j}")
        return self

    def cutout_box_m(self, cut: Cutout) -> tuple[float, float, float, float]:
        """(x_min, x_max, y_min, y_max) of a cut-out in the model frame."""
        x_max = self.depth_m / 2 - cut.from_front_m
        y_min = -self.width_m / 2 + cut.left_m
        return x_max - cut.depth_m, x_max, y_min, y_min + cut.width_m
