"""Cupboards: a box open at the front with shelves, doors and drawers on it."""

from __future__ import annotations

from typing import Annotated, ClassVar, Literal

from pydantic import Field, model_validator

from homemodel.yaml_specs import FieldError
from modeller.specs.common import _EPS_M, Colour, Length, ObjectSpec, Offset, _Spec
from modeller.specs.handles import BarHandle, DoorHandle, DrawerHandle


class Front(_Spec):
    """A door or drawer front: a rectangle on the body's front, placed as seen from in front."""

    width_m: Length
    height_m: Length
    bottom_m: Offset = Field(description="height of the front's lower edge above the floor")
    left_m: Offset = Field(description="from the body's left edge to the front's left edge, seen from in front")

    def _check_handle(self, handle: BarHandle, offset_m: tuple[float, float], across_field: str) -> None:
        across, up = offset_m
        half_across, half_up = handle.half_extent_m
        if across - half_across < -_EPS_M or across + half_across > self.width_m + _EPS_M:
            raise FieldError(
                ("handle", across_field),
                f"handle bar spans {across - half_across:.3f}..{across + half_across:.3f} m across a "
                f"{self.width_m} m wide front",
            )
        if up - half_up < -_EPS_M or up + half_up > self.height_m + _EPS_M:
            raise FieldError(
                ("handle", "height_m"),
                f"handle bar spans {up - half_up:.3f}..{up + half_up:.3f} m above the bottom edge of a "
                f"{self.height_m} m high front",
            )


class DoorSpec(Front):
    hinge: Literal["left", "right"] = Field(description="hinge side, seen from in front")
    opening_limit_deg: Annotated[float, Field(gt=0, le=180)] = 100.0
    handle: DoorHandle = Field(default_factory=DoorHandle)

    def handle_offset_m(self) -> tuple[float, float]:
        """Bar centre from the door's left edge (seen from in front) and above its bottom edge."""
        from_free = self.handle.from_free_edge_m
        across = self.width_m - from_free if self.hinge == "left" else from_free
        up = self.height_m / 2 if self.handle.height_m is None else self.handle.height_m
        return across, up

    @model_validator(mode="after")
    def _handle_on_door(self) -> DoorSpec:
        self._check_handle(self.handle, self.handle_offset_m(), "from_free_edge_m")
        return self


class DrawerSpec(Front):
    depth_m: Length = Field(description="depth of the drawer box behind the front")
    travel_m: Length = Field(description="how far the drawer pulls out")
    handle: DrawerHandle = Field(default_factory=DrawerHandle)

    def handle_offset_m(self) -> tuple[float, float]:
        """Bar centre from the front's left edge (seen from in front) and above its bottom edge."""
        across = self.width_m / 2 if self.handle.from_left_m is None else self.handle.from_left_m
        up = self.height_m / 2 if self.handle.height_m is None else self.handle.height_m
        return across, up

    @model_validator(mode="after")
    def _drawer_fits(self) -> DrawerSpec:
        self._check_handle(self.handle, self.handle_offset_m(), "from_left_m")
        if self.travel_m > self.depth_m + _EPS_M:
            raise FieldError(
                ("travel_m",), f"drawer travels {self.travel_m} m but its box is only {self.depth_m} m deep"
            )
        return self


class Shelf(_Spec):
    height_m: Length = Field(description="height of the shelf's top surface above the floor")


class CupboardSpec(ObjectSpec):
    """A box at the real outer size with its front open, walls of one thickness, fronts on it.

    Doors and drawer fronts sit `door_gap_m` in front of the body's front plane
    (x = depth_m / 2), `door_thickness_m` thick.
    """

    default_density_kg_m3: ClassVar[float] = 650.0  # chipboard

    kind: Literal["cupboard"]
    width_m: Length
    depth_m: Length = Field(description="depth of the body, without doors and handles")
    height_m: Length
    wall_thickness_m: Length = 0.018
    plinth_height_m: Offset = 0.0
    plinth_recess_m: Offset = Field(0.05, description="how far the plinth's front sits back from the body's front")
    door_thickness_m: Length = 0.018
    door_gap_m: Offset = Field(0.002, description="clearance between the body and its doors and drawers")
    shelves: list[Shelf] = []
    doors: list[DoorSpec] = []
    drawers: list[DrawerSpec] = []
    colour: Colour = "white"
    handle_colour: Colour = "silver"

    @property
    def inner_depth_m(self) -> float:
        return self.depth_m - self.wall_thickness_m

    def drawer_box_bounds_m(self, drawer: DrawerSpec) -> tuple[float, float, float, float]:
        """(y_min, y_max, z_min, z_max) of a drawer's box: behind its front, inside the body."""
        t, gap = self.wall_thickness_m, self.door_gap_m
        # Seen from in front, the body's left edge is at y = -width/2, so a front spans
        # y = -width/2 + left_m .. -width/2 + left_m + width_m.
        y_min = max(-self.width_m / 2 + drawer.left_m, -self.width_m / 2 + t) + gap
        y_max = min(-self.width_m / 2 + drawer.left_m + drawer.width_m, self.width_m / 2 - t) - gap
        z_min = max(drawer.bottom_m, self.plinth_height_m + t) + gap
        z_max = min(drawer.bottom_m + drawer.height_m, self.height_m - t) - gap
        return y_min, y_max, z_min, z_max

    @model_validator(mode="after")
    def _geometry_possible(self) -> CupboardSpec:
        self._check_walls()
        self._check_shelves()
        fronts = [("doors", i, f) for i, f in enumerate(self.doors)] + [
            ("drawers", i, f) for i, f in enumerate(self.drawers)
        ]
        for group, i, front in fronts:
            self._check_front_on_body(group, i, front)
        self._check_no_overlap(fronts)
        for i, drawer in enumerate(self.drawers):
            self._check_drawer(i, drawer)
        return self

    def _check_walls(self) -> None:
        t = self.wall_thickness_m
        carcass_height = self.height_m - self.plinth_height_m
        if 2 * t >= self.width_m:
            raise FieldError(
                ("wall_thickness_m",), f"walls {t} m thick leave no room inside a {self.width_m} m wide cupboard"
            )
        if t >= self.depth_m:
            raise FieldError(
                ("wall_thickness_m",), f"a back wall {t} m thick leaves no room in a {self.depth_m} m deep cupboard"
            )
        if 2 * t >= carcass_height:
            raise FieldError(
                ("plinth_height_m",) if self.plinth_height_m > 0 else ("wall_thickness_m",),
                f"walls {t} m thick leave no room in a body {carcass_height:.3f} m high above the plinth",
            )
        if self.plinth_height_m > 0 and self.plinth_recess_m + 2 * t >= self.depth_m:
            raise FieldError(
                ("plinth_recess_m",), f"a plinth set back {self.plinth_recess_m} m leaves no plinth under the body"
            )

    def _check_shelves(self) -> None:
        t = self.wall_thickness_m
        floor_m, ceiling_m = self.plinth_height_m + t, self.height_m - t
        for i, shelf in enumerate(self.shelves):
            if shelf.height_m > ceiling_m + _EPS_M:
                raise FieldError(
                    ("shelves", i, "height_m"),
                    f"shelf at {shelf.height_m} m is above the body's inside top at {ceiling_m:.3f} m",
                )
            if shelf.height_m - t < floor_m - _EPS_M:
                raise FieldError(
                    ("shelves", i, "height_m"),
                    f"shelf at {shelf.height_m} m ({t} m thick) is below the body's inside floor at {floor_m:.3f} m",
                )

    def _check_front_on_body(self, group: str, i: int, front: Front) -> None:
        what = group[:-1]
        if front.width_m > self.width_m + _EPS_M:
            raise FieldError(
                (group, i, "width_m"), f"{what} is {front.width_m} m wide but the cupboard is {self.width_m} m"
            )
        if front.left_m + front.width_m > self.width_m + _EPS_M:
            raise FieldError(
                (group, i, "left_m"),
                f"{what} spans {front.left_m}..{front.left_m + front.width_m:.3f} m from the left edge "
                f"but the cupboard is {self.width_m} m wide",
            )
        if front.height_m > self.height_m + _EPS_M:
            raise FieldError(
                (group, i, "height_m"), f"{what} is {front.height_m} m high but the cupboard is {self.height_m} m"
            )
        if front.bottom_m + front.height_m > self.height_m + _EPS_M:
            raise FieldError(
                (group, i, "bottom_m"),
                f"{what} reaches {front.bottom_m + front.height_m:.3f} m above the floor "
                f"but the cupboard is {self.height_m} m high",
            )

    @staticmethod
    def _check_no_overlap(fronts: list[tuple[str, int, Front]]) -> None:
        for k, (group, i, a) in enumerate(fronts):
            for other_group, j, b in fronts[:k]:
                across = min(a.left_m + a.width_m, b.left_m + b.width_m) - max(a.left_m, b.left_m)
                up = min(a.bottom_m + a.height_m, b.bottom_m + b.height_m) - max(a.bottom_m, b.bottom_m)
                if across > _EPS_M and up > _EPS_M:
                    raise FieldError(
                        (group, i),
                        f"{group[:-1]} {i} overlaps {other_group[:-1]} {j} by {across:.3f} x {up:.3f} m",
                    )

    def _check_drawer(self, i: int, drawer: DrawerSpec) -> None:
        if drawer.depth_m > self.inner_depth_m + _EPS_M:
            raise FieldError(
                ("drawers", i, "depth_m"),
                f"drawer box is {drawer.depth_m} m deep but the body is {self.inner_depth_m:.3f} m deep inside",
            )
        y_min, y_max, z_min, z_max = self.drawer_box_bounds_m(drawer)
        t = self.wall_thickness_m
        if y_max - y_min <= 2 * t:
            raise FieldError(
                ("drawers", i, "width_m"), f"drawer front leaves a box {y_max - y_min:.3f} m wide inside the body"
            )
        if z_max - z_min <= t:
            raise FieldError(
                ("drawers", i, "height_m"), f"drawer front leaves a box {z_max - z_min:.3f} m high inside the body"
            )
        for k, shelf in enumerate(self.shelves):
            if shelf.height_m > z_min and shelf.height_m - t < z_max:
                raise FieldError(
                    ("shelves", k, "height_m"),
                    f"shelf at {shelf.height_m} m cuts through drawer {i}'s box ({z_min:.3f}..{z_max:.3f} m)",
                )
