"""Cabinets: a box open at the front with shelves, dividers, fixed panels, doors, drawers and
knobs on it. `CabinetSpec` holds what every cabinet-like kind shares (cupboards, wall cabinets,
wardrobes, and the appliances in `modeller.specs.appliances`); each kind adds its own parts.

Heights (`bottom_m` of a front, `height_m` of a shelf, a knob's `height_m`) are above the
floor, that is the model frame's z, for every kind; `left_m` is from the body's left outer
edge as seen from in front. The hinge line of a door is, by default, its hinge-side edge on
its outer face; `modeller.specs.hinges` moves it where the real hinges put it.

The rules every cabinet must meet are in `modeller.specs.cabinet_rules`, where its parts lie
(shelf spans, drawer boxes, door bins) in `modeller.specs.cabinet_geometry`.
"""

from __future__ import annotations

import math
from typing import Annotated, ClassVar, Literal

from pydantic import Field, ValidationError, model_validator

from homemodel.core.yaml_specs import FieldError
from modeller.specs.cabinet_geometry import shelf_span_m
from modeller.specs.cabinet_rules import check_cabinet, check_door_front, check_drawer_front
from modeller.specs.common import _EPS_M, Colour, Length, ObjectSpec, Offset, _Spec
from modeller.specs.handles import ControlKnob, DoorHandle, DrawerHandle, Orientation, PushButton
from modeller.specs.hinges import DoorMount, Mounting
from modeller.specs.joint_dynamics import JointDynamicsSpec

Hinge = Literal["left", "right", "top", "bottom"]
# Dark glass for door windows and hob plates.
GLASS_COLOUR = (0.03, 0.035, 0.04)


class Front(_Spec):
    """A rectangle on the body's front, placed as seen from in front."""

    width_m: Length
    height_m: Length
    bottom_m: Offset = Field(description="height of the lower edge above the floor")
    left_m: float = Field(
        description="from the body's left edge to the rectangle's left edge, seen from in front (negative: a door or "
        "drawer front over a face frame's stile standing out past the left side)",
        allow_inf_nan=False,
    )

    @property
    def right_m(self) -> float:
        return self.left_m + self.width_m

    @property
    def top_m(self) -> float:
        return self.bottom_m + self.height_m


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


class DoorSpec(Front, DoorMount):
    """A door turning about its hinge line (by default the hinge-side edge on its outer face;
    `mounting`, `hinge_type`, `hinge_line` and `hinge_measured` from `DoorMount`).

    `left`/`right` hinges are vertical (seen from in front); `bottom` opens down (an oven),
    `top` opens up (a wall cabinet's flap). A `round` door (a washing machine's) is a disc
    of diameter `width_m` = `height_m` in that square, its hinge line tangent to it.
    """

    hinge: Hinge = Field(description="hinge side, seen from in front")
    shape: Literal["rectangle", "round"] = "rectangle"
    opening_limit_deg: Annotated[float, Field(gt=0, le=180)] = 100.0
    handle: DoorHandle = Field(default_factory=DoorHandle)
    window: Window | None = None
    dynamics: JointDynamicsSpec | None = Field(None, description="the hinge's damping and friction; default: by its kind")
    shelves: list[DoorShelf] = Field([], description="bins on the door's inner face (a fridge door's)")
    thickness_m: Length | None = Field(
        None,
        description="from the door's outer face to its innermost face (what a tape across its hinge-side edge "
        "reads, the part inside the opening included); default: the cabinet's door_thickness_m",
    )
    in_opening_m: Offset = Field(
        0.0,
        description="how much of that thickness lies inside the opening, behind the body's front plane "
        "(a microwave door's inner part in the cavity's recess): a plug door_gap_m clear of the opening's edges",
    )

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
            up = self.height_m if self.handle.type == "channel" else up  # its top edge
        else:
            across = self.width_m / 2 if self.handle.from_left_m is None else self.handle.from_left_m
            up = self.height_m - from_free if self.hinge == "bottom" else from_free
        return across, up

    @model_validator(mode="after")
    def _door_possible(self) -> DoorSpec:
        check_door_front(self)
        cup = self.concealed.boring_distance_m + self.concealed.cup_diameter_m
        if self.hinge_type == "concealed" and cup >= (self.width_m if self.side_hinged else self.height_m):
            raise FieldError(("concealed", "cup_diameter_m"), f"the hinge's cup reaches {cup:.3f} m across the door")
        if self.hinge_type == "concealed" and self.opening_limit_deg > self.concealed.opening_deg:
            raise FieldError(
                ("opening_limit_deg",),
                f"a {self.concealed.opening_deg:g} degree concealed hinge does not open to {self.opening_limit_deg:g}",
            )
        return self


class DrawerSpec(Front):
    """A drawer: a front with an open box behind it, sliding straight out (+x)."""

    depth_m: Length = Field(description="depth of the drawer box behind the front")
    travel_m: Length = Field(description="how far the drawer pulls out")
    handle: DrawerHandle = Field(default_factory=DrawerHandle)
    mounting: Mounting = Field("overlay", description="overlay: in front of the body; inset: flush with its front")
    box_height_m: Length | None = Field(
        None, description="height of the box's sides (lower than the front); default: as high as the opening allows"
    )
    runner_clearance_m: Offset | None = Field(
        None, description="gap each side between the box and the carcass for the runners; default: door_gap_m"
    )
    inner_board_m: Offset = Field(
        0.0,
        description="a second board behind the front, inside the opening, this thick (the box's own front, "
        "across the box); the box starts behind it",
    )
    inner_board_inside_m: Offset | None = Field(
        None,
        description="how far behind the carcass' front plane the second board's front face is (inside the opening); "
        "default: right behind the front",
    )
    inner_board_height_m: Length | None = Field(
        None,
        description="the second board's own height, from the box's underside up (the drawer pulled out); "
        "default: up to the front's top, door_gap_m inside the opening",
    )
    box_bottom_m: Offset | None = Field(
        None,
        description="from the front's bottom edge up to the box's underside; default: as low as the opening allows",
    )
    box_offset_m: float = Field(
        0.0, description="the box's middle from the front's middle, sideways (positive: to the right, seen from in front)"
    )
    box_width_m: Length | None = Field(
        None, description="the box's outer width; default: as wide as the opening allows, less runner_clearance_m"
    )
    box_wall_m: Length | None = Field(
        None, description="thickness of the box's sides, back and floor (often thinner than the carcass); default: wall_thickness_m"
    )
    dynamics: JointDynamicsSpec | None = Field(None, description="the slide's damping and friction; default: by its kind")

    def handle_orientation(self) -> Orientation:
        return self.handle.direction("horizontal")

    def handle_offset_m(self) -> tuple[float, float]:
        """Handle centre from the front's left edge (seen from in front) and above its bottom edge."""
        across = self.width_m / 2 if self.handle.from_left_m is None else self.handle.from_left_m
        up = self.height_m / 2 if self.handle.height_m is None else self.handle.height_m
        return across, self.height_m if self.handle.type == "channel" else up

    @model_validator(mode="after")
    def _drawer_fits(self) -> DrawerSpec:
        check_drawer_front(self)
        return self


class Shelf(_Spec):
    """A fixed shelf from the back wall forward, as thick as the cabinet's shelves."""

    height_m: Length = Field(description="height of the shelf's top surface above the floor")
    left_m: Offset | None = Field(
        None, description="from the body's left edge to the shelf's left end; default: the left wall"
    )
    width_m: Length | None = Field(None, description="length side to side; default: to the right wall")
    depth_m: Length | None = Field(None, description="from the back wall's inner face forward; default: to the front")
    thickness_m: Length | None = Field(None, description="this shelf's own thickness; default: shelf_thickness_m")


class Divider(_Spec):
    """A vertical partition, as thick as the walls, from the back wall to the front, floor to top."""

    left_m: Offset = Field(description="from the body's left edge to the divider's left face")


class Hole(_Spec):
    """A round opening through a panel (a washing machine's drum mouth)."""

    centre_left_m: Offset = Field(description="centre from the body's left edge")
    centre_height_m: Offset = Field(description="centre above the floor")
    diameter_m: Length


class Panel(Front):
    """A fixed panel in the body's front (a control panel, a kick plate), as thick as the walls
    unless given; knobs and buttons on it may sit in pockets cut into it."""

    hole: Hole | None = None
    thickness_m: Length | None = Field(None, description="the panel's own thickness; default: wall_thickness_m")
    forward_m: float = Field(
        0.0, description="how far the panel's face stands out of the body's front (negative: set back into it)"
    )
    colour: Colour | None = Field(None, description="default: the body's colour")


class FrameStile(_Spec):
    """A middle stile of a face frame: a vertical member between the top and bottom rails
    (a door may hang on it; it is not a divider behind the opening)."""

    left_m: Offset = Field(description="from the body's left edge to the stile's left edge, seen from in front")
    width_m: Length | None = Field(None, description="default: the frame's width_m")
    bottom_m: Offset | None = Field(None, description="its lower end above the floor; default: the bottom rail")
    top_m: Offset | None = Field(None, description="its upper end above the floor; default: the top rail")


class FrameRail(_Spec):
    """A middle rail of a face frame: a horizontal member across the opening."""

    bottom_m: Offset = Field(description="height of the rail's lower edge above the floor")
    height_m: Length | None = Field(None, description="seen from in front; default: the frame's width_m")
    left_m: Offset | None = Field(None, description="its left end from the body's left edge; default: the left stile")
    right_m: Offset | None = Field(None, description="its right end from the body's left edge; default: the right stile")


class FaceFrame(_Spec):
    """A frame round the front opening (stiles and rails), its face flush with the body's front."""

    width_m: Length = Field(0.038, description="width of the stiles and rails, seen from in front")
    thickness_m: Length = Field(0.019, description="depth of the frame, front to back")
    overhang_m: Offset = Field(
        0.0, description="how far the outer stiles stand out past the side panels, each side (the stiles' width_m includes it)"
    )
    stiles: list[FrameStile] = Field([], description="middle stiles (a door may hang on one)")
    rails: list[FrameRail] = Field([], description="middle rails")


class TopRail(_Spec):
    """A rail (cleat) across an open top, side to side, flush with the sides' top edges."""

    from_front_m: Offset = Field(description="from the body's front plane back to the rail's front edge")
    depth_m: Length = Field(description="front to back")
    thickness_m: Length | None = Field(None, description="default: top_thickness_m (else wall_thickness_m)")


class BackPanel(_Spec):
    """A back panel of its own thickness, set in from the body's back edge (in a groove)."""

    thickness_m: Length = Field(0.008, description="3 to 8 mm usually")
    inset_m: Offset = Field(0.0, description="from the sides' back edges forward to the panel's back face")


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
    wall_thickness_m: Length = Field(0.018, description="sides, top, bottom (and back, without back_panel)")
    top_panel: bool = Field(True, description="false: no top (a base unit under a worktop)")
    top_thickness_m: Length | None = Field(None, description="the top's own thickness; default: wall_thickness_m")
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
