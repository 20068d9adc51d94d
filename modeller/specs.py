"""Measurement specs: what an installer measures with a tape, as pydantic models.

Lengths are metres (`_m`), angles degrees (`_deg`), masses kilograms. Colours are
`[r, g, b]` in 0..1 (linear, as Blender, URDF and glTF take them) or a name from
`NAMED_COLOURS`.

Every model's frame: origin at the centre of its footprint on the floor, +z up, +x out of
its front face, +y to the object's own left. An installer standing in front of it, facing
it, has -y on the left hand and +y on the right. "Left" and "right" in a spec (a door's
hinge side, `left_m` offsets) are always as that installer sees them.

Checks that need more than one field (a door wider than the cupboard, overlapping fronts,
...) raise `FieldError`, which carries the path of the field to blame below the model it
is checked in; `homemodel.yaml_specs` joins it to pydantic's location.
"""

from __future__ import annotations

from typing import Annotated, ClassVar, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, model_validator

from homemodel.yaml_specs import FieldError

# Below this, two lengths count as equal (floating point noise in YAML values).
_EPS_M = 1e-9

Length = Annotated[float, Field(gt=0)]
Offset = Annotated[float, Field(ge=0)]
_Unit = Annotated[float, Field(ge=0, le=1)]

NAMED_COLOURS: dict[str, tuple[float, float, float]] = {
    "white": (0.9, 0.9, 0.9),
    "black": (0.02, 0.02, 0.02),
    "grey": (0.35, 0.35, 0.35),
    "gray": (0.35, 0.35, 0.35),
    "silver": (0.6, 0.6, 0.62),
    "red": (0.75, 0.05, 0.05),
    "green": (0.1, 0.5, 0.1),
    "blue": (0.05, 0.15, 0.7),
    "yellow": (0.85, 0.7, 0.05),
    "orange": (0.9, 0.35, 0.02),
    "brown": (0.3, 0.15, 0.06),
    "beige": (0.75, 0.65, 0.5),
    "oak": (0.55, 0.36, 0.18),
    "pink": (0.9, 0.4, 0.55),
    "purple": (0.35, 0.08, 0.5),
}


def _known_colour(value: str | tuple[float, float, float]) -> str | tuple[float, float, float]:
    if isinstance(value, str):
        name = value.strip().lower()
        if name not in NAMED_COLOURS:
            raise ValueError(f"unknown colour {value!r}; give [r, g, b] or one of {', '.join(NAMED_COLOURS)}")
        return name
    return value


Colour = Annotated[str | tuple[_Unit, _Unit, _Unit], AfterValidator(_known_colour)]


def colour_rgb(colour: Colour) -> tuple[float, float, float]:
    return NAMED_COLOURS[colour] if isinstance(colour, str) else tuple(colour)


def colour_name(colour: Colour) -> str:
    """The colour's name, or `rgb_rrggbb` for a colour given as numbers."""
    if isinstance(colour, str):
        return colour
    return "rgb_" + "".join(f"{round(c * 255):02x}" for c in colour)


class _Spec(BaseModel):
    # A misspelt field must not be silently ignored: the default it leaves is a wrong model.
    # YAML reads .nan and .inf as numbers; no measurement is either.
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class ObjectSpec(_Spec):
    """Fields every kind of model has."""

    default_density_kg_m3: ClassVar[float]

    name: str | None = Field(None, description="model name; default: the spec file's name without .yaml")
    density_kg_m3: Length | None = None
    mass_kg: Length | None = Field(None, description="total mass, spread uniformly over the volume")

    @model_validator(mode="after")
    def _one_mass(self) -> ObjectSpec:
        if self.density_kg_m3 is not None and self.mass_kg is not None:
            raise FieldError(("mass_kg",), "give density_kg_m3 or mass_kg, not both")
        return self

    @property
    def density_or_default_kg_m3(self) -> float | None:
        """The density to use, or None when `mass_kg` decides."""
        if self.mass_kg is not None:
            return None
        return self.density_kg_m3 if self.density_kg_m3 is not None else self.default_density_kg_m3


# ---------------------------------------------------------------------------- cupboard


class BarHandle(_Spec):
    """A straight bar on two posts, screwed to a door or drawer front."""

    length_m: Length = 0.16
    diameter_m: Length = 0.012
    standoff_m: Length = Field(0.035, description="from the front's outer face to the bar's axis")
    orientation: Literal["vertical", "horizontal"]

    @model_validator(mode="after")
    def _bar_fits(self) -> BarHandle:
        if self.length_m < 3 * self.diameter_m:
            raise FieldError(
                ("length_m",), f"bar of {self.length_m} m is too short for its {self.diameter_m} m diameter"
            )
        if self.standoff_m <= self.diameter_m / 2:
            raise FieldError(
                ("standoff_m",),
                f"bar axis {self.standoff_m} m off the front is inside the front ({self.diameter_m} m bar)",
            )
        return self

    @property
    def half_extent_m(self) -> tuple[float, float]:
        """Half the bar's footprint on the front: (across the front, up the front)."""
        along, across = self.length_m / 2, self.diameter_m / 2
        return (across, along) if self.orientation == "vertical" else (along, across)


class DoorHandle(BarHandle):
    orientation: Literal["vertical", "horizontal"] = "vertical"
    from_free_edge_m: Offset = Field(0.04, description="from the door's free (unhinged) edge to the bar's centre")
    height_m: Offset | None = Field(None, description="bar centre above the door's bottom edge; default: mid-door")


class DrawerHandle(BarHandle):
    orientation: Literal["vertical", "horizontal"] = "horizontal"
    from_left_m: Offset | None = Field(None, description="bar centre from the front's left edge; default: centred")
    height_m: Offset | None = Field(None, description="bar centre above the front's bottom edge; default: centred")


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


# ---------------------------------------------------------------------------- table


class TableTop(_Spec):
    length_m: Length = Field(description="side to side, seen from the front (along y)")
    width_m: Length = Field(description="front to back (along x)")
    thickness_m: Length = 0.03


class TableLegs(_Spec):
    """Four legs, square (`size_m`) or round (`diameter_m`); 5 cm square when neither is given."""

    size_m: Length | None = None
    diameter_m: Length | None = None
    inset_m: Offset = Field(0.03, description="from the top's edge to the leg's outer face")

    @model_validator(mode="after")
    def _one_section(self) -> TableLegs:
        if self.size_m is not None and self.diameter_m is not None:
            raise FieldError(("diameter_m",), "give size_m (square legs) or diameter_m (round legs), not both")
        return self

    @property
    def section_m(self) -> float:
        if self.diameter_m is not None:
            return self.diameter_m
        return self.size_m if self.size_m is not None else 0.05


class TableSpec(ObjectSpec):
    default_density_kg_m3: ClassVar[float] = 700.0  # wood

    kind: Literal["table"]
    top: TableTop
    height_m: Length = Field(description="floor to the top surface")
    legs: TableLegs = Field(default_factory=TableLegs)
    colour: Colour = "oak"

    @model_validator(mode="after")
    def _geometry_possible(self) -> TableSpec:
        if self.top.thickness_m >= self.height_m:
            raise FieldError(
                ("top", "thickness_m"), f"top {self.top.thickness_m} m thick on a table {self.height_m} m high"
            )
        footprint = 2 * (self.legs.inset_m + self.legs.section_m)
        narrowest = min(self.top.length_m, self.top.width_m)
        if footprint >= narrowest:
            raise FieldError(
                ("legs", "inset_m"),
                f"legs {self.legs.section_m} m thick, {self.legs.inset_m} m in from the edges, "
                f"do not fit under a top {narrowest} m across",
            )
        return self


# ---------------------------------------------------------------------------- cup


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


SPEC_TYPES: dict[str, type[ObjectSpec]] = {"cupboard": CupboardSpec, "table": TableSpec, "cup": CupSpec}
Spec = CupboardSpec | TableSpec | CupSpec
