"""Cabinets: a box open at the front with shelves, dividers, fixed panels, doors, drawers and
knobs on it. `CabinetSpec` holds what every cabinet-like kind shares (cupboards, wall cabinets,
wardrobes, and the appliances in `modeller.specs.appliances`); each kind adds its own parts.

Heights (`bottom_m` of a front, `height_m` of a shelf, a knob's `height_m`) are above the
floor, that is the model frame's z, for every kind; `left_m` is from the body's left outer
edge as seen from in front. The hinge line of a door is, by default, its hinge-side edge on
its outer face; `modeller.specs.hinges` moves it where the real hinges put it.

The parts are in `modeller.specs.cabinet_parts` and the box with its derived sizes in
`modeller.specs.cabinet_body`; the rules every cabinet must meet are in
`modeller.specs.cabinet_rules`, where its parts lie (shelf spans, drawer boxes, door bins) in
`modeller.specs.cabinet_geometry`. Those read the body and never this module, so there is no
import loop.
"""

from __future__ import annotations

import math
from typing import ClassVar, Literal

from pydantic import Field, ValidationError, model_validator

from homemodel.core.yaml_specs import FieldError
from modeller.specs.cabinet_body import CabinetBody
from modeller.specs.cabinet_geometry import shelf_span_m
from modeller.specs.cabinet_parts import DoorSpec
from modeller.specs.cabinet_rules import check_cabinet
from modeller.specs.common import _EPS_M, Length, Offset, _Spec


class CabinetSpec(CabinetBody):
    """A cabinet as specified: the kind's standard layout fills the fronts left out, then every
    cabinet rule (`modeller.specs.cabinet_rules`) and the kind's own checks must hold."""

    # ------------------------------------------------------------------ layout and checks

    def default_layout(self) -> None:
        """Fill `doors`, `drawers` and `panels` left out (None); a kind overrides this."""
        self.doors = [] if self.doors is None else self.doors
        self.drawers = [] if self.drawers is None else self.drawers
        self.panels = [] if self.panels is None else self.panels

    @model_validator(mode="after")
    def _geometry_possible(self) -> CabinetSpec:
        try:
            self.default_layout()
        except ValidationError as exc:
            first = exc.errors()[0]
            where = ".".join(str(part) for part in first["loc"])
            raise FieldError(
                (),
                f"the standard {self.kind_label} layout does not fit this size ({exc.title} {where}: {first['msg']}); "
                "give doors, drawers and panels",
            ) from None
        check_cabinet(self)
        self._check_kind()
        return self

    def _check_kind(self) -> None:
        """A kind's own checks, after the shared ones."""


def _split_width(width_m: float, count: int, gap_m: float) -> list[tuple[float, float]]:
    """(left_m, width_m) of `count` equal fronts across `width_m` with `gap_m` at the edges and between."""
    each = (width_m - (count + 1) * gap_m) / count
    return [(gap_m + k * (each + gap_m), each) for k in range(count)]


def side_by_side_doors(spec: CabinetSpec, bottom_m: float, top_m: float, *, max_door_m: float = 0.6) -> list[DoorSpec]:
    """The usual doors over `bottom_m..top_m`: one left-hinged if narrow, else pairs meeting in the middle."""
    count = max(1, math.ceil(spec.width_m / max_door_m))
    gap = spec.door_gap_m
    doors = []
    for k, (left, width) in enumerate(_split_width(spec.width_m, count, gap)):
        hinge = "left" if (count == 1 or k % 2 == 0) else "right"
        doors.append(
            DoorSpec(
                hinge=hinge, left_m=left, width_m=width, bottom_m=bottom_m + gap, height_m=top_m - bottom_m - 2 * gap
            )
        )
    return doors


class CupboardSpec(CabinetSpec):
    """A standing cupboard (a kitchen base unit, a sideboard). Default layout: doors over the front."""

    kind_label: ClassVar[str] = "cupboard"
    kind: Literal["cupboard"]

    def default_layout(self) -> None:
        if self.doors is None:
            self.doors = side_by_side_doors(self, self.carcass_bottom_m, self.top_m)
        super().default_layout()


class WallCabinetSpec(CabinetSpec):
    """A cabinet hung on the wall: its body spans `mount_height_m` .. `mount_height_m + height_m`.

    The model frame's origin stays on the floor under the body's footprint centre, so the map
    places it like any other large object; every height in the spec is above the floor.
    Default layout: doors over the front.
    """

    kind_label: ClassVar[str] = "wall cabinet"
    kind: Literal["wall_cabinet"]
    mount_height_m: Offset = Field(1.4, description="height of the body's underside above the floor")
    depth_m: Length = Field(0.33, description="depth of the body, without doors and handles")
    height_m: Length = Field(0.7, description="height of the body itself (not above the floor)")

    @property
    def base_m(self) -> float:
        return self.mount_height_m

    @property
    def top_m(self) -> float:
        return self.mount_height_m + self.height_m

    def default_layout(self) -> None:
        if self.doors is None:
            self.doors = side_by_side_doors(self, self.base_m, self.top_m)
        super().default_layout()

    def _check_kind(self) -> None:
        if self.plinth_height_m > 0:
            raise FieldError(("plinth_height_m",), "a wall cabinet hangs; it has no plinth")


class Rail(_Spec):
    """A round hanging rail from one side to the other (or to a divider)."""

    height_m: Length = Field(description="height of the rail's axis above the floor")
    diameter_m: Length = 0.025
    left_m: Offset | None = Field(
        None, description="from the body's left edge to the rail's left end; default: the left wall"
    )
    width_m: Length | None = Field(None, description="rail length; default: to the right wall")
    from_back_m: Length | None = Field(
        None, description="rail axis from the back wall's inner face; default: mid-depth"
    )


class WardrobeSpec(CabinetSpec):
    """A wardrobe or closet: a tall cupboard with hanging rails. Default layout: doors over the front."""

    kind_label: ClassVar[str] = "wardrobe"
    kind: Literal["wardrobe"]
    width_m: Length = 1.0
    depth_m: Length = Field(0.58, description="depth of the body, without doors and handles")
    height_m: Length = Field(2.0, description="floor to the top of the body")
    plinth_height_m: Offset = 0.06
    rails: list[Rail] = []

    def default_layout(self) -> None:
        if self.doors is None:
            self.doors = side_by_side_doors(self, self.carcass_bottom_m, self.top_m)
        super().default_layout()

    def rail_span_m(self, rail: Rail) -> tuple[float, float, float]:
        """(left, right) from the body's left edge, and the axis' x in the model frame."""
        t = self.wall_thickness_m
        left = t if rail.left_m is None else rail.left_m
        right = self.width_m - t if rail.width_m is None else left + rail.width_m
        from_back = self.inner_depth_m / 2 if rail.from_back_m is None else rail.from_back_m
        return left, right, self.back_inner_x_m + from_back

    def _check_kind(self) -> None:
        t = self.wall_thickness_m
        for i, rail in enumerate(self.rails):
            left, right, x = self.rail_span_m(rail)
            r = rail.diameter_m / 2
            if left < t - _EPS_M or right > self.width_m - t + _EPS_M or right <= left:
                raise FieldError(("rails", i, "width_m"), f"rail spans {left:.3f}..{right:.3f} m, not inside the body")
            if rail.height_m + r > self.inner_top_m + _EPS_M or rail.height_m - r < self.inner_floor_m - _EPS_M:
                raise FieldError(("rails", i, "height_m"), f"rail at {rail.height_m} m is not inside the body")
            if x - r < self.back_inner_x_m - _EPS_M or x + r > self.depth_m / 2 + _EPS_M:
                raise FieldError(("rails", i, "from_back_m"), "rail is not between the back wall and the front")
            for k, divider in enumerate(self.dividers):
                if left < divider.left_m + t - _EPS_M and right > divider.left_m + _EPS_M:
                    raise FieldError(("rails", i, "width_m"), f"rail runs through divider {k} at {divider.left_m} m")
            for k, shelf in enumerate(self.shelves):
                s_left, s_right, depth = shelf_span_m(self, shelf)
                overlaps = s_left < right and s_right > left
                in_depth = x - r < self.back_inner_x_m + depth
                if (
                    overlaps
                    and in_depth
                    and shelf.height_m - self.shelf_board_m(shelf) < rail.height_m + r
                    and shelf.height_m > rail.height_m - r
                ):
                    raise FieldError(("rails", i, "height_m"), f"rail runs through shelf {k}")
