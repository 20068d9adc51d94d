"""What every cabinet-like kind is built from (cupboards, wall cabinets, wardrobes and the
appliances): a box at the real outer size with its front face (and its top, or its back
for a back panel set in) removed and walls of the measured thickness, a plinth or legs, a face
frame, shelves, dividers, fixed front panels, and doors, drawers, handles, control knobs
and push buttons at their measured places.

Links and frames (model frame: see `modeller.specs`):
- `body` (root): the model frame. Carcass, plinth, shelves, dividers, panels, and a kind's
  fixed parts (a hob, rails, racks, a drum).
- `door_<i>`: origin on the door's hinge line (`modeller.specs.cabinet_geometry.
  door_hinge_point_m`: by default its hinge-side edge on its outer face, else where the
  spec's hinge type, hinge line or tape measurements put it): for a side-hinged door at the
  height of its bottom edge, for a top- or bottom-hinged one at its left end; axes as the
  body's. Joint `door_<i>_hinge`, revolute, 0..opening limit, positive opening the door
  outward: axis -z (hinged left), +z (right), +y (bottom, opening down), -y (top, opening
  up). About the outer front edge an overlay door never enters the body; an axis further
  in is the spec's to keep clear (the gate's collision sweep checks it).
- `drawer_<i>`: origin on the body's front plane (x = depth/2) at the middle of the front's
  width and the height of its bottom edge (an inset front lies behind it). Joint
  `drawer_<i>_slide`, prismatic along +x, 0..travel.
- `<door or drawer>_handle`: fixed joint `<...>_handle_mount` (see `modeller.builders.handles`).
- `knob_<i>`: origin on the panel's outer face at the knob's centre; joint `knob_<i>_turn`.
- `button_<i>`: origin on the panel's outer face at the button's centre; joint `button_<i>_press`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from articulation.model import Joint, JointLimits
from homemodel.core.transforms import translation_transform
from modeller.blender_scene import (
    add_object,
    add_solidify,
    box_mesh,
    colour_material,
    cylinder_mesh,
    remove_faces,
    subtract,
)
from modeller.blender_to_model import Assembly
from modeller.builders import FACE_NORMALS, box_collision, wall_collisions
from modeller.builders.handles import (
    add_control_knob,
    add_handle,
    add_push_button,
    blender_matrix,
    cylinder_collision,
)
from modeller.builders.table import four_legs
from modeller.joint_physics import spec_dynamics
from modeller.part_masses import front_masses_kg
from modeller.specs import colour_name, colour_rgb
from modeller.specs.cabinet_geometry import (
    door_face_x_m,
    door_hinge_point_m,
    door_plug_bounds_m,
    door_shelf_box_m,
    door_slab_m,
    drawer_board_front_x_m,
    drawer_board_top_m,
    drawer_box_bounds_m,
    drawer_box_front_x_m,
    drawer_front_x_m,
    frame_members_m,
    panel_at,
    panel_bounds_m,
    panel_face_x_m,
    shelf_span_m,
)
from modeller.specs.cabinet_parts import Panel
from modeller.specs.cabinets import CabinetSpec
from modeller.specs.handles import PushButton

if TYPE_CHECKING:
    import bpy

# Door windows stand this little proud of the door's face (so the glass shows), and go this
# deep into it.
_GLASS_PROUD_M = 0.0005
_GLASS_DEPTH_M = 0.004
# Sheet thickness of door shelves (bins).
_BIN_WALL_M = 0.003

_DOOR_AXES = {"left": (0.0, 0.0, -1.0), "right": (0.0, 0.0, 1.0), "bottom": (0.0, 1.0, 0.0), "top": (0.0, -1.0, 0.0)}


def material(colour) -> bpy.types.Material:
    return colour_material(colour_name(colour), colour_rgb(colour))


@dataclass
class Cabinet:
    """A cabinet being built: its spec, the body object, and the assembly to complete."""

    spec: CabinetSpec
    body: bpy.types.Object
    assembly: Assembly

    def add_to_body(self, name: str, mesh: bpy.types.Mesh, centre_m, colour=None) -> bpy.types.Object:
        """A fixed part of the body, its mesh centred at `centre_m` in the model frame."""
        return add_object(
            f"body.{name}",
            mesh,
            link="body",
            material=material(self.spec.colour if colour is None else colour),
            parent=self.body,
            parent_from_object=translation_transform(centre_m),
        )

    @property
    def body_collisions(self) -> list:
        return self.assembly.collisions["body"]


def build_cabinet(spec: CabinetSpec, name: str, *, category: str, affordances: list[str]) -> Cabinet:
    """The body with its fronts and knobs; the kind's builder adds its own parts after."""
    assembly = Assembly(
        name=name,
        category=category,
        collisions={},
        affordances=affordances,
        properties={"colour": spec.colour} if isinstance(spec.colour, str) else {},
        density_kg_m3=spec.density_or_default_kg_m3,
        mass_kg=spec.mass_kg,
        link_masses_kg=front_masses_kg(spec),
    )
    cabinet = Cabinet(spec=spec, body=_add_carcass(spec, assembly), assembly=assembly)
    for i, shelf in enumerate(spec.shelves):
        left, right, depth = shelf_span_m(spec, shelf)
        t = spec.shelf_board_m(shelf)
        size = (depth, right - left, t)
        centre = (spec.back_inner_x_m + depth / 2, -spec.width_m / 2 + (left + right) / 2, shelf.height_m - t / 2)
        cabinet.add_to_body(f"shelf_{i}", box_mesh(f"body.shelf_{i}", size), centre)
        cabinet.body_collisions.append(box_collision(f"shelf_{i}", size, centre))
    for i, divider in enumerate(spec.dividers):
        t = spec.wall_thickness_m
        size = (spec.inner_depth_m, t, spec.inner_top_m - spec.inner_floor_m)
        centre = (
            (spec.back_inner_x_m + spec.depth_m / 2) / 2,
            -spec.width_m / 2 + divider.left_m + t / 2,
            (spec.inner_floor_m + spec.inner_top_m) / 2,
        )
        cabinet.add_to_body(f"divider_{i}", box_mesh(f"body.divider_{i}", size), centre)
        cabinet.body_collisions.append(box_collision(f"divider_{i}", size, centre))
    for i, panel in enumerate(spec.panels):
        _add_panel(cabinet, i, panel)
    handle_material = material(spec.handle_colour)
    for i in range(len(spec.doors)):
        _add_door(cabinet, i, handle_material)
    for i in range(len(spec.drawers)):
        _add_drawer(cabinet, i, handle_material)
    for i, knob in enumerate(spec.knobs):
        face_x = panel_face_x_m(spec, knob.left_m, knob.height_m)
        body_from_knob = translation_transform((face_x, -spec.width_m / 2 + knob.left_m, knob.height_m))
        add_control_knob(i, knob, cabinet.body, body_from_knob, assembly)
    for i, button in enumerate(spec.buttons):
        face_x = panel_face_x_m(spec, button.left_m, button.height_m)
        body_from_button = translation_transform((face_x, -spec.width_m / 2 + button.left_m, button.height_m))
        add_push_button(i, button, cabinet.body, body_from_button, assembly)
    return cabinet


def _add_carcass(spec: CabinetSpec, assembly: Assembly) -> bpy.types.Object:
    t = spec.wall_thickness_m
    bottom, top = spec.carcass_bottom_m, spec.carcass_top_m
    if spec.top_panel and spec.top_overhang is not None:
        top -= spec.top_board_m  # the sides and back end under the slab, which lies on them
    size = (spec.depth_m, spec.width_m, top - bottom)
    centre = (0.0, 0.0, (bottom + top) / 2)
    mesh = box_mesh("body", size, centre)
    # Boards of their own thickness are boxes of their own, not the shell's faces.
    own_top = not spec.top_panel or spec.top_thickness_m is not None or spec.top_overhang is not None
    own_bottom = spec.bottom_thickness_m is not None or spec.bottom_raise_m > 0
    open_faces = ["+x"] + (["+z"] if own_top else []) + (["-z"] if own_bottom else [])
    open_faces += [] if spec.back_panel is None else ["-x"]
    remove_faces(mesh, [FACE_NORMALS[face] for face in open_faces])
    body = add_object("body", mesh, link="body", material=material(spec.colour))
    add_solidify(body, t)
    walls = [face for face in ("-x", "+y", "-y", "+z", "-z") if face not in open_faces]
    collisions = wall_collisions("carcass", size, centre, walls, t)
    for name, part_size, part_centre in _carcass_extras(spec):
        add_object(
            f"body.{name}",
            box_mesh(f"body.{name}", part_size),
            link="body",
            material=material(spec.colour),
            parent=body,
            parent_from_object=translation_transform(part_centre),
        )
        collisions.append(box_collision(name, part_size, part_centre))
    if spec.plinth_height_m > 0 and spec.legs is not None:
        # Legs, not a plinth: a camera sees the floor and the wall between them.
        four_legs(spec.legs, (spec.depth_m, spec.width_m), spec.plinth_height_m, round_top=False, colour=spec.colour,
                  parent=body, collisions=collisions)
    elif spec.plinth_height_m > 0:
        # A frame under the carcass, its front set back for the feet: a box without top and bottom.
        plinth_size = (spec.depth_m - spec.plinth_recess_m, spec.width_m, spec.plinth_height_m)
        plinth_centre = (-spec.plinth_recess_m / 2, 0.0, spec.base_m + spec.plinth_height_m / 2)
        plinth_mesh = box_mesh("body.plinth", plinth_size)
        remove_faces(plinth_mesh, [FACE_NORMALS["+z"], FACE_NORMALS["-z"]])
        plinth = add_object(
            "body.plinth",
            plinth_mesh,
            link="body",
            material=material(spec.colour),
            parent=body,
            parent_from_object=translation_transform(plinth_centre),
        )
        add_solidify(plinth, t)
        collisions += wall_collisions("plinth", plinth_size, plinth_centre, ["+x", "-x", "+y", "-y"], t)
    assembly.collisions["body"] = collisions
    return body


def _carcass_extras(spec: CabinetSpec) -> list[tuple[str, tuple[float, float, float], tuple[float, float, float]]]:
    """(name, size, centre) of the carcass' boxes beyond its shell: a top and a bottom of their
    own thickness (between the sides; a top standing out past them lies over them), a back
    panel set in from the back edge, and a face frame's stiles and rails round the front
    opening."""
    parts = []
    bottom, top = spec.carcass_bottom_m, spec.carcass_top_m
    half_w, t = spec.width_m / 2, spec.wall_thickness_m
    between_sides = spec.width_m - 2 * t
    over = spec.top_overhang
    if spec.top_panel and over is not None:
        # A slab over the sides' and back's top edges, standing out past them.
        size = (spec.depth_m + over.front_m + over.back_m, spec.width_m + 2 * over.sides_m, spec.top_board_m)
        parts.append(("carcass_top", size, ((over.front_m - over.back_m) / 2, 0.0, top - spec.top_board_m / 2)))
    elif spec.top_panel and spec.top_thickness_m is not None:
        size = (spec.depth_m, between_sides, spec.top_board_m)
        parts.append(("carcass_top", size, (0.0, 0.0, top - spec.top_board_m / 2)))
    if spec.bottom_thickness_m is not None or spec.bottom_raise_m > 0:
        # A raised bottom leaves a void under it, open at the front.
        size = (spec.depth_m, between_sides, spec.bottom_board_m)
        parts.append(("carcass_bottom", size, (0.0, 0.0, bottom + spec.bottom_raise_m + spec.bottom_board_m / 2)))
    for k, rail in enumerate(spec.top_rails):
        thickness = spec.top_board_m if rail.thickness_m is None else rail.thickness_m
        x = spec.depth_m / 2 - rail.from_front_m - rail.depth_m / 2
        parts.append((f"top_rail_{k}", (rail.depth_m, between_sides, thickness), (x, 0.0, top - thickness / 2)))
    if spec.back_panel is not None:
        back = spec.back_panel
        z0, z1 = spec.inner_floor_m, spec.inner_top_m
        size = (back.thickness_m, between_sides, z1 - z0)
        parts.append(("back_panel", size, (spec.back_inner_x_m - back.thickness_m / 2, 0.0, (z0 + z1) / 2)))
    frame = spec.face_frame
    if frame is not None:
        w, x, out = frame.width_m, spec.depth_m / 2 - frame.thickness_m / 2, frame.overhang_m
        stile = (frame.thickness_m, w, top - bottom)
        rail = (frame.thickness_m, spec.width_m + 2 * out - 2 * w, w)
        parts += [
            ("frame_left", stile, (x, -half_w - out + w / 2, (bottom + top) / 2)),
            ("frame_right", stile, (x, half_w + out - w / 2, (bottom + top) / 2)),
            ("frame_bottom", rail, (x, 0.0, bottom + w / 2)),
            ("frame_top", rail, (x, 0.0, top - w / 2)),
        ]
        for name, left, right, low, high in frame_members_m(spec)[4:]:
            size = (frame.thickness_m, right - left, high - low)
            parts.append((name, size, (x, -half_w + (left + right) / 2, (low + high) / 2)))
    return parts


def _pockets(spec: CabinetSpec, panel: Panel) -> list[tuple[float, float, float, float, float, bool]]:
    """(y_min, y_max, z_min, z_max, depth, round) of the pockets cut into `panel` for the knobs
    and buttons on it, in the model frame."""
    pockets = []
    for part in [*spec.knobs, *spec.buttons]:
        if part.pocket is None or panel_at(spec, part.left_m, part.height_m) is not panel:
            continue
        across, up = part.half_size_m
        y = -spec.width_m / 2 + part.left_m
        is_round = not isinstance(part, PushButton) or part.shape == "round"
        pockets.append((y - across, y + across, part.height_m - up, part.height_m + up, part.pocket.depth_m, is_round))
    return pockets


def _slab_round_pockets(
    name: str, x_face: float, thickness: float, bounds: tuple[float, float, float, float], pockets: list
) -> list:
    """A panel's collision as boxes: the slab cut on a grid at the pockets' edges, full
    thickness outside the pockets, only the floor behind each pocket inside it."""
    y0, y1, z0, z1 = bounds
    ys = sorted({y0, y1, *(min(max(v, y0), y1) for p in pockets for v in p[:2])})
    zs = sorted({z0, z1, *(min(max(v, z0), z1) for p in pockets for v in p[2:4])})
    boxes = []
    for c, d in zip(zs, zs[1:]):
        if d - c < 1e-6:
            continue
        # Along the row, neighbouring cells of one depth become one box.
        runs: list[list[float]] = []  # [start, end, depth]
        for a, b in zip(ys, ys[1:]):
            if b - a < 1e-6:
                continue
            inside = [p for p in pockets if p[0] <= a + 1e-9 and b <= p[1] + 1e-9 and p[2] <= c + 1e-9 and d <= p[3] + 1e-9]
            depth = max((p[4] for p in inside), default=0.0)
            if runs and runs[-1][2] == depth:
                runs[-1][1] = b
            else:
                runs.append([a, b, depth])
        for a, b, depth in runs:
            size = (thickness - depth, b - a, d - c)
            centre = (x_face - depth - size[0] / 2, (a + b) / 2, (c + d) / 2)
            boxes.append(box_collision(f"{name}_{len(boxes)}", size, centre))
    return boxes


def _add_panel(cabinet: Cabinet, i: int, panel: Panel) -> None:
    """A slab in the front plane, inside the carcass' edges (they show round it), with its hole
    and the pockets of the knobs and buttons on it cut."""
    spec = cabinet.spec
    y0, y1, z0, z1 = panel_bounds_m(spec, panel)
    if y1 - y0 <= 0 or z1 - z0 <= 0:
        return  # wholly in front of the carcass' edges, which are the panel
    t = spec.panel_board_m(panel)
    size = (t, y1 - y0, z1 - z0)
    centre = (spec.depth_m / 2 + panel.forward_m - t / 2, (y0 + y1) / 2, (z0 + z1) / 2)
    obj = cabinet.add_to_body(f"panel_{i}", box_mesh(f"body.panel_{i}", size), centre, panel.colour)
    pockets = _pockets(spec, panel)
    if pockets:
        face = spec.depth_m / 2 + panel.forward_m
        for k, (a, b, c, d, depth, is_round) in enumerate(pockets):
            # Twice the depth, centred on the face: it opens the face and stops at the floor.
            cutter_name = f"body.panel_{i}.pocket_{k}"
            if is_round:
                cutter = cylinder_mesh(cutter_name, (b - a) / 2, 2 * depth, axis="x", segments=48)
            else:
                cutter = box_mesh(cutter_name, (2 * depth, b - a, d - c))
            at = translation_transform((face - centre[0], (a + b) / 2 - centre[1], (c + d) / 2 - centre[2]))
            subtract(obj, cutter_name, cutter_name, cutter, at)
        cabinet.body_collisions.extend(_slab_round_pockets(f"panel_{i}", face, t, (y0, y1, z0, z1), pockets))
        return
    hole = panel.hole
    if hole is None:
        cabinet.body_collisions.append(box_collision(f"panel_{i}", size, centre))
        return
    r = hole.diameter_m / 2
    hole_y, hole_z = -spec.width_m / 2 + hole.centre_left_m, hole.centre_height_m
    cutter = cylinder_mesh(f"body.panel_{i}.cutter", r, 4 * t, axis="x")
    subtract(obj, "hole", f"body.panel_{i}.cutter", cutter, translation_transform((0.0, hole_y - centre[1], hole_z - centre[2])))
    # Collision: the slab round the hole's bounding square, as four boxes.
    x = centre[0]
    pieces = [
        ("left", (y0, hole_y - r, z0, z1)),
        ("right", (hole_y + r, y1, z0, z1)),
        ("below", (hole_y - r, hole_y + r, z0, hole_z - r)),
        ("above", (hole_y - r, hole_y + r, hole_z + r, z1)),
    ]
    for where, (a0, a1, b0, b1) in pieces:
        if a1 - a0 > 1e-6 and b1 - b0 > 1e-6:
            cabinet.body_collisions.append(
                box_collision(f"panel_{i}_{where}", (t, a1 - a0, b1 - b0), (x, (a0 + a1) / 2, (b0 + b1) / 2))
            )


def _add_door(cabinet: Cabinet, i: int, handle_material: bpy.types.Material) -> None:
    spec, assembly = cabinet.spec, cabinet.assembly
    door = spec.doors[i]
    link = f"door_{i}"
    thick = door_slab_m(spec, door)
    hinge = door_hinge_point_m(spec, door)
    body_from_door = translation_transform(hinge)
    face_x = door_face_x_m(spec, door)
    # The door's middle in its own frame.
    y0 = -spec.width_m / 2 + door.left_m
    middle = np.array([face_x - thick / 2, y0 + door.width_m / 2, door.bottom_m + door.height_m / 2]) - hinge
    door_material = material(spec.colour)
    if door.shape == "round":
        mesh = cylinder_mesh(link, door.width_m / 2, thick, axis="x", segments=64)
        collisions = [cylinder_collision(link, door.width_m / 2, thick, middle)]
    else:
        mesh = box_mesh(link, (thick, door.width_m, door.height_m))
        collisions = [box_collision(link, (thick, door.width_m, door.height_m), middle)]
    mesh.transform(blender_matrix(translation_transform(middle)))
    door_obj = add_object(
        link, mesh, link=link, material=door_material, parent=cabinet.body, parent_from_object=body_from_door
    )
    if door.in_opening_m > 0:
        # The door's inner part, in the opening: from its slab back past the front plane.
        y_min, y_max, z_min, z_max = door_plug_bounds_m(spec, door)
        x0, x1 = spec.depth_m / 2 - door.in_opening_m, face_x - thick
        size = (x1 - x0, y_max - y_min, z_max - z_min)
        centre = np.array([(x0 + x1) / 2, (y_min + y_max) / 2, (z_min + z_max) / 2]) - hinge
        add_object(
            f"{link}.inner",
            box_mesh(f"{link}.inner", size),
            link=link,
            material=door_material,
            parent=door_obj,
            parent_from_object=translation_transform(centre),
        )
        collisions.append(box_collision(f"{link}_inner", size, centre))
    if door.window is not None:
        glass_material = material(door.window.colour)
        glass_x = face_x - hinge[0] - _GLASS_DEPTH_M / 2 + _GLASS_PROUD_M
        centre = (glass_x, middle[1], middle[2])
        if door.shape == "round":
            glass = cylinder_mesh(
                f"{link}.window", door.width_m / 2 - door.window.margin_m, _GLASS_DEPTH_M, axis="x", segments=64
            )
        else:
            size = (_GLASS_DEPTH_M, door.width_m - 2 * door.window.margin_m, door.height_m - 2 * door.window.margin_m)
            glass = box_mesh(f"{link}.window", size)
        add_object(
            f"{link}.window",
            glass,
            link=link,
            material=glass_material,
            parent=door_obj,
            parent_from_object=translation_transform(centre),
        )
    for k, shelf in enumerate(door.shelves):
        low, high = door_shelf_box_m(spec, door, shelf)
        size = high - low
        centre = (low + high) / 2 - hinge
        bin_mesh = box_mesh(f"{link}.shelf_{k}", size)
        remove_faces(bin_mesh, [FACE_NORMALS["+z"]])
        bin_obj = add_object(
            f"{link}.shelf_{k}",
            bin_mesh,
            link=link,
            material=door_material,
            parent=door_obj,
            parent_from_object=translation_transform(centre),
        )
        add_solidify(bin_obj, _BIN_WALL_M)
        collisions += wall_collisions(f"{link}_shelf_{k}", size, centre, ["+x", "-x", "+y", "-y", "-z"], _BIN_WALL_M)
    assembly.collisions[link] = collisions
    assembly.joints.append(
        Joint(
            name=f"{link}_hinge",
            type="revolute",
            parent="body",
            child=link,
            parent_from_joint=body_from_door,
            axis=np.array(_DOOR_AXES[door.hinge]),
            limits=JointLimits(lower=0.0, upper=math.radians(door.opening_limit_deg)),
            dynamics=spec_dynamics(door.dynamics),
        )
    )
    across, up = door.handle_offset_m()
    door_from_face = translation_transform(np.array([face_x, y0 + across, door.bottom_m + up]) - hinge)
    add_handle(
        f"{link}_handle",
        link,
        door_obj,
        door_from_face,
        door.handle,
        door.handle_orientation(),
        handle_material,
        assembly,
    )


def _add_drawer(cabinet: Cabinet, i: int, handle_material: bpy.types.Material) -> None:
    spec, assembly = cabinet.spec, cabinet.assembly
    drawer = spec.drawers[i]
    link = f"drawer_{i}"
    thick = spec.door_thickness_m
    # The front's inner face, from the body's front plane (the drawer's origin).
    inner = drawer_front_x_m(spec, drawer) - spec.depth_m / 2
    left_y = -spec.width_m / 2 + drawer.left_m
    middle_y = left_y + drawer.width_m / 2
    body_from_drawer = translation_transform((spec.depth_m / 2, middle_y, drawer.bottom_m))
    front_size = (thick, drawer.width_m, drawer.height_m)
    front_centre = (inner + thick / 2, 0.0, drawer.height_m / 2)
    drawer_material = material(spec.colour)
    front_mesh = box_mesh(link, front_size, front_centre)
    drawer_obj = add_object(
        link, front_mesh, link=link, material=drawer_material, parent=cabinet.body, parent_from_object=body_from_drawer
    )
    collisions = [box_collision(f"{link}_front", front_size, front_centre)]
    # The box behind the front (and its inner board), inside the body: a box without its top, walls inward.
    y_min, y_max, z_min, z_max = drawer_box_bounds_m(spec, drawer)
    if drawer.inner_board_m > 0:
        # The second board, across the box, from the box's floor to the front's top inside the opening.
        top = drawer_board_top_m(spec, drawer)
        board_size = (drawer.inner_board_m, y_max - y_min, top - z_min)
        board_front = drawer_board_front_x_m(spec, drawer) - spec.depth_m / 2
        board_centre = (
            board_front - drawer.inner_board_m / 2,
            (y_min + y_max) / 2 - middle_y,
            (z_min + top) / 2 - drawer.bottom_m,
        )
        add_object(
            f"{link}.inner_board",
            box_mesh(f"{link}.inner_board", board_size),
            link=link,
            material=drawer_material,
            parent=drawer_obj,
            parent_from_object=translation_transform(board_centre),
        )
        collisions.append(box_collision(f"{link}_inner_board", board_size, board_centre))
    face = inner + thick
    inner = drawer_box_front_x_m(spec, drawer) - spec.depth_m / 2
    box_size = (drawer.depth_m, y_max - y_min, z_max - z_min)
    box_centre = (inner - drawer.depth_m / 2, (y_min + y_max) / 2 - middle_y, (z_min + z_max) / 2 - drawer.bottom_m)
    open_box = box_mesh(f"{link}.box", box_size)
    remove_faces(open_box, [FACE_NORMALS["+z"]])
    box = add_object(
        f"{link}.box",
        open_box,
        link=link,
        material=drawer_material,
        parent=drawer_obj,
        parent_from_object=translation_transform(box_centre),
    )
    box_wall = spec.wall_thickness_m if drawer.box_wall_m is None else drawer.box_wall_m
    add_solidify(box, box_wall)
    walls = ["+x", "-x", "+y", "-y", "-z"]
    collisions += wall_collisions(f"{link}_box", box_size, box_centre, walls, box_wall)
    assembly.collisions[link] = collisions
    assembly.joints.append(
        Joint(
            name=f"{link}_slide",
            type="prismatic",
            parent="body",
            child=link,
            parent_from_joint=body_from_drawer,
            axis=np.array([1.0, 0.0, 0.0]),
            limits=JointLimits(lower=0.0, upper=drawer.travel_m),
            dynamics=spec_dynamics(drawer.dynamics),
        )
    )
    across, up = drawer.handle_offset_m()
    drawer_from_face = translation_transform((face, left_y + across - middle_y, up))
    add_handle(
        f"{link}_handle",
        link,
        drawer_obj,
        drawer_from_face,
        drawer.handle,
        drawer.handle_orientation(),
        handle_material,
        assembly,
    )
