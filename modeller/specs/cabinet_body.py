"""What every cabinet-like kind is made of: `CabinetBody`, the box at its real outer size with
its parts, and the sizes derived from them. The cabinet rules (`modeller.specs.cabinet_rules`)
and where the parts lie (`modeller.specs.cabinet_geometry`) read this; `CabinetSpec`
(`modeller.specs.cabinets`) adds the standard layouts and runs those rules.
"""

from __future__ import annotations

from typing import ClassVar

from pydantic import Field

from modeller.specs.cabinet_parts import (
    BackPanel,
    Divider,
    DoorSpec,
    DrawerSpec,
    FaceFrame,
    Panel,
    Shelf,
    TopOverhang,
    TopRail,
)
from modeller.specs.common import Colour, Length, ObjectSpec, Offset
from modeller.specs.furniture import Legs
from modeller.specs.handles import ControlKnob, PushButton


class CabinetBody(ObjectSpec):
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
    wall_thickness_m: Length = Field(0.018, description="sides, top, bottom (and back, without back_panel)")
    top_panel: bool = Field(True, description="false: no top (a base unit under a worktop)")
    top_thickness_m: Length | None = Field(None, description="the top's own thickness; default: wall_thickness_m")
    top_overhang: TopOverhang | None = Field(None, description="default: a top flush with the carcass")
    bottom_thickness_m: Length | None = Field(None, description="the bottom's own thickness; default: wall_thickness_m")
    bottom_raise_m: Offset = Field(
        0.0, description="from the carcass' underside (the plinth's top) up to the bottom board: a void under it"
    )
    shelf_thickness_m: Length | None = Field(None, description="the shelves' thickness; default: wall_thickness_m")
    top_rails: list[TopRail] = Field([], description="rails or cleats across an open top (top_panel: false)")
    back_panel: BackPanel | None = Field(None, description="default: a back wall as thick as the walls, flush")
    face_frame: FaceFrame | None = None
    plinth_height_m: Offset = 0.0
    plinth_recess_m: Offset = Field(0.05, description="how far the plinth's front sits back from the body's front")
    legs: Legs | None = Field(
        None, description="four legs plinth_height_m high in the carcass' corners instead of a plinth (a bedside table's)"
    )
    door_thickness_m: Length = 0.018
    door_gap_m: Offset = Field(0.002, description="clearance between the body and its doors and drawers")
    shelves: list[Shelf] = []
    dividers: list[Divider] = []
    panels: list[Panel] | None = None
    doors: list[DoorSpec] | None = None
    drawers: list[DrawerSpec] | None = None
    knobs: list[ControlKnob] = []
    buttons: list[PushButton] = Field([], description="push buttons on panels (a microwave's door release)")
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
    def back_inner_x_m(self) -> float:
        """x of the back wall's (or back panel's) inner face."""
        back = self.back_panel
        return -self.depth_m / 2 + (self.wall_thickness_m if back is None else back.inset_m + back.thickness_m)

    @property
    def inner_depth_m(self) -> float:
        back = self.back_panel
        return self.depth_m - (self.wall_thickness_m if back is None else back.inset_m + back.thickness_m)

    @property
    def top_board_m(self) -> float:
        """Thickness of the top (when it has one)."""
        return self.wall_thickness_m if self.top_thickness_m is None else self.top_thickness_m

    @property
    def bottom_board_m(self) -> float:
        return self.wall_thickness_m if self.bottom_thickness_m is None else self.bottom_thickness_m

    @property
    def inner_floor_m(self) -> float:
        return self.carcass_bottom_m + self.bottom_raise_m + self.bottom_board_m

    def shelf_board_m(self, shelf: Shelf) -> float:
        """A shelf's thickness."""
        if shelf.thickness_m is not None:
            return shelf.thickness_m
        return self.wall_thickness_m if self.shelf_thickness_m is None else self.shelf_thickness_m

    def door_board_m(self, door: DoorSpec) -> float:
        """A door's thickness, outer face to innermost face."""
        return self.door_thickness_m if door.thickness_m is None else door.thickness_m

    def panel_board_m(self, panel: Panel) -> float:
        return self.wall_thickness_m if panel.thickness_m is None else panel.thickness_m

    @property
    def inner_top_m(self) -> float:
        return self.carcass_top_m - (self.top_board_m if self.top_panel else 0.0)

    @property
    def front_recess_m(self) -> float:
        """How far inset fronts reach back from the body's front (shelves stop behind them)."""
        fronts = [*self.doors, *self.drawers] if self.doors is not None and self.drawers is not None else []
        inset = any(front.mounting == "inset" for front in fronts)
        reach = self.door_thickness_m + self.door_gap_m if inset else 0.0
        plugs = [door.in_opening_m for door in self.doors or [] if door.mounting != "inset"]
        return max([reach, *plugs])
