"""Cabinets: a box open at the front with shelves, dividers, fixed panels, doors, drawers and
knobs on it. `CabinetSpec` holds what every cabinet-like kind shares (cupboards, wall cabinets,
wardrobes, and the appliances in `modeller.specs.appliances`); each kind adds its own parts.

Heights (`bottom_m` of a front, `height_m` of a shelf, a knob's `height_m`) are above the
floor, that is the model frame's z, for every kind; `left_m` is from the body's left outer
edge as seen from in front. The hinge line of a door is its hinge-side edge on its outer face.
"""

from __future__ import annotations

import math
from typing import Annotated, ClassVar, Literal

import numpy as np
from pydantic import Field, ValidationError, model_validator

from homemodel.core.yaml_specs import FieldError
from modeller.specs.common import _EPS_M, Colour, Length, ObjectSpec, Offset, _Spec
from modeller.specs.handles import (
    ControlKnob,
    DoorHandle,
    DrawerHandle,
    Handle,
    Orientation,
)

Hinge = Literal["left", "right", "top", "bottom"]
# Dark glass for door windows and hob plates.
GLASS_COLOUR = (0.03, 0.035, 0.04)
# Angles at which a door's sweep is checked against the body (door shelves).
_SWEEP_SAMPLES = 91


class Front(_Spec):
    """A rectangle on the body's front, placed as seen from in front."""

    width_m: Length
    height_m: Length
    bottom_m: Offset = Field(description="height of the lower edge above the floor")
    left_m: Offset = Field(description="from the body's left edge to the rectangle's left edge, seen from in front")

    @property
    def right_m(self) -> float:
        return self.left_m + self.width_m

    @property
    def top_m(self) -> float:
        return self.bottom_m + self.height_m

    def _check_handle(self, handle: Handle, centre_m: tuple[float, float], orientation: Orientation) -> None:
        """The handle's footprint (centre from the left and bottom edges) must lie on the front."""
        (across, up), (half_across, half_up) = centre_m, handle.half_extent_m(orientation)
        across_field, up_field = self._handle_fields()
        if across - half_across < -_EPS_M or across + half_across > self.width_m + _EPS_M:
            raise FieldError(
                ("handle", across_field),
                f"{handle.type} handle spans {across - half_across:.3f}..{across + half_across:.3f} m across a "
                f"{self.width_m} m wide front",
            )
        if up - half_up < -_EPS_M or up + half_up > self.height_m + _EPS_M:
            raise FieldError(
                ("handle", up_field),
                f"{handle.type} handle spans {up - half_up:.3f}..{up + half_up:.3f} m above the bottom edge of a "
                f"{self.height_m} m high front",
            )

    def _handle_fields(self) -> tuple[str, str]:
        return "from_left_m", "height_m"


class Window(_Spec):
    """A glass pane in a door (an oven's, a microwave's, a washing machine's porthole)."""

    margin_m: Offset = Field(0.06, description="from the door's edges (a round door's rim) to the glass")
    colour: Colour = GLASS_COLOUR


class DoorShelf(_Spec):
    """A shelf (bin) on a door's inner face, as in a fridge door: an open box behind the door."""

    height_m: Offset = Field(description="height of the bin's floor above the door's bottom edge")
    depth_m: Length = Field(0.1, description="how far the bin reaches in from the door's inner face")
    lip_height_m: Length = Field(0.06, description="height of the bin's walls")
    margin_m: Offset = Field(0.06, description="from each side edge of the door to the bin's side")


class DoorSpec(Front):
    """A door turning about its hinge line: the hinge-side edge on its outer face.

    `left`/`right` hinges are vertical (seen from in front); `bottom` opens down (an oven),
    `top` opens up (a wall cabinet's flap). A `round` door (a washing machine's) is a disc
    of diameter `width_m` = `height_m` in that square, its hinge line tangent to it.
    """

    hinge: Hinge = Field(description="hinge side, seen from in front")
    shape: Literal["rectangle", "round"] = "rectangle"
    opening_limit_deg: Annotated[float, Field(gt=0, le=180)] = 100.0
    handle: DoorHandle = Field(default_factory=DoorHandle)
    window: Window | None = None
    shelves: list[DoorShelf] = Field([], description="bins on the door's inner face (a fridge door's)")

    @property
    def side_hinged(self) -> bool:
        return self.hinge in ("left", "right")

    def handle_orientation(self) -> Orientation:
        return self.handle.direction("vertical" if self.side_hinged else "horizontal")

    def handle_offset_m(self) -> tuple[float, float]:
        """Handle centre from the door's left edge (seen from in front) and above its bottom edge."""
        from_free = self.handle.from_free_edge_m
        if self.side_hinged:
            across = self.width_m - from_free if self.hinge == "left" else from_free
            up = self.height_m / 2 if self.handle.height_m is None else self.handle.height_m
        else:
            across = self.width_m / 2 if self.handle.from_left_m is None else self.handle.from_left_m
            up = self.height_m - from_free if self.hinge == "bottom" else from_free
        return across, up

    def _handle_fields(self) -> tuple[str, str]:
        return ("from_free_edge_m", "height_m") if self.side_hinged else ("from_left_m", "from_free_edge_m")

    @model_validator(mode="after")
    def _door_possible(self) -> DoorSpec:
        if self.shape == "round" and abs(self.width_m - self.height_m) > _EPS_M:
            raise FieldError(
                ("height_m",),
                f"a round door is {self.width_m} m wide, so it is {self.width_m} m high, not {self.height_m}",
            )
        if self.side_hinged and self.handle.from_left_m is not None:
            raise FieldError(("handle", "from_left_m"), f"a {self.hinge}-hinged door's handle is placed by height_m")
        if not self.side_hinged and self.handle.height_m is not None:
            raise FieldError(("handle", "height_m"), f"a {self.hinge}-hinged door's handle is placed by from_left_m")
        centre = self.handle_offset_m()
        self._check_handle(self.handle, centre, self.handle_orientation())
        if self.shape == "round":
            half_across, half_up = self.handle.half_extent_m(self.handle_orientation())
            reach = math.hypot(
                abs(centre[0] - self.width_m / 2) + half_across, abs(centre[1] - self.height_m / 2) + half_up
            )
            if reach > self.width_m / 2 + _EPS_M:
                raise FieldError(
                    ("handle", "from_free_edge_m"),
                    f"{self.handle.type} handle reaches {reach:.3f} m from the centre of a round door "
                    f"{self.width_m / 2:.3f} m in radius",
                )
        if self.window is not None and 2 * self.window.margin_m >= min(self.width_m, self.height_m):
            raise FieldError(
                ("window", "margin_m"),
                f"a window {self.window.margin_m} m in from the edges leaves no glass in a "
                f"{self.width_m} x {self.height_m} m door",
            )
        for k, shelf in enumerate(self.shelves):
            if not self.side_hinged:
                raise FieldError(("shelves", k), f"door shelves need a side-hinged door, not a {self.hinge}-hinged one")
            if 2 * shelf.margin_m >= self.width_m:
                raise FieldError(("shelves", k, "margin_m"), f"leaves no bin on a {self.width_m} m wide door")
            if shelf.height_m + shelf.lip_height_m > self.height_m + _EPS_M:
                raise FieldError(
                    ("shelves", k, "height_m"),
                    f"bin reaches {shelf.height_m + shelf.lip_height_m:.3f} m up a {self.height_m} m high door",
                )
        return self


class DrawerSpec(Front):
    """A drawer: a front with an open box behind it, sliding straight out (+x)."""

    depth_m: Length = Field(description="depth of the drawer box behind the front")
    travel_m: Length = Field(description="how far the drawer pulls out")
    handle: DrawerHandle = Field(default_factory=DrawerHandle)

    def handle_orientation(self) -> Orientation:
        return self.handle.direction("horizontal")

    def handle_offset_m(self) -> tuple[float, float]:
        """Handle centre from the front's left edge (seen from in front) and above its bottom edge."""
        across = self.width_m / 2 if self.handle.from_left_m is None else self.handle.from_left_m
        up = self.height_m / 2 if self.handle.height_m is None else self.handle.height_m
        return across, up

    @model_validator(mode="after")
    def _drawer_fits(self) -> DrawerSpec:
        self._check_handle(self.handle, self.handle_offset_m(), self.handle_orientation())
        if self.travel_m > self.depth_m + _EPS_M:
            raise FieldError(
                ("travel_m",), f"drawer travels {self.travel_m} m but its box is only {self.depth_m} m deep"
            )
        return self


class Shelf(_Spec):
    """A fixed shelf, as thick as the walls, from the back wall forward."""

    height_m: Length = Field(description="height of the shelf's top surface above the floor")
    left_m: Offset | None = Field(
        None, description="from the body's left edge to the shelf's left end; default: the left wall"
    )
    width_m: Length | None = Field(None, description="length side to side; default: to the right wall")
    depth_m: Length | None = Field(None, description="from the back wall's inner face forward; default: to the front")


class Divider(_Spec):
    """A vertical partition, as thick as the walls, from the back wall to the front, floor to top."""

    left_m: Offset = Field(description="from the body's left edge to the divider's left face")


class Hole(_Spec):
    """A round opening through a panel (a washing machine's drum mouth)."""

    centre_left_m: Offset = Field(description="centre from the body's left edge")
    centre_height_m: Offset = Field(description="centre above the floor")
    diameter_m: Length


class Panel(Front):
    """A fixed panel flush with the body's front (a control panel, a kick plate), as thick as the walls."""

    hole: Hole | None = None
    colour: Colour | None = Field(None, description="default: the body's colour")


class CabinetSpec(ObjectSpec):
    """A box at the real outer size with its front open, walls of one thickness, parts on it.

    Doors and drawer fronts sit `door_gap_m` in front of the body's front plane
    (x = depth_m / 2), `door_thickness_m` thick. Fronts must not overlap each other nor
    panels, except that a door may close in front of a panel (not of a knob on it).
    `doors`, `drawers` and `panels` left out take the kind's standard layout for the size.
    """

    kind_label: ClassVar[str] = "cabinet"
    default_density_kg_m3: ClassVar[float] = 650.0  # chipboard

    width_m: Length = 0.8
    depth_m: Length = Field(0.45, description="depth of the body, without doors and handles")
    height_m: Length = Field(0.9, description="floor to the top of the body")
    wall_thickness_m: Length = 0.018
    plinth_height_m: Offset = 0.0
    plinth_recess_m: Offset = Field(0.05, description="how far the plinth's front sits back from the body's front")
    door_thickness_m: Length = 0.018
    door_gap_m: Offset = Field(0.002, description="clearance between the body and its doors and drawers")
    shelves: list[Shelf] = []
    dividers: list[Divider] = []
    panels: list[Panel] | None = None
    doors: list[DoorSpec] | None = None
    drawers: list[DrawerSpec] | None = None
    knobs: list[ControlKnob] = []
    colour: Colour = "white"
    handle_colour: Colour = "silver"

    # ------------------------------------------------------------------ derived sizes

    @property
    def base_m(self) -> float:
        """Height of the body's underside above the floor (a wall cabinet hangs)."""
        return 0.0

    @property
    def top_m(self) -> float:
        """Height of the body's top above the floor."""
        return self.height_m

    @property
    def carcass_bottom_m(self) -> float:
        return self.base_m + self.plinth_height_m

    @property
    def carcass_top_m(self) -> float:
        """Top of the open box (below a hob plate, say)."""
        return self.top_m

    @property
    def inner_depth_m(self) -> float:
        return self.depth_m - self.wall_thickness_m

    @property
    def inner_floor_m(self) -> float:
        return self.carcass_bottom_m + self.wall_thickness_m

    @property
    def inner_top_m(self) -> float:
        return self.carcass_top_m - self.wall_thickness_m

    def shelf_span_m(self, shelf: Shelf) -> tuple[float, float, float]:
        """(left, right) from the body's left edge and depth from the back wall's inner face."""
        t = self.wall_thickness_m
        left = t if shelf.left_m is None else shelf.left_m
        right = self.width_m - t if shelf.width_m is None else left + shelf.width_m
        return left, right, self.inner_depth_m if shelf.depth_m is None else shelf.depth_m

    def drawer_box_bounds_m(self, drawer: DrawerSpec) -> tuple[float, float, float, float]:
        """(y_min, y_max, z_min, z_max) of a drawer's box: behind its front, inside the body
        between the walls or dividers either side of the front's middle."""
        t, gap = self.wall_thickness_m, self.door_gap_m
        middle = drawer.left_m + drawer.width_m / 2
        inner_left = max([t] + [d.left_m + t for d in self.dividers if d.left_m + t <= middle])
        inner_right = min([self.width_m - t] + [d.left_m for d in self.dividers if d.left_m >= middle])
        # Seen from in front, the body's left edge is at y = -width/2.
        y_min = -self.width_m / 2 + max(drawer.left_m, inner_left) + gap
        y_max = -self.width_m / 2 + min(drawer.right_m, inner_right) - gap
        z_min = max(drawer.bottom_m, self.inner_floor_m) + gap
        z_max = min(drawer.top_m, self.inner_top_m) - gap
        return y_min, y_max, z_min, z_max

    def front_x_m(self) -> float:
        """x of the fronts' outer faces (closed)."""
        return self.depth_m / 2 + self.door_gap_m + self.door_thickness_m

    def door_shelf_box_m(self, door: DoorSpec, shelf: DoorShelf) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) corners of a closed door's bin in the model frame."""
        inner_x = self.depth_m / 2 + self.door_gap_m
        y0 = -self.width_m / 2 + door.left_m + shelf.margin_m
        y1 = -self.width_m / 2 + door.right_m - shelf.margin_m
        z0 = door.bottom_m + shelf.height_m
        return np.array([inner_x - shelf.depth_m, y0, z0]), np.array([inner_x, y1, z0 + shelf.lip_height_m])

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
                f"the standard {self._what()} layout does not fit this size ({exc.title} {where}: {first['msg']}); "
                "give doors, drawers and panels",
            ) from None
        self._check_walls()
        self._check_shelves_and_dividers()
        fronts = [("doors", i, f) for i, f in enumerate(self.doors)] + [
            ("drawers", i, f) for i, f in enumerate(self.drawers)
        ]
        placed = fronts + [("panels", i, p) for i, p in enumerate(self.panels)]
        for group, i, front in placed:
            self._check_on_body(group, i, front)
        self._check_no_overlap(placed)
        for i, drawer in enumerate(self.drawers):
            self._check_drawer(i, drawer)
        for i, door in enumerate(self.doors):
            self._check_door(i, door)
        for i, panel in enumerate(self.panels):
            self._check_panel(i, panel)
        self._check_knobs()
        self._check_kind()
        return self

    def _check_kind(self) -> None:
        """A kind's own checks, after the shared ones."""

    def _what(self) -> str:
        return self.kind_label

    def _check_walls(self) -> None:
        t = self.wall_thickness_m
        carcass_height = self.carcass_top_m - self.carcass_bottom_m
        if 2 * t >= self.width_m:
            raise FieldError(
                ("wall_thickness_m",), f"walls {t} m thick leave no room inside a {self.width_m} m wide {self._what()}"
            )
        if t >= self.depth_m:
            raise FieldError(
                ("wall_thickness_m",),
                f"a back wall {t} m thick leaves no room in a {self.depth_m} m deep {self._what()}",
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

    def _check_shelves_and_dividers(self) -> None:
        t = self.wall_thickness_m
        for i, divider in enumerate(self.dividers):
            if divider.left_m < t - _EPS_M or divider.left_m + t > self.width_m - t + _EPS_M:
                raise FieldError(
                    ("dividers", i, "left_m"),
                    f"divider at {divider.left_m} m is not between the side walls of a {self.width_m} m wide body",
                )
            for j, other in enumerate(self.dividers[:i]):
                if abs(other.left_m - divider.left_m) < t - _EPS_M:
                    raise FieldError(("dividers", i, "left_m"), f"divider {i} overlaps divider {j}")
        for i, shelf in enumerate(self.shelves):
            if shelf.height_m > self.inner_top_m + _EPS_M:
                raise FieldError(
                    ("shelves", i, "height_m"),
                    f"shelf at {shelf.height_m} m is above the body's inside top at {self.inner_top_m:.3f} m",
                )
            if shelf.height_m - t < self.inner_floor_m - _EPS_M:
                raise FieldError(
                    ("shelves", i, "height_m"),
                    f"shelf at {shelf.height_m} m ({t} m thick) is below the body's inside floor at "
                    f"{self.inner_floor_m:.3f} m",
                )
            left, right, depth = self.shelf_span_m(shelf)
            if left < t - _EPS_M or right > self.width_m - t + _EPS_M or right - left <= 0:
                raise FieldError(
                    ("shelves", i, "width_m" if shelf.width_m is not None else "left_m"),
                    f"shelf spans {left:.3f}..{right:.3f} m, not between the side walls of a {self.width_m} m wide body",
                )
            if depth > self.inner_depth_m + _EPS_M:
                raise FieldError(
                    ("shelves", i, "depth_m"), f"shelf {depth} m deep in a body {self.inner_depth_m:.3f} m deep inside"
                )
            for j, divider in enumerate(self.dividers):
                if left < divider.left_m + t - _EPS_M and right > divider.left_m + _EPS_M:
                    raise FieldError(
                        ("shelves", i, "width_m" if shelf.width_m is not None else "left_m"),
                        f"shelf spanning {left:.3f}..{right:.3f} m cuts through divider {j} at {divider.left_m} m",
                    )

    def _check_on_body(self, group: str, i: int, front: Front) -> None:
        what = group[:-1]
        if front.width_m > self.width_m + _EPS_M:
            raise FieldError(
                (group, i, "width_m"), f"{what} is {front.width_m} m wide but the {self._what()} is {self.width_m} m"
            )
        if front.right_m > self.width_m + _EPS_M:
            raise FieldError(
                (group, i, "left_m"),
                f"{what} spans {front.left_m}..{front.right_m:.3f} m from the left edge "
                f"but the {self._what()} is {self.width_m} m wide",
            )
        body_height = self.top_m - self.base_m
        if front.height_m > body_height + _EPS_M:
            raise FieldError(
                (group, i, "height_m"),
                f"{what} is {front.height_m} m high but the {self._what()} is {body_height:.3g} m",
            )
        if front.top_m > self.top_m + _EPS_M:
            raise FieldError(
                (group, i, "bottom_m"),
                f"{what} reaches {front.top_m:.3f} m above the floor but the {self._what()}'s top is at {self.top_m:.3g} m",
            )
        if front.bottom_m < self.base_m - _EPS_M:
            raise FieldError(
                (group, i, "bottom_m"),
                f"{what} starts {front.bottom_m} m above the floor, below the {self._what()} at {self.base_m} m",
            )

    @staticmethod
    def _check_no_overlap(fronts: list[tuple[str, int, Front]]) -> None:
        for k, (group, i, a) in enumerate(fronts):
            for other_group, j, b in fronts[:k]:
                if {group, other_group} == {"doors", "panels"}:
                    continue  # a door closes in front of a panel (a washing machine's over its porthole)
                across = min(a.right_m, b.right_m) - max(a.left_m, b.left_m)
                up = min(a.top_m, b.top_m) - max(a.bottom_m, b.bottom_m)
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
        if drawer.handle.type == "recessed" and drawer.handle.recess_depth_m >= self.door_thickness_m:
            raise FieldError(
                ("drawers", i, "handle", "recess_depth_m"),
                f"a pocket {drawer.handle.recess_depth_m} m deep goes through a {self.door_thickness_m} m thick front",
            )
        for k, shelf in enumerate(self.shelves):
            left, right, _ = self.shelf_span_m(shelf)
            beside = right - self.width_m / 2 <= y_min or left - self.width_m / 2 >= y_max
            if not beside and shelf.height_m > z_min and shelf.height_m - t < z_max:
                raise FieldError(
                    ("shelves", k, "height_m"),
                    f"shelf at {shelf.height_m} m cuts through drawer {i}'s box ({z_min:.3f}..{z_max:.3f} m)",
                )
        for k, divider in enumerate(self.dividers):
            y0 = -self.width_m / 2 + divider.left_m
            if y0 < y_max and y0 + t > y_min:
                raise FieldError(
                    ("drawers", i, "width_m"), f"drawer {i}'s box runs through divider {k} at {divider.left_m} m"
                )

    def _check_door(self, i: int, door: DoorSpec) -> None:
        if door.handle.type == "recessed" and door.handle.recess_depth_m >= self.door_thickness_m:
            raise FieldError(
                ("doors", i, "handle", "recess_depth_m"),
                f"a pocket {door.handle.recess_depth_m} m deep goes through a {self.door_thickness_m} m thick door",
            )
        for k, shelf in enumerate(door.shelves):
            self._check_door_shelf(i, door, k, shelf)

    def _check_door_shelf(self, i: int, door: DoorSpec, k: int, shelf: DoorShelf) -> None:
        """A closed door's bin must sit inside the body, clear of shelves and drawers, and swing out clear."""
        t, where = self.wall_thickness_m, ("doors", i, "shelves", k)
        low, high = self.door_shelf_box_m(door, shelf)
        if shelf.depth_m > self.inner_depth_m + _EPS_M:
            raise FieldError(
                (*where, "depth_m"), f"bin {shelf.depth_m} m deep in a body {self.inner_depth_m:.3f} m deep"
            )
        if low[1] < -self.width_m / 2 + t - _EPS_M or high[1] > self.width_m / 2 - t + _EPS_M:
            raise FieldError((*where, "margin_m"), "bin reaches into the body's side walls; give a larger margin_m")
        if low[2] < self.inner_floor_m - _EPS_M or high[2] > self.inner_top_m + _EPS_M:
            raise FieldError((*where, "height_m"), "bin is not between the body's inside floor and top")
        obstacles = [(f"shelf {j}", *self._shelf_box_m(s)) for j, s in enumerate(self.shelves)]
        obstacles += [(f"drawer {j}", *self._drawer_reach_m(d)) for j, d in enumerate(self.drawers)]
        for name, o_low, o_high in obstacles:
            if np.all(np.minimum(high, o_high) - np.maximum(low, o_low) > _EPS_M):
                raise FieldError(
                    (*where, "depth_m"),
                    f"bin runs into {name} when the door is closed; set that back or the bin shallower",
                )
        # Swinging open, the bin's far corners must clear the side wall on the door's free side.
        hinge_y = -self.width_m / 2 + (door.left_m if door.hinge == "left" else door.right_m)
        inner_wall = (self.width_m / 2 - t) if door.hinge == "left" else (-self.width_m / 2 + t)
        hinge_x = self.front_x_m()
        angles = np.radians(np.linspace(0, door.opening_limit_deg, _SWEEP_SAMPLES))
        for corner_y in (low[1], high[1]):
            dx, dy = low[0] - hinge_x, corner_y - hinge_y
            sign = 1.0 if door.hinge == "left" else -1.0  # the left door turns about -z
            x = hinge_x + dx * np.cos(angles) + sign * dy * np.sin(angles)
            y = hinge_y - sign * dx * np.sin(angles) + dy * np.cos(angles)
            inside = x < self.depth_m / 2
            beyond = (y > inner_wall) if door.hinge == "left" else (y < inner_wall)
            if np.any(inside & beyond):
                raise FieldError(
                    (*where, "margin_m"), "bin hits the body's side wall as the door opens; give a larger margin_m"
                )

    def _shelf_box_m(self, shelf: Shelf) -> tuple[np.ndarray, np.ndarray]:
        left, right, depth = self.shelf_span_m(shelf)
        back = -self.depth_m / 2 + self.wall_thickness_m
        y0 = -self.width_m / 2
        return (
            np.array([back, y0 + left, shelf.height_m - self.wall_thickness_m]),
            np.array([back + depth, y0 + right, shelf.height_m]),
        )

    def _drawer_reach_m(self, drawer: DrawerSpec) -> tuple[np.ndarray, np.ndarray]:
        y_min, y_max, z_min, z_max = self.drawer_box_bounds_m(drawer)
        front = self.depth_m / 2 + self.door_gap_m
        return np.array([front - drawer.depth_m, y_min, z_min]), np.array([front, y_max, z_max])

    def _check_panel(self, i: int, panel: Panel) -> None:
        hole = panel.hole
        if hole is None:
            return
        r = hole.diameter_m / 2
        inside = (
            hole.centre_left_m - r >= panel.left_m - _EPS_M
            and hole.centre_left_m + r <= panel.right_m + _EPS_M
            and hole.centre_height_m - r >= panel.bottom_m - _EPS_M
            and hole.centre_height_m + r <= panel.top_m + _EPS_M
        )
        if not inside:
            raise FieldError(("panels", i, "hole"), f"hole {hole.diameter_m} m across is not inside its panel")

    def _check_knobs(self) -> None:
        for i, knob in enumerate(self.knobs):
            r = knob.diameter_m / 2
            on = [
                p
                for p in self.panels
                if knob.left_m - r >= p.left_m - _EPS_M
                and knob.left_m + r <= p.right_m + _EPS_M
                and knob.height_m - r >= p.bottom_m - _EPS_M
                and knob.height_m + r <= p.top_m + _EPS_M
            ]
            if not on:
                raise FieldError(
                    ("knobs", i, "left_m"),
                    f"knob {knob.diameter_m} m across at {knob.left_m} m from the left, {knob.height_m} m up "
                    f"is off every panel ({len(self.panels)} panels)",
                )
            for j, door in enumerate(self.doors):
                if (
                    knob.left_m + r > door.left_m + _EPS_M
                    and knob.left_m - r < door.right_m - _EPS_M
                    and knob.height_m + r > door.bottom_m + _EPS_M
                    and knob.height_m - r < door.top_m - _EPS_M
                ):
                    raise FieldError(("knobs", i, "left_m"), f"knob {i} is behind door {j}, which would close on it")
            for j, other in enumerate(self.knobs[:i]):
                gap = math.hypot(knob.left_m - other.left_m, knob.height_m - other.height_m) - r - other.diameter_m / 2
                if gap < -_EPS_M:
                    raise FieldError(("knobs", i, "left_m"), f"knob {i} overlaps knob {j} by {-gap:.3f} m")


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
        return left, right, -self.depth_m / 2 + t + from_back

    def _check_kind(self) -> None:
        t = self.wall_thickness_m
        for i, rail in enumerate(self.rails):
            left, right, x = self.rail_span_m(rail)
            r = rail.diameter_m / 2
            if left < t - _EPS_M or right > self.width_m - t + _EPS_M or right <= left:
                raise FieldError(("rails", i, "width_m"), f"rail spans {left:.3f}..{right:.3f} m, not inside the body")
            if rail.height_m + r > self.inner_top_m + _EPS_M or rail.height_m - r < self.inner_floor_m - _EPS_M:
                raise FieldError(("rails", i, "height_m"), f"rail at {rail.height_m} m is not inside the body")
            if x - r < -self.depth_m / 2 + t - _EPS_M or x + r > self.depth_m / 2 + _EPS_M:
                raise FieldError(("rails", i, "from_back_m"), "rail is not between the back wall and the front")
            for k, divider in enumerate(self.dividers):
                if left < divider.left_m + t - _EPS_M and right > divider.left_m + _EPS_M:
                    raise FieldError(("rails", i, "width_m"), f"rail runs through divider {k} at {divider.left_m} m")
            for k, shelf in enumerate(self.shelves):
                s_left, s_right, depth = self.shelf_span_m(shelf)
                overlaps = s_left < right and s_right > left
                in_depth = x - r < -self.depth_m / 2 + t + depth
                if (
                    overlaps
                    and in_depth
                    and shelf.height_m - t < rail.height_m + r
                    and shelf.height_m > rail.height_m - r
                ):
                    raise FieldError(("rails", i, "height_m"), f"rail runs through shelf {k}")
