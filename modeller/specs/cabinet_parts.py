"""A cabinet's parts, each checked on its own: fronts (doors, drawers, fixed panels), shelves,
dividers, the face frame, the back panel. Heights are above the floor, `left_m` from the
body's left outer edge seen from in front (see `modeller.specs.cabinets`).

A door's and a drawer's own rules (its shape, its handle on it, its bins) are here with them;
the rules that need the whole cabinet are in `modeller.specs.cabinet_rules`.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import Field, model_validator

from homemodel.core.yaml_specs import FieldError
from modeller.specs.common import _EPS_M, Colour, Length, Offset, _Spec
from modeller.specs.handles import DoorHandle, DrawerHandle, Handle, Orientation
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


class TopOverhang(_Spec):
    """A top slab wider or deeper than the carcass (a chest's, a desk's): how far it stands out
    past the carcass' faces; the sides and back reach up under it."""

    front_m: Offset = Field(0.0, description="past the body's front plane (not the fronts')")
    sides_m: Offset = Field(0.0, description="past each side panel's outer face")
    back_m: Offset = Field(0.0, description="past the back's outer face")


class TopRail(_Spec):
    """A rail (cleat) across an open top, side to side, flush with the sides' top edges."""

    from_front_m: Offset = Field(description="from the body's front plane back to the rail's front edge")
    depth_m: Length = Field(description="front to back")
    thickness_m: Length | None = Field(None, description="default: top_thickness_m (else wall_thickness_m)")


class BackPanel(_Spec):
    """A back panel of its own thickness, set in from the body's back edge (in a groove)."""

    thickness_m: Length = Field(0.008, description="3 to 8 mm usually")
    inset_m: Offset = Field(0.0, description="from the sides' back edges forward to the panel's back face")


# ---------------------------------------------------------------------------- a front alone


def check_door_front(door: DoorSpec) -> None:
    """A door on its own: its shape, its handle on it, its window and bins inside it."""
    if door.shape == "round" and abs(door.width_m - door.height_m) > _EPS_M:
        raise FieldError(
            ("height_m",),
            f"a round door is {door.width_m} m wide, so it is {door.width_m} m high, not {door.height_m}",
        )
    if not door.side_hinged and door.handle.type == "channel":
        raise FieldError(("handle", "type"), f"a grip channel is over a side-hinged door, not a {door.hinge}-hinged one")
    if door.side_hinged and door.handle.from_left_m is not None:
        raise FieldError(("handle", "from_left_m"), f"a {door.hinge}-hinged door's handle is placed by height_m")
    if not door.side_hinged and door.handle.height_m is not None:
        raise FieldError(("handle", "height_m"), f"a {door.hinge}-hinged door's handle is placed by from_left_m")
    centre = door.handle_offset_m()
    fields = ("from_free_edge_m", "height_m") if door.side_hinged else ("from_left_m", "from_free_edge_m")
    _check_handle_on_front(door, door.handle, centre, door.handle_orientation(), fields)
    if door.shape == "round":
        half_across, half_up = door.handle.half_extent_m(door.handle_orientation())
        reach = math.hypot(
            abs(centre[0] - door.width_m / 2) + half_across, abs(centre[1] - door.height_m / 2) + half_up
        )
        if reach > door.width_m / 2 + _EPS_M:
            raise FieldError(
                ("handle", "from_free_edge_m"),
                f"{door.handle.type} handle reaches {reach:.3f} m from the centre of a round door "
                f"{door.width_m / 2:.3f} m in radius",
            )
    if door.window is not None and 2 * door.window.margin_m >= min(door.width_m, door.height_m):
        raise FieldError(
            ("window", "margin_m"),
            f"a window {door.window.margin_m} m in from the edges leaves no glass in a "
            f"{door.width_m} x {door.height_m} m door",
        )
    for k, shelf in enumerate(door.shelves):
        if not door.side_hinged:
            raise FieldError(("shelves", k), f"door shelves need a side-hinged door, not a {door.hinge}-hinged one")
        if 2 * shelf.margin_m >= door.width_m:
            raise FieldError(("shelves", k, "margin_m"), f"leaves no bin on a {door.width_m} m wide door")
        if shelf.height_m + shelf.lip_height_m > door.height_m + _EPS_M:
            raise FieldError(
                ("shelves", k, "height_m"),
                f"bin reaches {shelf.height_m + shelf.lip_height_m:.3f} m up a {door.height_m} m high door",
            )


def check_drawer_front(drawer: DrawerSpec) -> None:
    """A drawer on its own: its handle on its front, its travel within its box."""
    _check_handle_on_front(
        drawer, drawer.handle, drawer.handle_offset_m(), drawer.handle_orientation(), ("from_left_m", "height_m")
    )
    if drawer.travel_m > drawer.depth_m + _EPS_M:
        raise FieldError(
            ("travel_m",), f"drawer travels {drawer.travel_m} m but its box is only {drawer.depth_m} m deep"
        )


def _check_handle_on_front(
    front: Front,
    handle: Handle,
    centre_m: tuple[float, float],
    orientation: Orientation,
    fields: tuple[str, str],
) -> None:
    """The handle's footprint (centre from the left and bottom edges) must lie on the front;
    `fields` are the handle's fields placing it across and up, to blame."""
    (across, up), (half_across, half_up) = centre_m, handle.half_extent_m(orientation)
    across_field, up_field = fields
    if across - half_across < -_EPS_M or across + half_across > front.width_m + _EPS_M:
        raise FieldError(
            ("handle", across_field),
            f"{handle.type} handle spans {across - half_across:.3f}..{across + half_across:.3f} m across a "
            f"{front.width_m} m wide front",
        )
    if up - half_up < -_EPS_M or up + half_up > front.height_m + _EPS_M:
        raise FieldError(
            ("handle", up_field),
            f"{handle.type} handle spans {up - half_up:.3f}..{up + half_up:.3f} m above the bottom edge of a "
            f"{front.height_m} m high front",
        )
