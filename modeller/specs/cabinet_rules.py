"""The feasibility rules of cabinet specs (`modeller.specs.cabinets`): what a tape measure can
say but no cabinet can be. Each rule raises `FieldError` naming the field to blame, with a
message saying what does not fit; the spec classes' validators run them.

A kind's own rules (a wardrobe's rails, an appliance's drum) stay with the kind, in its
`_check_kind`, which runs after these.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from homemodel.core.yaml_specs import FieldError
from modeller.specs.cabinet_geometry import (
    door_hinge_point_m,
    door_plug_bounds_m,
    door_shelf_box_m,
    door_slab_m,
    drawer_board_front_x_m,
    drawer_board_top_m,
    drawer_box_bounds_m,
    drawer_box_front_x_m,
    drawer_front_x_m,
    drawer_reach_m,
    frame_members_m,
    hinge_offsets_m,
    opening_around_m,
    panel_at,
    panel_bounds_m,
    shelf_box_m,
    shelf_span_m,
)
from modeller.specs.common import _EPS_M

if TYPE_CHECKING:
    from modeller.specs.cabinet_body import CabinetBody
    from modeller.specs.cabinet_parts import DoorShelf, DoorSpec, DrawerSpec, Front, Panel

# Angles at which a door's sweep is checked against the body (door shelves).
_SWEEP_SAMPLES = 91
# Readings to the millimetre (a front's bottom and its height) may add up to this much past
# the body they were measured on.
_TAPE_SLACK_M = 0.001


# ---------------------------------------------------------------------------- the whole cabinet


def check_cabinet(spec: CabinetBody) -> None:
    """The rules every cabinet-like kind shares, on a spec whose layout is filled in."""
    _check_walls(spec)
    _check_frame_and_top(spec)
    _check_shelves_and_dividers(spec)
    fronts = [("doors", i, f) for i, f in enumerate(spec.doors)] + [
        ("drawers", i, f) for i, f in enumerate(spec.drawers)
    ]
    placed = fronts + [("panels", i, p) for i, p in enumerate(spec.panels)]
    for group, i, front in placed:
        _check_on_body(spec, group, i, front)
    _check_no_overlap(placed)
    for i, drawer in enumerate(spec.drawers):
        _check_drawer(spec, i, drawer)
    for i, door in enumerate(spec.doors):
        _check_door(spec, i, door)
    for group, i, front in fronts:
        if front.mounting == "inset":
            _check_inset(spec, group, i, front)
    for i, panel in enumerate(spec.panels):
        _check_panel(spec, i, panel)
    _check_knobs(spec)
    _check_buttons(spec)


def _check_walls(spec: CabinetBody) -> None:
    t = spec.wall_thickness_m
    carcass_height = spec.carcass_top_m - spec.carcass_bottom_m
    if 2 * t >= spec.width_m:
        raise FieldError(
            ("wall_thickness_m",), f"walls {t} m thick leave no room inside a {spec.width_m} m wide {spec.kind_label}"
        )
    if t >= spec.depth_m:
        raise FieldError(
            ("wall_thickness_m",),
            f"a back wall {t} m thick leaves no room in a {spec.depth_m} m deep {spec.kind_label}",
        )
    if spec.inner_top_m - spec.inner_floor_m <= 0:
        raise FieldError(
            ("plinth_height_m",) if spec.plinth_height_m > 0 else ("wall_thickness_m",),
            f"top and bottom {spec.carcass_top_m - spec.inner_top_m:.3f} and {spec.bottom_board_m} m thick leave "
            f"no room in a body {carcass_height:.3f} m high above the plinth",
        )
    if spec.legs is not None:
        if spec.plinth_height_m <= 0:
            raise FieldError(("legs",), "legs stand under the carcass: give their height as plinth_height_m")
        spec.legs.check_fit((spec.depth_m, spec.width_m), round_top=False, what=f"a {spec.kind_label}")
    elif spec.plinth_height_m > 0 and spec.plinth_recess_m + 2 * t >= spec.depth_m:
        raise FieldError(
            ("plinth_recess_m",), f"a plinth set back {spec.plinth_recess_m} m leaves no plinth under the body"
        )


def _check_frame_and_top(spec: CabinetBody) -> None:
    """A face frame's members on the front, its overhang narrower than its stiles; a top's
    overhang; top rails over an open top."""
    frame = spec.face_frame
    if frame is not None and frame.overhang_m >= frame.width_m:
        raise FieldError(
            ("face_frame", "overhang_m"), f"stiles {frame.width_m} m wide cannot stand {frame.overhang_m} m out"
        )
    if frame is not None:
        members = frame_members_m(spec)
        left, right = members[0][2], members[1][1]
        bottom, top = members[2][4], members[3][3]
        for name, m_left, m_right, m_bottom, m_top in members[4:]:
            _, member, k = name.split("_")  # frame_stile_<k>, frame_rail_<k>
            where = ("face_frame", f"{member}s", int(k))
            if m_left < left - _EPS_M or m_right > right + _EPS_M or m_right - m_left <= 0:
                raise FieldError(
                    (*where, "left_m"),
                    f"spans {m_left:.3f}..{m_right:.3f} m, not inside the frame's opening {left:.3f}..{right:.3f} m",
                )
            if m_bottom < bottom - _EPS_M or m_top > top + _EPS_M or m_top - m_bottom <= 0:
                raise FieldError(
                    (*where, "bottom_m"),
                    f"spans {m_bottom:.3f}..{m_top:.3f} m up, not inside the frame's opening {bottom:.3f}..{top:.3f} m",
                )
    _check_top_overhang(spec)
    if spec.top_rails and spec.top_panel:
        raise FieldError(("top_rails",), "rails go across an open top; give top_panel: false")
    for i, rail in enumerate(spec.top_rails):
        if rail.from_front_m + rail.depth_m > spec.depth_m + _EPS_M:
            raise FieldError(
                ("top_rails", i, "depth_m"), f"rail reaches {rail.from_front_m + rail.depth_m:.3f} m back in a "
                f"{spec.depth_m} m deep body"
            )
        thickness = spec.top_board_m if rail.thickness_m is None else rail.thickness_m
        if spec.carcass_top_m - thickness < spec.inner_floor_m:
            raise FieldError(("top_rails", i, "thickness_m"), f"a rail {thickness} m thick fills the body")


def _check_top_overhang(spec: CabinetBody) -> None:
    """An overhanging top needs a top; standing out over the fronts, it leaves them below it."""
    over = spec.top_overhang
    if over is None:
        return
    if not spec.top_panel:
        raise FieldError(("top_overhang",), "an open top (top_panel: false) has no top to overhang")
    if over.front_m <= spec.door_gap_m:
        return
    underside = spec.carcass_top_m - spec.top_board_m
    for group in ("doors", "drawers", "panels"):
        for i, front in enumerate(getattr(spec, group) or []):
            if front.top_m > underside + _TAPE_SLACK_M:
                raise FieldError(
                    ("top_overhang", "front_m"),
                    f"a top {over.front_m} m over the front would cut {group[:-1]} {i}, which reaches "
                    f"{front.top_m:.3f} m up, past the top's underside at {underside:.3f} m",
                )


def _check_shelves_and_dividers(spec: CabinetBody) -> None:
    t = spec.wall_thickness_m
    for i, divider in enumerate(spec.dividers):
        if divider.left_m < t - _EPS_M or divider.left_m + t > spec.width_m - t + _EPS_M:
            raise FieldError(
                ("dividers", i, "left_m"),
                f"divider at {divider.left_m} m is not between the side walls of a {spec.width_m} m wide body",
            )
        for j, other in enumerate(spec.dividers[:i]):
            if abs(other.left_m - divider.left_m) < t - _EPS_M:
                raise FieldError(("dividers", i, "left_m"), f"divider {i} overlaps divider {j}")
    for i, shelf in enumerate(spec.shelves):
        if shelf.height_m > spec.inner_top_m + _EPS_M:
            raise FieldError(
                ("shelves", i, "height_m"),
                f"shelf at {shelf.height_m} m is above the body's inside top at {spec.inner_top_m:.3f} m",
            )
        if shelf.height_m - spec.shelf_board_m(shelf) < spec.inner_floor_m - _EPS_M:
            raise FieldError(
                ("shelves", i, "height_m"),
                f"shelf at {shelf.height_m} m ({spec.shelf_board_m(shelf)} m thick) is below the body's inside floor at "
                f"{spec.inner_floor_m:.3f} m",
            )
        left, right, depth = shelf_span_m(spec, shelf)
        if left < t - _EPS_M or right > spec.width_m - t + _EPS_M or right - left <= 0:
            raise FieldError(
                ("shelves", i, "width_m" if shelf.width_m is not None else "left_m"),
                f"shelf spans {left:.3f}..{right:.3f} m, not between the side walls of a {spec.width_m} m wide body",
            )
        if depth > spec.inner_depth_m + _EPS_M:
            raise FieldError(
                ("shelves", i, "depth_m"), f"shelf {depth} m deep in a body {spec.inner_depth_m:.3f} m deep inside"
            )
        for j, divider in enumerate(spec.dividers):
            if left < divider.left_m + t - _EPS_M and right > divider.left_m + _EPS_M:
                raise FieldError(
                    ("shelves", i, "width_m" if shelf.width_m is not None else "left_m"),
                    f"shelf spanning {left:.3f}..{right:.3f} m cuts through divider {j} at {divider.left_m} m",
                )


def _check_on_body(spec: CabinetBody, group: str, i: int, front: Front) -> None:
    """A front lies on the body's front; doors and drawers may also cover a face frame's
    stiles where they stand out past the sides."""
    what = group[:-1]
    out = spec.face_frame.overhang_m if spec.face_frame is not None and group != "panels" else 0.0
    across = spec.width_m + 2 * out
    if front.width_m > across + _TAPE_SLACK_M:
        raise FieldError(
            (group, i, "width_m"), f"{what} is {front.width_m} m wide but the {spec.kind_label} is {across:.3g} m"
        )
    if front.left_m < -out - _TAPE_SLACK_M or front.right_m > spec.width_m + out + _TAPE_SLACK_M:
        beyond = f", its face frame {out} m past each side" if out else ""
        raise FieldError(
            (group, i, "left_m"),
            f"{what} spans {front.left_m}..{front.right_m:.3f} m from the left edge "
            f"but the {spec.kind_label} is {spec.width_m} m wide{beyond}",
        )
    body_height = spec.top_m - spec.base_m
    if front.height_m > body_height + _TAPE_SLACK_M:
        raise FieldError(
            (group, i, "height_m"),
            f"{what} is {front.height_m} m high but the {spec.kind_label} is {body_height:.3g} m",
        )
    if front.top_m > spec.top_m + _TAPE_SLACK_M:
        raise FieldError(
            (group, i, "bottom_m"),
            f"{what} reaches {front.top_m:.3f} m above the floor "
            f"but the {spec.kind_label}'s top is at {spec.top_m:.3g} m",
        )
    if front.bottom_m < spec.base_m - _TAPE_SLACK_M:
        raise FieldError(
            (group, i, "bottom_m"),
            f"{what} starts {front.bottom_m} m above the floor, below the {spec.kind_label} at {spec.base_m} m",
        )


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


def _check_drawer(spec: CabinetBody, i: int, drawer: DrawerSpec) -> None:
    room = min(drawer_box_front_x_m(spec, drawer), spec.depth_m / 2) - spec.back_inner_x_m
    if drawer.depth_m > room + _EPS_M:
        raise FieldError(
            ("drawers", i, "depth_m"),
            f"drawer box is {drawer.depth_m} m deep but the body is {room:.3f} m deep inside, behind the front",
        )
    y_min, y_max, z_min, z_max = drawer_box_bounds_m(spec, drawer)
    t = spec.wall_thickness_m
    box_wall = t if drawer.box_wall_m is None else drawer.box_wall_m
    if drawer.inner_board_inside_m is not None and drawer_board_front_x_m(spec, drawer) > drawer_front_x_m(spec, drawer) + _EPS_M:
        raise FieldError(
            ("drawers", i, "inner_board_inside_m"),
            f"a second board {drawer.inner_board_inside_m} m inside the opening is in the inset front",
        )
    middle = drawer.left_m + drawer.width_m / 2
    left, right, bottom, top = opening_around_m(spec, middle, drawer.bottom_m + drawer.height_m / 2)
    if drawer.inner_board_height_m is not None:
        if drawer.inner_board_m <= 0:
            raise FieldError(("drawers", i, "inner_board_height_m"), "a second board's height needs its inner_board_m")
        board_top = drawer_board_top_m(spec, drawer)
        if board_top > top + _EPS_M:
            raise FieldError(
                ("drawers", i, "inner_board_height_m"),
                f"drawer {i}'s second board reaches {board_top:.3f} m, above its opening's top at {top:.3f} m",
            )
    if y_min < -spec.width_m / 2 + left - _EPS_M or y_max > -spec.width_m / 2 + right + _EPS_M:
        raise FieldError(
            ("drawers", i, "box_offset_m" if drawer.box_offset_m or drawer.box_width_m is None else "box_width_m"),
            f"drawer {i}'s box spans {y_min + spec.width_m / 2:.3f}..{y_max + spec.width_m / 2:.3f} m from the left, "
            f"outside its opening {left:.3f}..{right:.3f} m",
        )
    if z_min < bottom - _EPS_M:
        raise FieldError(
            ("drawers", i, "box_bottom_m"), f"drawer {i}'s box starts at {z_min:.3f} m, below its opening at {bottom:.3f} m"
        )
    if y_max - y_min <= 2 * box_wall:
        raise FieldError(
            ("drawers", i, "width_m"), f"drawer front leaves a box {y_max - y_min:.3f} m wide inside the body"
        )
    if z_max - z_min <= box_wall:
        raise FieldError(
            ("drawers", i, "height_m"), f"drawer front leaves a box {z_max - z_min:.3f} m high inside the body"
        )
    if drawer.handle.type == "recessed" and drawer.handle.recess_depth_m >= spec.door_thickness_m:
        raise FieldError(
            ("drawers", i, "handle", "recess_depth_m"),
            f"a pocket {drawer.handle.recess_depth_m} m deep goes through a {spec.door_thickness_m} m thick front",
        )
    for k, shelf in enumerate(spec.shelves):
        left, right, _ = shelf_span_m(spec, shelf)
        beside = right - spec.width_m / 2 <= y_min or left - spec.width_m / 2 >= y_max
        if not beside and shelf.height_m > z_min and shelf.height_m - spec.shelf_board_m(shelf) < z_max:
            raise FieldError(
                ("shelves", k, "height_m"),
                f"shelf at {shelf.height_m} m cuts through drawer {i}'s box ({z_min:.3f}..{z_max:.3f} m)",
            )
    for k, divider in enumerate(spec.dividers):
        y0 = -spec.width_m / 2 + divider.left_m
        if y0 < y_max and y0 + t > y_min:
            raise FieldError(
                ("drawers", i, "width_m"), f"drawer {i}'s box runs through divider {k} at {divider.left_m} m"
            )


def _check_door(spec: CabinetBody, i: int, door: DoorSpec) -> None:
    try:
        hinge_offsets_m(spec, door)  # measurements solved here, so a misread tape fails on load
    except FieldError as exc:
        raise FieldError(("doors", i, *exc.loc), str(exc)) from None
    slab = door_slab_m(spec, door)
    if door.handle.type == "recessed" and door.handle.recess_depth_m >= slab:
        raise FieldError(
            ("doors", i, "handle", "recess_depth_m"),
            f"a pocket {door.handle.recess_depth_m} m deep goes through a {slab:.3f} m thick door",
        )
    if door.in_opening_m > 0:
        if door.mounting == "inset":
            raise FieldError(("doors", i, "in_opening_m"), "an inset door is in the opening already; give its thickness")
        if slab <= 0:
            raise FieldError(
                ("doors", i, "in_opening_m"),
                f"{door.in_opening_m} m inside the opening leaves nothing of a {spec.door_board_m(door)} m thick door "
                f"in front of it ({spec.door_gap_m} m clear of the body)",
            )
        y0, y1, z0, z1 = door_plug_bounds_m(spec, door)
        if y1 - y0 <= 0 or z1 - z0 <= 0:
            raise FieldError(("doors", i, "in_opening_m"), f"door {i} is not over an opening its inner part could enter")
    for k, shelf in enumerate(door.shelves):
        _check_door_shelf(spec, i, door, k, shelf)


def _check_door_shelf(spec: CabinetBody, i: int, door: DoorSpec, k: int, shelf: DoorShelf) -> None:
    """A closed door's bin must sit inside the body, clear of shelves and drawers, and swing out clear."""
    t, where = spec.wall_thickness_m, ("doors", i, "shelves", k)
    low, high = door_shelf_box_m(spec, door, shelf)
    if shelf.depth_m > spec.inner_depth_m + _EPS_M:
        raise FieldError(
            (*where, "depth_m"), f"bin {shelf.depth_m} m deep in a body {spec.inner_depth_m:.3f} m deep"
        )
    if low[1] < -spec.width_m / 2 + t - _EPS_M or high[1] > spec.width_m / 2 - t + _EPS_M:
        raise FieldError((*where, "margin_m"), "bin reaches into the body's side walls; give a larger margin_m")
    if low[2] < spec.inner_floor_m - _EPS_M or high[2] > spec.inner_top_m + _EPS_M:
        raise FieldError((*where, "height_m"), "bin is not between the body's inside floor and top")
    obstacles = [(f"shelf {j}", *shelf_box_m(spec, s)) for j, s in enumerate(spec.shelves)]
    obstacles += [(f"drawer {j}", *drawer_reach_m(spec, d)) for j, d in enumerate(spec.drawers)]
    for name, o_low, o_high in obstacles:
        if np.all(np.minimum(high, o_high) - np.maximum(low, o_low) > _EPS_M):
            raise FieldError(
                (*where, "depth_m"),
                f"bin runs into {name} when the door is closed; set that back or the bin shallower",
            )
    # Swinging open, the bin's far corners must clear the side wall on the door's free side.
    hinge_x, hinge_y, _ = door_hinge_point_m(spec, door)
    inner_wall = (spec.width_m / 2 - t) if door.hinge == "left" else (-spec.width_m / 2 + t)
    angles = np.radians(np.linspace(0, door.opening_limit_deg, _SWEEP_SAMPLES))
    for corner_y in (low[1], high[1]):
        dx, dy = low[0] - hinge_x, corner_y - hinge_y
        sign = 1.0 if door.hinge == "left" else -1.0  # the left door turns about -z
        x = hinge_x + dx * np.cos(angles) + sign * dy * np.sin(angles)
        y = hinge_y - sign * dx * np.sin(angles) + dy * np.cos(angles)
        inside = x < spec.depth_m / 2
        beyond = (y > inner_wall) if door.hinge == "left" else (y < inner_wall)
        if np.any(inside & beyond):
            raise FieldError(
                (*where, "margin_m"), "bin hits the body's side wall as the door opens; give a larger margin_m"
            )


def _check_inset(spec: CabinetBody, group: str, i: int, front: Front) -> None:
    """An inset front sits inside the opening (the carcass' edges or the face frame)."""
    left, right, bottom, top = opening_around_m(spec, front.left_m + front.width_m / 2, front.bottom_m + front.height_m / 2)
    if front.left_m < left - _EPS_M or front.right_m > right + _EPS_M:
        raise FieldError(
            (group, i, "left_m"),
            f"inset {group[:-1]} spans {front.left_m}..{front.right_m:.3f} m but the opening is {left:.3f}..{right:.3f} m",
        )
    if front.bottom_m < bottom - _EPS_M or front.top_m > top + _EPS_M:
        raise FieldError(
            (group, i, "bottom_m"),
            f"inset {group[:-1]} spans {front.bottom_m}..{front.top_m:.3f} m up but the opening is "
            f"{bottom:.3f}..{top:.3f} m",
        )


def _check_panel(spec: CabinetBody, i: int, panel: Panel) -> None:
    for j, door in enumerate(spec.doors):
        over = (
            min(door.right_m, panel.right_m) - max(door.left_m, panel.left_m) > _EPS_M
            and min(door.top_m, panel.top_m) - max(door.bottom_m, panel.bottom_m) > _EPS_M
        )
        room = spec.door_gap_m if door.mounting != "inset" else -spec.door_board_m(door)
        if over and panel.forward_m > room + _EPS_M:
            raise FieldError(("panels", i, "forward_m"), f"panel stands {panel.forward_m} m out, into door {j}")
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


def _on_a_panel(spec: CabinetBody, left_m: float, height_m: float, radius_m: float, up_m: float | None = None) -> bool:
    """Whether the rectangle `radius_m` either side and `up_m` (default: the same) above and
    below the point lies on one panel."""
    up_m = radius_m if up_m is None else up_m
    return any(
        left_m - radius_m >= p.left_m - _EPS_M
        and left_m + radius_m <= p.right_m + _EPS_M
        and height_m - up_m >= p.bottom_m - _EPS_M
        and height_m + up_m <= p.top_m + _EPS_M
        for p in spec.panels
    )


def _check_buttons(spec: CabinetBody) -> None:
    for i, button in enumerate(spec.buttons):
        across, up = button.half_size_m
        if not _on_a_panel(spec, button.left_m, button.height_m, across, up):
            raise FieldError(
                ("buttons", i, "left_m"),
                f"button at {button.left_m} m from the left, {button.height_m} m up is off every panel",
            )
        for k, knob in enumerate(spec.knobs):
            if button.shape == "round" and button.pocket is None and knob.pocket is None:
                gap = math.hypot(button.left_m - knob.left_m, button.height_m - knob.height_m)
                overlaps = gap < (button.diameter_m + knob.diameter_m) / 2 - _EPS_M
            else:
                overlaps = _boxes_overlap(button.left_m, button.height_m, (across, up), knob.left_m, knob.height_m, knob.half_size_m)
            if overlaps:
                raise FieldError(("buttons", i, "left_m"), f"button {i} overlaps knob {k}")
        for k, other in enumerate(spec.buttons[:i]):
            if _boxes_overlap(button.left_m, button.height_m, (across, up), other.left_m, other.height_m, other.half_size_m):
                raise FieldError(("buttons", i, "left_m"), f"button {i} overlaps button {k}")
    for group, parts in (("buttons", spec.buttons), ("knobs", spec.knobs)):
        for i, part in enumerate(parts):
            if part.pocket is not None:
                _check_pocket(spec, group, i, part)


def _boxes_overlap(x0: float, z0: float, half0: tuple[float, float], x1: float, z1: float, half1: tuple[float, float]) -> bool:
    return abs(x0 - x1) < half0[0] + half1[0] - _EPS_M and abs(z0 - z1) < half0[1] + half1[1] - _EPS_M


def _check_pocket(spec: CabinetBody, group: str, i: int, part) -> None:
    """A pocket lies in one panel without a hole, shallower than the panel is thick."""
    panel = panel_at(spec, part.left_m, part.height_m)
    if panel is None or panel.hole is not None:
        raise FieldError((group, i, "pocket"), f"a pocket is cut into a panel without a hole; {group[:-1]} {i} has none")
    y0, y1, z0, z1 = panel_bounds_m(spec, panel)
    across, up = part.half_size_m
    y, z = -spec.width_m / 2 + part.left_m, part.height_m
    if y - across < y0 - _EPS_M or y + across > y1 + _EPS_M or z - up < z0 - _EPS_M or z + up > z1 + _EPS_M:
        raise FieldError(
            (group, i, "pocket"),
            f"the pocket round {group[:-1]} {i} reaches into the carcass' edge round its panel "
            f"({y0 + spec.width_m / 2:.3f}..{y1 + spec.width_m / 2:.3f} m across, {z0:.3f}..{z1:.3f} m up)",
        )
    thickness = spec.panel_board_m(panel)
    if part.pocket.depth_m >= thickness:
        raise FieldError(
            (group, i, "pocket", "depth_m"),
            f"a pocket {part.pocket.depth_m} m deep goes through a panel {thickness} m thick; give the panel's thickness_m",
        )


def _check_knobs(spec: CabinetBody) -> None:
    for i, knob in enumerate(spec.knobs):
        r = knob.half_size_m[0]
        if not _on_a_panel(spec, knob.left_m, knob.height_m, r):
            raise FieldError(
                ("knobs", i, "left_m"),
                f"knob {knob.diameter_m} m across at {knob.left_m} m from the left, {knob.height_m} m up "
                f"is off every panel ({len(spec.panels)} panels)",
            )
        for j, door in enumerate(spec.doors):
            if (
                knob.left_m + r > door.left_m + _EPS_M
                and knob.left_m - r < door.right_m - _EPS_M
                and knob.height_m + r > door.bottom_m + _EPS_M
                and knob.height_m - r < door.top_m - _EPS_M
            ):
                raise FieldError(("knobs", i, "left_m"), f"knob {i} is behind door {j}, which would close on it")
        for j, other in enumerate(spec.knobs[:i]):
            gap = math.hypot(knob.left_m - other.left_m, knob.height_m - other.height_m) - r - other.half_size_m[0]
            if gap < -_EPS_M:
                raise FieldError(("knobs", i, "left_m"), f"knob {i} overlaps knob {j} by {-gap:.3f} m")
