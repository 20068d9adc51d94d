"""Kitchen and household appliances: fridges, ovens and cookers, dishwashers, washing
machines, microwaves. Each is a cabinet (`CabinetSpec`: body, panels, doors, drawers, knobs)
with its own parts and a standard layout for its size when `doors`, `drawers` or `panels`
are left out.
"""

from __future__ import annotations

from typing import Annotated, ClassVar, Literal

from pydantic import Field

from homemodel.core.yaml_specs import FieldError
from modeller.specs.cabinet_geometry import drawer_box_bounds_m
from modeller.specs.cabinet_parts import (
    GLASS_COLOUR,
    Divider,
    DoorShelf,
    DoorSpec,
    DrawerSpec,
    Hole,
    Panel,
    Shelf,
    Window,
)
from modeller.specs.cabinets import CabinetSpec
from modeller.specs.common import _EPS_M, Colour, Length, Offset, _Spec
from modeller.specs.handles import ControlKnob, DoorHandle, DrawerHandle


class _ApplianceSpec(CabinetSpec):
    """Appliances are sheet metal with thick doors; mass is better given as `mass_kg`."""

    default_density_kg_m3: ClassVar[float] = 900.0  # a shell, insulation and machinery, averaged
    wall_thickness_m: Length = 0.02
    door_thickness_m: Length = 0.03
    door_gap_m: Offset = Field(0.003, description="clearance between the body and its doors and drawers")
    handle_colour: Colour = "silver"

    def _bottom_drawer(
        self, top_m: float, depth_m: float, travel_fraction: float, handle: DrawerHandle | None = None
    ) -> DrawerSpec:
        """A default layout's drawer across the whole front, from the floor up to `top_m`."""
        g = self.door_gap_m
        return DrawerSpec(
            left_m=g,
            width_m=self.width_m - 2 * g,
            bottom_m=g,
            height_m=top_m - 1.5 * g,
            depth_m=depth_m,
            travel_m=round(travel_fraction * depth_m, 3),
            handle=handle or DrawerHandle(),
        )


def _knob_row(spec: CabinetSpec, panel: Panel, count: int, states: list[str], step_deg: float) -> list[ControlKnob]:
    """`count` knobs evenly across the middle of `panel`."""
    height = (panel.bottom_m + panel.top_m) / 2
    pitch = panel.width_m / count
    diameter = min(0.045, 0.7 * panel.height_m, 0.8 * pitch)
    return [
        ControlKnob(
            left_m=panel.left_m + (k + 0.5) * pitch,
            height_m=height,
            diameter_m=diameter,
            states=states,
            step_deg=step_deg,
        )
        for k in range(count)
    ]


# ---------------------------------------------------------------------------- fridge


class FridgeSpec(_ApplianceSpec):
    """A fridge: an insulated body, one or two doors (with door shelves), a freezer drawer.

    Default layout: a right-hinged door over the upper `1 - freezer_fraction` of the front
    with three door shelves, and a freezer drawer below it behind a divider shelf.
    """

    kind_label: ClassVar[str] = "fridge"
    kind: Literal["fridge"]
    width_m: Length = 0.6
    depth_m: Length = Field(0.65, description="depth of the body, without doors and handles")
    height_m: Length = Field(1.8, description="floor to the top of the body")
    wall_thickness_m: Length = 0.04
    door_thickness_m: Length = 0.05
    freezer_fraction: Annotated[float, Field(ge=0, lt=0.8)] = Field(
        0.3, description="default layout: share of the height behind the freezer drawer (0: no freezer)"
    )

    def default_layout(self) -> None:
        g, t = self.door_gap_m, self.wall_thickness_m
        split = round(self.freezer_fraction * self.height_m, 3)
        if self.drawers is None:
            self.drawers = []
            if split > 0:
                handle = DrawerHandle(length_m=min(0.4, 0.6 * self.width_m), height_m=split - 0.06)
                self.drawers = [self._bottom_drawer(split, round(self.inner_depth_m - 0.05, 3), 0.8, handle)]
        if self.doors is None:
            bottom = split + g / 2 if split > 0 else g
            self.doors = [
                DoorSpec(
                    hinge="right",
                    left_m=g,
                    width_m=self.width_m - 2 * g,
                    bottom_m=bottom,
                    height_m=self.height_m - g - bottom,
                    handle=DoorHandle(
                        length_m=0.3, from_free_edge_m=0.04, height_m=min(1.0, self.height_m - bottom) - 0.25
                    ),
                    shelves=[
                        DoorShelf(height_m=h) for h in (0.15, 0.45, 0.75) if h + 0.06 < self.height_m - bottom - 0.1
                    ],
                )
            ]
            if split > 0 and not self.shelves:
                # The divider between freezer and fridge, then glass shelves set back behind the door shelves.
                self.shelves = [Shelf(height_m=split + t)]
                bins = max((s.depth_m for s in self.doors[0].shelves), default=0.0)
                set_back = round(self.inner_depth_m - bins - 0.03, 3)
                inside = self.height_m - t - (split + t)
                self.shelves += [
                    Shelf(height_m=round(split + t + f * inside, 3), depth_m=set_back) for f in (0.35, 0.65)
                ]
        super().default_layout()


# ---------------------------------------------------------------------------- oven


class Burner(_Spec):
    """A burner or cooking zone on the hob: a flat disc."""

    from_left_m: Offset = Field(description="centre from the body's left edge, seen from in front")
    from_front_m: Offset = Field(description="centre from the body's front plane, going back")
    diameter_m: Length = 0.18


class Hob(_Spec):
    """The hob on top of a cooker: a plate the body's size, burners on it."""

    thickness_m: Length = Field(0.006, description="plate thickness; the plate's top is the oven's height_m")
    colour: Colour = GLASS_COLOUR
    burner_colour: Colour = "grey"
    burners: list[Burner] | None = Field(None, description="default: four burners, two front and two back")


class OvenSpec(_ApplianceSpec):
    """An oven or a cooker: a door hinged at the bottom (with a window), a control panel with
    knobs (revolute, with named states and a marker), an optional hob and storage drawer.

    `height_m` is to the hob plate's top when there is a hob. Default layout: a control
    panel `panel_height_m` high across the top of the front with one knob per burner (four
    without a hob), the door below it, and a storage drawer under the door when the oven is
    taller than 0.7 m (a free-standing cooker).
    """

    kind_label: ClassVar[str] = "oven"
    kind: Literal["oven"]
    width_m: Length = 0.6
    depth_m: Length = Field(0.6, description="depth of the body, without doors and handles")
    height_m: Length = Field(0.9, description="floor to the top (the hob plate's top if there is a hob)")
    hob: Hob | None = Field(default_factory=Hob)
    panel_height_m: Length = Field(0.1, description="default layout: height of the control panel strip")
    colour: Colour = "white"

    @property
    def carcass_top_m(self) -> float:
        return self.height_m - (self.hob.thickness_m if self.hob is not None else 0.0)

    def burners(self) -> list[Burner]:
        if self.hob is None:
            return []
        if self.hob.burners is not None:
            return self.hob.burners
        size = round(min(0.18, self.width_m / 3, self.depth_m / 3), 3)
        return [
            Burner(from_left_m=self.width_m * a, from_front_m=self.depth_m * b, diameter_m=size)
            for b in (0.3, 0.7)
            for a in (0.28, 0.72)
        ]

    def default_layout(self) -> None:
        g, t = self.door_gap_m, self.wall_thickness_m
        top = self.carcass_top_m
        panel_bottom = top - self.panel_height_m
        drawer_top = round(0.16, 3) if self.height_m > 0.7 else 0.0
        if self.panels is None:
            self.panels = [Panel(left_m=0, width_m=self.width_m, bottom_m=panel_bottom, height_m=self.panel_height_m)]
            if not self.knobs:
                count = len(self.burners()) or 4
                self.knobs = _knob_row(self, self.panels[0], count, ["off", *map(str, range(1, 10))], 30.0)
        if self.drawers is None:
            self.drawers = []
            if drawer_top > 0:
                self.drawers = [self._bottom_drawer(drawer_top, round(self.inner_depth_m - 0.1, 3), 0.7)]
                if not self.shelves:
                    self.shelves = [Shelf(height_m=drawer_top + t)]
        if self.doors is None:
            bottom = drawer_top + g / 2 if drawer_top > 0 else g
            self.doors = [
                DoorSpec(
                    hinge="bottom",
                    left_m=g,
                    width_m=self.width_m - 2 * g,
                    bottom_m=bottom,
                    height_m=round(panel_bottom - g - bottom, 4),
                    opening_limit_deg=90,
                    handle=DoorHandle(length_m=round(0.75 * self.width_m, 3), from_free_edge_m=0.04),
                    window=Window(margin_m=0.08),
                )
            ]
        super().default_layout()

    def _check_kind(self) -> None:
        if (
            self.hob is not None
            and self.hob.thickness_m >= self.height_m - self.carcass_bottom_m - 2 * self.wall_thickness_m
        ):
            raise FieldError(("hob", "thickness_m"), f"a hob plate {self.hob.thickness_m} m thick fills the oven")
        for i, burner in enumerate(self.burners()):
            r = burner.diameter_m / 2
            if not (r - _EPS_M <= burner.from_left_m <= self.width_m - r + _EPS_M):
                raise FieldError(("hob", "burners", i, "from_left_m"), f"burner {i} overhangs the hob's side")
            if not (r - _EPS_M <= burner.from_front_m <= self.depth_m - r + _EPS_M):
                raise FieldError(("hob", "burners", i, "from_front_m"), f"burner {i} overhangs the hob's front or back")


# ---------------------------------------------------------------------------- dishwasher


class Rack(_Spec):
    """A wire basket inside a dishwasher (fixed: it pulls out only with the door open, which
    a model of independent joints cannot say, so it is part of the body)."""

    bottom_m: Length = Field(description="height of the basket's floor above the floor")
    height_m: Length = 0.18
    clearance_m: Offset = Field(0.02, description="gap to the side walls, the back wall and the door")


class DishwasherSpec(_ApplianceSpec):
    """A dishwasher: a door hinged at the bottom over the front above a kick plate, racks inside.

    Default layout: a kick plate `kick_plate_height_m` high, the door above it, two racks.
    """

    kind_label: ClassVar[str] = "dishwasher"
    kind: Literal["dishwasher"]
    width_m: Length = 0.6
    depth_m: Length = Field(0.57, description="depth of the body, without the door and its handle")
    height_m: Length = Field(0.85, description="floor to the top of the body")
    kick_plate_height_m: Length = Field(0.1, description="default layout: height of the panel under the door")
    racks: list[Rack] | None = Field(None, description="default: a lower and an upper rack")

    def default_layout(self) -> None:
        g = self.door_gap_m
        k = self.kick_plate_height_m
        if self.panels is None:
            self.panels = [Panel(left_m=0, width_m=self.width_m, bottom_m=0, height_m=k)]
        if self.doors is None:
            self.doors = [
                DoorSpec(
                    hinge="bottom",
                    left_m=g,
                    width_m=self.width_m - 2 * g,
                    bottom_m=k + g,
                    height_m=self.height_m - k - 2 * g,
                    opening_limit_deg=90,
                    handle=DoorHandle(length_m=round(0.5 * self.width_m, 3), from_free_edge_m=0.04),
                )
            ]
        if self.racks is None:
            inside = self.inner_top_m - self.inner_floor_m
            self.racks = [Rack(bottom_m=round(self.inner_floor_m + f * inside, 3)) for f in (0.1, 0.55)]
        super().default_layout()

    def rack_bounds_m(self, rack: Rack) -> tuple[float, float, float, float, float, float]:
        """(x_min, x_max, y_min, y_max, z_min, z_max) of a rack in the model frame."""
        t, c = self.wall_thickness_m, rack.clearance_m
        return (
            self.back_inner_x_m + c,
            self.depth_m / 2 - c,
            -self.width_m / 2 + t + c,
            self.width_m / 2 - t - c,
            rack.bottom_m,
            rack.bottom_m + rack.height_m,
        )

    def _check_kind(self) -> None:
        for i, rack in enumerate(self.racks):
            x0, x1, y0, y1, z0, z1 = self.rack_bounds_m(rack)
            if x1 - x0 <= 0.05 or y1 - y0 <= 0.05:
                raise FieldError(("racks", i, "clearance_m"), "leaves no rack inside the body")
            if z0 < self.inner_floor_m - _EPS_M or z1 > self.inner_top_m + _EPS_M:
                raise FieldError(("racks", i, "bottom_m"), f"rack spans {z0:.3f}..{z1:.3f} m, not inside the body")
            for j, other in enumerate(self.racks[:i]):
                if z0 < other.bottom_m + other.height_m and z1 > other.bottom_m:
                    raise FieldError(("racks", i, "bottom_m"), f"rack {i} overlaps rack {j}")
            for j, shelf in enumerate(self.shelves):
                if z0 < shelf.height_m and z1 > shelf.height_m - self.shelf_board_m(shelf):
                    raise FieldError(("racks", i, "bottom_m"), f"rack {i} runs through shelf {j}")


# ---------------------------------------------------------------------------- washing machine


class Drum(_Spec):
    """The drum behind the porthole: a cylinder open at the front, behind the panel's hole."""

    diameter_m: Length = Field(0.46, description="outer diameter")
    depth_m: Length = Field(0.3, description="from the front panel's inner face back")
    wall_thickness_m: Length = 0.004


class WashingMachineSpec(_ApplianceSpec):
    """A front-loading washing machine: a round door on a side hinge with a porthole window
    over a hole in the front panel, the drum behind it, a program knob and a detergent drawer.

    Default layout: a control strip `control_height_m` high across the top (detergent drawer
    on the left, the panel with the program knob on the right) and the lower panel with the
    hole, the door centred on it.
    """

    kind_label: ClassVar[str] = "washing machine"
    kind: Literal["washing_machine"]
    width_m: Length = 0.6
    depth_m: Length = Field(0.55, description="depth of the body, without the door and knobs")
    height_m: Length = Field(0.85, description="floor to the top of the body")
    door_thickness_m: Length = 0.06
    control_height_m: Length = Field(0.12, description="default layout: height of the control strip")
    door_diameter_m: Length = Field(0.44, description="default layout: diameter of the round door")
    drum: Drum | None = Field(default_factory=Drum)

    def holed_panel(self) -> Panel | None:
        return next((p for p in self.panels if p.hole is not None), None)

    def default_layout(self) -> None:
        g = self.door_gap_m
        strip_bottom = self.height_m - self.control_height_m
        centre_height = round(strip_bottom / 2 + 0.03, 3)
        drawer_width = round(0.35 * self.width_m, 3)
        if self.panels is None:
            hole = Hole(
                centre_left_m=self.width_m / 2,
                centre_height_m=centre_height,
                diameter_m=round(0.75 * self.door_diameter_m, 3),
            )
            self.panels = [
                Panel(left_m=0, width_m=self.width_m, bottom_m=0, height_m=strip_bottom, hole=hole),
                Panel(
                    left_m=drawer_width,
                    width_m=self.width_m - drawer_width,
                    bottom_m=strip_bottom,
                    height_m=self.control_height_m,
                ),
            ]
            if not self.knobs:
                programs = ["off", "cotton 60", "cotton 40", "synthetics", "delicates", "wool", "rinse", "spin"]
                knob = _knob_row(self, self.panels[1], 1, programs, 30.0)[0]
                self.knobs = [
                    knob.model_copy(
                        update={"left_m": self.width_m - 0.1, "diameter_m": min(0.06, 0.7 * self.control_height_m)}
                    )
                ]
        if self.drawers is None:
            self.drawers = [
                DrawerSpec(
                    left_m=g,
                    width_m=drawer_width - 2 * g,
                    bottom_m=strip_bottom + g,
                    height_m=self.control_height_m - 2 * g,
                    depth_m=0.3,
                    travel_m=0.2,
                    handle=DrawerHandle(type="recessed", length_m=0.1, recess_depth_m=0.015),
                )
            ]
        if self.doors is None:
            d = self.door_diameter_m
            self.doors = [
                DoorSpec(
                    hinge="left",
                    shape="round",
                    left_m=self.width_m / 2 - d / 2,
                    width_m=d,
                    height_m=d,
                    bottom_m=centre_height - d / 2,
                    opening_limit_deg=150,
                    window=Window(margin_m=0.07),
                    handle=DoorHandle(length_m=0.1, diameter_m=0.016, from_free_edge_m=0.045),
                )
            ]
        super().default_layout()

    def drum_bounds_m(self) -> tuple[float, float, float, float, float]:
        """(x_back, x_front, y_centre, z_centre, radius) of the drum in the model frame."""
        panel = self.holed_panel()
        assert panel is not None and panel.hole is not None and self.drum is not None
        x_front = self.depth_m / 2 - self.wall_thickness_m
        return (
            x_front - self.drum.depth_m,
            x_front,
            -self.width_m / 2 + panel.hole.centre_left_m,
            panel.hole.centre_height_m,
            self.drum.diameter_m / 2,
        )

    def _check_kind(self) -> None:
        if self.drum is None:
            return
        panel = self.holed_panel()
        if panel is None:
            raise FieldError(("drum",), "a drum needs a panel with a hole in front of it")
        t = self.wall_thickness_m
        x_back, x_front, y, z, r = self.drum_bounds_m()
        if self.drum.diameter_m < panel.hole.diameter_m:
            raise FieldError(
                ("drum", "diameter_m"),
                f"drum {self.drum.diameter_m} m across is smaller than its {panel.hole.diameter_m} m hole",
            )
        if 2 * self.drum.wall_thickness_m >= self.drum.diameter_m:
            raise FieldError(("drum", "wall_thickness_m"), "fills the drum")
        if x_back < self.back_inner_x_m - _EPS_M:
            raise FieldError(("drum", "depth_m"), f"drum {self.drum.depth_m} m deep goes through the back wall")
        if y - r < -self.width_m / 2 + t - _EPS_M or y + r > self.width_m / 2 - t + _EPS_M:
            raise FieldError(("drum", "diameter_m"), "drum goes through the side walls")
        if z - r < self.inner_floor_m - _EPS_M or z + r > self.inner_top_m + _EPS_M:
            raise FieldError(("drum", "diameter_m"), "drum goes through the floor or the top")
        for i, drawer in enumerate(self.drawers):
            y0, y1, z0, z1 = drawer_box_bounds_m(self, drawer)
            if y0 < y + r and y1 > y - r and z0 < z + r and z1 > z - r:
                raise FieldError(("drawers", i, "bottom_m"), f"drawer {i}'s box runs into the drum")


# ---------------------------------------------------------------------------- microwave


class MicrowaveSpec(_ApplianceSpec):
    """A microwave oven: a cavity behind a side-hinged door with a window, a control panel
    beside it (behind a divider) with a timer knob, a turntable plate on the cavity floor.

    Default layout: a panel `panel_width_m` wide on the right, a divider behind its left
    edge, the left-hinged door over the rest, one knob.
    """

    kind_label: ClassVar[str] = "microwave"
    kind: Literal["microwave"]
    width_m: Length = 0.5
    depth_m: Length = Field(0.38, description="depth of the body, without the door and knobs")
    height_m: Length = Field(0.3, description="underside to the top of the body")
    wall_thickness_m: Length = 0.012
    door_thickness_m: Length = 0.03
    colour: Colour = "black"
    panel_width_m: Length = Field(0.12, description="default layout: width of the control panel on the right")
    turntable_diameter_m: Length | None = Field(0.27, description="glass plate on the cavity floor; null: none")
    turntable_colour: Colour = GLASS_COLOUR
    turntable_raise_m: Offset = Field(
        0.0, description="from the cavity floor up to the plate's underside (on its roller ring and coupler)"
    )
    turntable_turns: bool = Field(False, description="true: the plate turns freely (a continuous joint)")
    turntable_right_m: float = Field(
        0.0, description="the plate's centre from the cavity's centre, sideways (positive: to the right, seen from in front)"
    )
    turntable_back_m: float = Field(
        0.0, description="the plate's centre from the cavity's centre, front to back (positive: toward the back)"
    )

    def turntable_centre_m(self) -> tuple[float, float]:
        """(x, y) of the plate's axis in the model frame."""
        left, right = self.cavity_span_m()
        x = (self.back_inner_x_m + self.depth_m / 2) / 2
        y = -self.width_m / 2 + (left + right) / 2
        return x - self.turntable_back_m, y + self.turntable_right_m

    def default_layout(self) -> None:
        g = self.door_gap_m
        p = self.panel_width_m
        if self.panels is None:
            self.panels = [Panel(left_m=self.width_m - p, width_m=p, bottom_m=0, height_m=self.height_m)]
            if not self.dividers:
                self.dividers = [Divider(left_m=self.width_m - p)]
            if not self.knobs:
                states = ["off", *(f"{m} min" for m in (1, 2, 3, 5, 10, 15, 20, 30))]
                self.knobs = [
                    ControlKnob(
                        left_m=self.width_m - p / 2,
                        height_m=round(0.6 * self.height_m, 3),
                        diameter_m=min(0.045, 0.6 * p),
                        states=states,
                        step_deg=30.0,
                    )
                ]
        if self.doors is None:
            right = self.panels[0].left_m if self.panels else self.width_m
            self.doors = [
                DoorSpec(
                    hinge="left",
                    left_m=g,
                    width_m=right - 2 * g,
                    bottom_m=g,
                    height_m=self.height_m - 2 * g,
                    window=Window(margin_m=0.05),
                    opening_limit_deg=110,
                    handle=DoorHandle(length_m=round(0.6 * self.height_m, 3), standoff_m=0.03, from_free_edge_m=0.03),
                )
            ]
        super().default_layout()

    def cavity_span_m(self) -> tuple[float, float]:
        """(left, right) of the cavity from the body's left edge: the left wall to the first divider."""
        t = self.wall_thickness_m
        right = min((d.left_m for d in self.dividers), default=self.width_m - t)
        return t, right

    def _check_kind(self) -> None:
        d = self.turntable_diameter_m
        if d is None:
            return
        left, right = self.cavity_span_m()
        if d > right - left + _EPS_M or d > self.inner_depth_m + _EPS_M:
            raise FieldError(
                ("turntable_diameter_m",),
                f"a plate {d} m across does not fit a cavity {right - left:.3f} x {self.inner_depth_m:.3f} m",
            )
        if abs(self.turntable_right_m) + d / 2 > (right - left) / 2 + _EPS_M:
            raise FieldError(
                ("turntable_right_m",),
                f"a plate {d} m across {self.turntable_right_m} m off the middle reaches into the cavity's side",
            )
        if abs(self.turntable_back_m) + d / 2 > self.inner_depth_m / 2 + _EPS_M:
            raise FieldError(
                ("turntable_back_m",),
                f"a plate {d} m across {self.turntable_back_m} m off the middle reaches the cavity's back or front",
            )
        if self.inner_floor_m + self.turntable_raise_m >= self.inner_top_m - _EPS_M:
            raise FieldError(("turntable_raise_m",), "raises the plate to the cavity's top")
