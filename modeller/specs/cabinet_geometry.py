"""Where a cabinet's parts lie, worked out from its spec (`modeller.specs.cabinets`): shelf
spans, drawer boxes, door bins. The feasibility rules check them, and the builders place
the parts by them, so both agree on one geometry.

Model frame as in `modeller.specs.common`: the body's front plane at x = depth_m / 2, its
left edge (seen from in front) at y = -width_m / 2.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from homemodel.core.yaml_specs import FieldError
from modeller.specs.hinges import (
    TAPE_AGREEMENT_M,
    THICKNESS_AGREEMENT_M,
    check_hinge_offsets,
    open_at_90_inner_face_m,
    solve_free_corner,
    solve_open_at_90,
)

# A cup hinge's door keeps at least this gap to the carcass' front (its axis' depth grows as
# the gap shrinks, see `hinge_offsets_m`).
_MIN_HINGE_GAP_M = 0.0005

if TYPE_CHECKING:
    from modeller.specs.cabinet_body import CabinetBody
    from modeller.specs.cabinet_parts import DoorShelf, DoorSpec, DrawerSpec, Panel, Shelf


def shelf_span_m(spec: CabinetBody, shelf: Shelf) -> tuple[float, float, float]:
    """(left, right) from the body's left edge and depth from the back wall's inner face."""
    t = spec.wall_thickness_m
    left = t if shelf.left_m is None else shelf.left_m
    right = spec.width_m - t if shelf.width_m is None else left + shelf.width_m
    default_depth = spec.inner_depth_m - spec.front_recess_m
    return left, right, default_depth if shelf.depth_m is None else shelf.depth_m


def frame_members_m(spec: CabinetBody) -> list[tuple[str, float, float, float, float]]:
    """(name, left, right, bottom, top) of each face frame member seen from in front, left
    and right from the body's left edge (an overhanging stile starts left of it)."""
    frame = spec.face_frame
    if frame is None:
        return []
    w, out = frame.width_m, frame.overhang_m
    bottom, top = spec.carcass_bottom_m, spec.carcass_top_m
    inner_left, inner_right = w - out, spec.width_m + out - w
    members = [
        ("frame_left", -out, inner_left, bottom, top),
        ("frame_right", inner_right, spec.width_m + out, bottom, top),
        ("frame_bottom", inner_left, inner_right, bottom, bottom + w),
        ("frame_top", inner_left, inner_right, top - w, top),
    ]
    for k, stile in enumerate(frame.stiles):
        width = w if stile.width_m is None else stile.width_m
        low = bottom + w if stile.bottom_m is None else stile.bottom_m
        high = top - w if stile.top_m is None else stile.top_m
        members.append((f"frame_stile_{k}", stile.left_m, stile.left_m + width, low, high))
    for k, rail in enumerate(frame.rails):
        height = w if rail.height_m is None else rail.height_m
        left = inner_left if rail.left_m is None else rail.left_m
        right = inner_right if rail.right_m is None else rail.right_m
        members.append((f"frame_rail_{k}", left, right, rail.bottom_m, rail.bottom_m + height))
    return members


def opening_around_m(spec: CabinetBody, left_m: float, height_m: float) -> tuple[float, float, float, float]:
    """(left, right, bottom, top) of the opening round a point of the front (`left_m` from the
    body's left edge, `height_m` above the floor): inside the carcass' edges or the face
    frame, between the dividers and the frame's middle stiles and rails either side of it."""
    t = spec.wall_thickness_m
    left, right, bottom, top = opening_bounds_m(spec)
    for d in spec.dividers:
        if d.left_m + t <= left_m:
            left = max(left, d.left_m + t)
        if d.left_m >= left_m:
            right = min(right, d.left_m)
    for name, m_left, m_right, m_bottom, m_top in frame_members_m(spec)[4:]:
        if name.startswith("frame_stile") and m_bottom <= height_m <= m_top:
            left = max(left, m_right) if m_right <= left_m else left
            right = min(right, m_left) if m_left >= left_m else right
        if name.startswith("frame_rail") and m_left <= left_m <= m_right:
            bottom = max(bottom, m_top) if m_top <= height_m else bottom
            top = min(top, m_bottom) if m_bottom >= height_m else top
    return left, right, bottom, top


def drawer_box_bounds_m(spec: CabinetBody, drawer: DrawerSpec) -> tuple[float, float, float, float]:
    """(y_min, y_max, z_min, z_max) of a drawer's box: behind its front, inside the body
    between the walls, dividers and frame members either side of the front's middle, or
    where the spec puts it (`box_bottom_m`, `box_offset_m`, `box_width_m`)."""
    gap = spec.door_gap_m
    runners = gap if drawer.runner_clearance_m is None else drawer.runner_clearance_m
    middle = drawer.left_m + drawer.width_m / 2
    # Inside the opening: the carcass' walls, or a face frame's stiles and rails.
    inner_left, inner_right, open_bottom, open_top = opening_around_m(spec, middle, drawer.bottom_m + drawer.height_m / 2)
    # Seen from in front, the body's left edge is at y = -width/2.
    if drawer.box_width_m is None:
        y_min = -spec.width_m / 2 + max(drawer.left_m, inner_left) + runners + drawer.box_offset_m
        y_max = -spec.width_m / 2 + min(drawer.right_m, inner_right) - runners + drawer.box_offset_m
    else:
        centre = -spec.width_m / 2 + middle + drawer.box_offset_m
        y_min, y_max = centre - drawer.box_width_m / 2, centre + drawer.box_width_m / 2
    if drawer.box_bottom_m is None:
        z_min = max(drawer.bottom_m, open_bottom) + gap
    else:
        z_min = drawer.bottom_m + drawer.box_bottom_m
    z_max = min(drawer.top_m, open_top) - gap
    if drawer.box_height_m is not None:
        z_max = min(z_max, z_min + drawer.box_height_m)
    return y_min, y_max, z_min, z_max


def drawer_front_x_m(spec: CabinetBody, drawer: DrawerSpec) -> float:
    """x of a closed drawer front's inner face: behind it the inner board, then the box."""
    if drawer.mounting == "inset":
        return spec.depth_m / 2 - spec.door_thickness_m
    return spec.depth_m / 2 + spec.door_gap_m


def drawer_board_front_x_m(spec: CabinetBody, drawer: DrawerSpec) -> float:
    """x of a closed drawer's second board's front face: right behind the front, or where measured."""
    if drawer.inner_board_inside_m is None:
        return drawer_front_x_m(spec, drawer)
    return spec.depth_m / 2 - drawer.inner_board_inside_m


def drawer_board_top_m(spec: CabinetBody, drawer: DrawerSpec) -> float:
    """Height above the floor of a drawer's second board's top edge: as measured, or up to
    the front's top, `door_gap_m` inside the opening."""
    z_min = drawer_box_bounds_m(spec, drawer)[2]
    if drawer.inner_board_height_m is not None:
        return z_min + drawer.inner_board_height_m
    return min(drawer.top_m, opening_around_m(spec, drawer.left_m + drawer.width_m / 2, z_min)[3]) - spec.door_gap_m


def drawer_box_front_x_m(spec: CabinetBody, drawer: DrawerSpec) -> float:
    """x of a closed drawer box's front face (behind the front and its inner board)."""
    return drawer_board_front_x_m(spec, drawer) - drawer.inner_board_m


def panel_at(spec: CabinetBody, left_m: float, height_m: float) -> Panel | None:
    """The panel a knob or button at (`left_m`, `height_m`) sits on."""
    for panel in spec.panels:
        if panel.left_m <= left_m <= panel.right_m and panel.bottom_m <= height_m <= panel.top_m:
            return panel
    return None


def panel_bounds_m(spec: CabinetBody, panel: Panel) -> tuple[float, float, float, float]:
    """(y_min, y_max, z_min, z_max) of the slab a panel is built as, in the model frame:
    inside the carcass' edges, which show round it (empty where it lies wholly on them)."""
    t = spec.wall_thickness_m
    y0 = max(-spec.width_m / 2 + panel.left_m, -spec.width_m / 2 + t)
    y1 = min(-spec.width_m / 2 + panel.right_m, spec.width_m / 2 - t)
    return y0, y1, max(panel.bottom_m, spec.inner_floor_m), min(panel.top_m, spec.inner_top_m)


def panel_face_x_m(spec: CabinetBody, left_m: float, height_m: float) -> float:
    """x of the face of the panel a knob or button at (`left_m`, `height_m`) sits on."""
    panel = panel_at(spec, left_m, height_m)
    return spec.depth_m / 2 + (0.0 if panel is None else panel.forward_m)


def front_x_m(spec: CabinetBody) -> float:
    """x of an overlay front's outer face (closed)."""
    return spec.depth_m / 2 + spec.door_gap_m + spec.door_thickness_m


def door_face_x_m(spec: CabinetBody, door: DoorSpec) -> float:
    """x of a closed door's outer face: in front of the body, or flush with its front if
    inset; a door partly inside the opening stands out by the rest of its thickness."""
    if door.mounting == "inset":
        return spec.depth_m / 2
    if door.in_opening_m > 0:
        return spec.depth_m / 2 + spec.door_board_m(door) - door.in_opening_m
    return spec.depth_m / 2 + spec.door_gap_m + spec.door_board_m(door)


def door_slab_m(spec: CabinetBody, door: DoorSpec) -> float:
    """Thickness of the door's slab in front of the opening (all of it, but for a plug)."""
    if door.in_opening_m > 0:
        return door_face_x_m(spec, door) - spec.depth_m / 2 - spec.door_gap_m
    return spec.door_board_m(door)


def door_plug_bounds_m(spec: CabinetBody, door: DoorSpec) -> tuple[float, float, float, float]:
    """(y_min, y_max, z_min, z_max) in the model frame of a door's part inside the opening:
    the opening round the door's middle, `door_gap_m` clear of its edges, within the door."""
    gap = spec.door_gap_m
    left, right, bottom, top = opening_around_m(spec, door.left_m + door.width_m / 2, door.bottom_m + door.height_m / 2)
    y0 = -spec.width_m / 2 + max(left + gap, door.left_m)
    y1 = -spec.width_m / 2 + min(right - gap, door.right_m)
    return y0, y1, max(bottom + gap, door.bottom_m), min(top - gap, door.top_m)


def opening_bounds_m(spec: CabinetBody) -> tuple[float, float, float, float]:
    """(left, right, bottom, top) of the front opening an inset front sits in: inside the
    carcass' edges, or inside the face frame; left and right from the body's left edge."""
    frame = 0.0 if spec.face_frame is None else spec.face_frame.width_m
    side = max(spec.wall_thickness_m, frame - (0.0 if spec.face_frame is None else spec.face_frame.overhang_m))
    bottom = max(spec.bottom_raise_m + spec.bottom_board_m, frame)  # a raised bottom's top, or the frame's rail
    rails = [spec.top_board_m if rail.thickness_m is None else rail.thickness_m for rail in spec.top_rails]
    top = max(spec.top_board_m if spec.top_panel else max(rails, default=0.0), frame)  # under an open top's rails
    return side, spec.width_m - side, spec.carcass_bottom_m + bottom, spec.carcass_top_m - top


def hinge_divider(spec: CabinetBody, door: DoorSpec) -> tuple[float, float] | None:
    """(left, right) faces, from the body's left edge, of the middle panel (a divider or a
    face frame's middle stile) a side-hinged door hangs on, if its hinge-side edge is over one."""
    if not door.side_hinged:
        return None
    edge = door.left_m if door.hinge == "left" else door.right_m
    t = spec.wall_thickness_m
    middles = [(d.left_m, d.left_m + t) for d in spec.dividers]
    middles += [(m[1], m[2]) for m in frame_members_m(spec) if m[0].startswith("frame_stile")]
    return next((faces for faces in middles if faces[0] - 1e-9 <= edge <= faces[1] + 1e-9), None)


def door_edge_in_m(spec: CabinetBody, door: DoorSpec) -> float:
    """How far the door's hinge-side edge is in from the outer face of what it hangs on: the
    body's side (its top or underside for a flap), or, for a door hung on a middle panel
    (a divider or a middle stile), that panel's face on the far side from the door."""
    middle = hinge_divider(spec, door)
    if middle is not None:
        far_face = middle[0] if door.hinge == "left" else middle[1]
        return abs(far_face - (door.left_m if door.hinge == "left" else door.right_m))
    return {
        "left": door.left_m,
        "right": spec.width_m - door.right_m,
        "top": spec.top_m - door.top_m,
        "bottom": door.bottom_m - spec.base_m,
    }[door.hinge]


def open_at_90_thickness_m(spec: CabinetBody, door: DoorSpec) -> float:
    """The thickness `open_at_90` is solved with: its own (outer face to inner face, open
    square) when both faces were read, else the door's."""
    tape = door.hinge_measured
    measured = None if tape is None or tape.open_at_90 is None else tape.open_at_90.thickness_m
    return spec.door_board_m(door) if measured is None else measured


def hinge_offsets_m(spec: CabinetBody, door: DoorSpec) -> tuple[float, float]:
    """(behind_face_m, in_from_edge_m) of the door's hinge line (see `modeller.specs.hinges`)."""
    thick = open_at_90_thickness_m(spec, door)
    if door.hinge_line is not None:
        return door.hinge_line.behind_face_m, door.hinge_line.in_from_edge_m
    face_forward = door_face_x_m(spec, door) - spec.depth_m / 2
    tape = door.hinge_measured
    if tape is not None:
        edge_in = door_edge_in_m(spec, door)
        if tape.free_corner is None:
            offsets = solve_open_at_90(tape.open_at_90, face_forward_m=face_forward, edge_in_m=edge_in, thickness_m=thick)
            check_hinge_offsets(offsets, "open_at_90")
        else:  # needs no thickness, so it wins when both are given (`hinge_tape_warnings` compares)
            across = door.width_m if door.side_hinged else door.height_m
            offsets = solve_free_corner(tape.free_corner, face_forward_m=face_forward, edge_in_m=edge_in, width_m=across)
            check_hinge_offsets(offsets, "free_corner")
        return offsets
    if door.hinge_type == "concealed":
        # See `ConcealedHinge`: the least deep fixed axis that keeps the door clear of the side.
        boring = door.concealed.boring_distance_m
        if door.mounting == "inset":
            return boring, boring
        if hinge_divider(spec, door) is not None:
            # Cranked hinges bring such a door forward as it opens, past its closed neighbour,
            # which no fixed axis behind it can: its line has to be measured.
            raise FieldError(
                ("hinge_type",),
                "a concealed hinge on a middle panel has no fixed axis of its own; measure it (hinge_measured)",
            )
        edge_in = door_edge_in_m(spec, door)
        over_side = edge_in if edge_in <= spec.wall_thickness_m + 1e-9 else 0.0
        # Opened fully, the inner face's hinge-side corner comes round to the side's plane ...
        full = math.radians(max(door.concealed.opening_deg, 90.0))
        corner_rule = (over_side + boring * (1 - math.cos(full))) / math.sin(full)
        # ... and on the way the inner face passes the side's front corner, which circles the
        # axis: its radius may not exceed the inner face's distance from the axis.
        gap = max(spec.door_gap_m, _MIN_HINGE_GAP_M)
        front_corner_rule = ((over_side + boring) ** 2 + gap**2) / (2 * gap)
        return thick + max(corner_rule, front_corner_rule), boring
    if door.hinge_type == "pivot":
        return thick / 2, thick / 2 if door.pivot_in_from_edge_m is None else door.pivot_in_from_edge_m
    return 0.0, 0.0


def hinge_tape_warnings(spec: CabinetBody) -> list[str]:
    """What the solver has to say about doors measured both ways: `open_at_90` relies on the
    door's thickness (outer face to inner face), `free_corner` does not. Where they put the
    hinge line more than `TAPE_AGREEMENT_M` apart, the thickness that reconciles them."""
    warnings = []
    for i, door in enumerate(spec.doors):
        tape = door.hinge_measured
        if door.hinge_line is not None or tape is None or tape.open_at_90 is None:
            continue
        given, thick = spec.door_board_m(door), open_at_90_thickness_m(spec, door)
        if abs(thick - given) > THICKNESS_AGREEMENT_M:
            warnings.append(
                f"doors.{i}.hinge_measured.open_at_90: the door open square is {thick * 1000:.0f} mm thick from its outer "
                f"face to its inner face (outer_face_out_m - inner_face_out_m) and the spec says {given * 1000:.0f} mm; "
                f"the hinge line is solved with {thick * 1000:.0f} mm. Give the door's thickness_m (and in_opening_m for "
                "a part inside the opening) so it is built as measured"
            )
        if tape.free_corner is None:
            continue
        face_forward = door_face_x_m(spec, door) - spec.depth_m / 2
        edge_in = door_edge_in_m(spec, door)
        behind, inward = solve_open_at_90(tape.open_at_90, face_forward_m=face_forward, edge_in_m=edge_in, thickness_m=thick)
        corner_behind, corner_inward = hinge_offsets_m(spec, door)
        apart = math.hypot(behind - corner_behind, inward - corner_inward)
        if apart <= TAPE_AGREEMENT_M:
            continue
        inner = open_at_90_inner_face_m(
            tape.open_at_90,
            axis_forward_m=face_forward - corner_behind,
            axis_in_m=edge_in + corner_inward,
            edge_in_m=edge_in,
        )
        warnings.append(
            f"doors.{i}.hinge_measured: open_at_90 puts the hinge line {apart * 1000:.1f} mm from where free_corner "
            f"puts it; they agree for a door {(face_forward - inner) * 1000:.0f} mm thick from its outer face to its "
            f"inner face, and {'the square reading says' if thick != given else 'the spec says'} {thick * 1000:.0f} mm. Measure the door across its hinge-side edge, the "
            "part inside the opening included (thickness_m, in_opening_m); free_corner's line is used"
        )
    return warnings


def door_hinge_point_m(spec: CabinetBody, door: DoorSpec) -> np.ndarray:
    """A point on the door's hinge line in the model frame: at its bottom end for a
    side-hinged door, at its left end for a top- or bottom-hinged one."""
    behind, inward = hinge_offsets_m(spec, door)
    y_left = -spec.width_m / 2 + door.left_m
    point = {
        "left": (y_left + inward, door.bottom_m),
        "right": (y_left + door.width_m - inward, door.bottom_m),
        "top": (y_left, door.top_m - inward),
        "bottom": (y_left, door.bottom_m + inward),
    }[door.hinge]
    return np.array([door_face_x_m(spec, door) - behind, *point])


def door_shelf_box_m(spec: CabinetBody, door: DoorSpec, shelf: DoorShelf) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) corners of a closed door's bin in the model frame."""
    inner_x = door_face_x_m(spec, door) - spec.door_board_m(door)
    y0 = -spec.width_m / 2 + door.left_m + shelf.margin_m
    y1 = -spec.width_m / 2 + door.right_m - shelf.margin_m
    z0 = door.bottom_m + shelf.height_m
    return np.array([inner_x - shelf.depth_m, y0, z0]), np.array([inner_x, y1, z0 + shelf.lip_height_m])


def shelf_box_m(spec: CabinetBody, shelf: Shelf) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) corners of a fixed shelf in the model frame."""
    left, right, depth = shelf_span_m(spec, shelf)
    back = spec.back_inner_x_m
    y0 = -spec.width_m / 2
    return (
        np.array([back, y0 + left, shelf.height_m - spec.shelf_board_m(shelf)]),
        np.array([back + depth, y0 + right, shelf.height_m]),
    )


def drawer_reach_m(spec: CabinetBody, drawer: DrawerSpec) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) corners of the space a closed drawer's box takes in the model frame."""
    y_min, y_max, z_min, z_max = drawer_box_bounds_m(spec, drawer)
    front = drawer_box_front_x_m(spec, drawer)
    return np.array([front - drawer.depth_m, y_min, z_min]), np.array([drawer_front_x_m(spec, drawer), y_max, z_max])
