"""A cupboard as the seed builds it: a box at the real outer size with its front face
removed and walls of the measured thickness, shelves, a plinth, and doors, drawers and bar
handles at their measured places.

Links and frames (model frame: see `modeller.specs`):
- `body` (root): the model frame. Carcass, shelves and plinth.
- `door_<i>`: origin on the door's hinge line (vertical, at its hinge-side edge, on the
  door's outer front face) at the height of its bottom edge; axes as the body's. Joint
  `door_<i>_hinge`, revolute, 0..opening limit, positive opening the door outward: its axis
  is -z for a door hinged on the left (seen from in front), +z for one hinged on the right.
  Turning about the door's outer front edge keeps the whole door at x >= the body's front
  plane + `door_gap_m` at every angle, so an open door never enters the body.
- `drawer_<i>`: origin on the body's front plane (x = depth/2) at the middle of the front's
  width and the height of its bottom edge. Joint `drawer_<i>_slide`, prismatic along +x,
  0..travel.
- `<door or drawer>_handle`: origin at the middle of the bar, on its axis; fixed joint
  `<...>_handle_mount`. Grasp point `<...>_handle` there: x the approach (-x, towards
  the front), z along the bar.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from articulation.model import GraspPoint, Joint, JointLimits
from homemodel.transforms import translation_transform
from modeller.blender_scene import (
    add_object,
    add_solidify,
    box_mesh,
    colour_material,
    cylinder_mesh,
    remove_faces,
)
from modeller.blender_to_model import Assembly
from modeller.builders import FACE_NORMALS, box_collision, grasp_frame, wall_collisions
from modeller.specs import CupboardSpec, colour_name, colour_rgb
from modeller.specs.handles import BarHandle

if TYPE_CHECKING:
    import bpy

# Posts of a bar handle: their diameter relative to the bar's, and how far in from the
# bar's ends (in bar diameters) they sit.
_POST_DIAMETER_RATIO = 0.7
_POST_INSET_DIAMETERS = 1.0


def build_cupboard(spec: CupboardSpec, name: str) -> Assembly:
    body_material = colour_material(colour_name(spec.colour), colour_rgb(spec.colour))
    handle_material = colour_material(colour_name(spec.handle_colour), colour_rgb(spec.handle_colour))
    assembly = Assembly(
        name=name,
        category="cupboard",
        collisions={},
        affordances=["container", "supporting_surface"],
        density_kg_m3=spec.density_or_default_kg_m3,
        mass_kg=spec.mass_kg,
    )
    body = _add_body(spec, body_material, assembly)
    for i in range(len(spec.doors)):
        _add_door(spec, i, body, body_material, handle_material, assembly)
    for i in range(len(spec.drawers)):
        _add_drawer(spec, i, body, body_material, handle_material, assembly)
    return assembly


def _add_body(spec: CupboardSpec, body_material: bpy.types.Material, assembly: Assembly) -> bpy.types.Object:
    t = spec.wall_thickness_m
    carcass_height = spec.height_m - spec.plinth_height_m
    size = (spec.depth_m, spec.width_m, carcass_height)
    centre = (0.0, 0.0, spec.plinth_height_m + carcass_height / 2)
    mesh = box_mesh("body", size, centre)
    remove_faces(mesh, [FACE_NORMALS["+x"]])
    body = add_object("body", mesh, link="body", material=body_material)
    add_solidify(body, t)
    collisions = wall_collisions("carcass", size, centre, ["-x", "+y", "-y", "+z", "-z"], t)

    for i, shelf in enumerate(spec.shelves):
        # From the back wall to the front plane, between the side walls; its top at height_m.
        shelf_size = (spec.depth_m - t, spec.width_m - 2 * t, t)
        shelf_centre = (t / 2, 0.0, shelf.height_m - t / 2)
        add_object(
            f"body.shelf_{i}",
            box_mesh(f"body.shelf_{i}", shelf_size),
            link="body",
            material=body_material,
            parent=body,
            parent_from_object=translation_transform(shelf_centre),
        )
        collisions.append(box_collision(f"shelf_{i}", shelf_size, shelf_centre))

    if spec.plinth_height_m > 0:
        # A frame under the carcass, its front set back for the feet: a box without top and bottom.
        plinth_size = (spec.depth_m - spec.plinth_recess_m, spec.width_m, spec.plinth_height_m)
        plinth_centre = (-spec.plinth_recess_m / 2, 0.0, spec.plinth_height_m / 2)
        plinth_mesh = box_mesh("body.plinth", plinth_size)
        remove_faces(plinth_mesh, [FACE_NORMALS["+z"], FACE_NORMALS["-z"]])
        plinth = add_object(
            "body.plinth",
            plinth_mesh,
            link="body",
            material=body_material,
            parent=body,
            parent_from_object=translation_transform(plinth_centre),
        )
        add_solidify(plinth, t)
        collisions += wall_collisions("plinth", plinth_size, plinth_centre, ["+x", "-x", "+y", "-y"], t)
    assembly.collisions["body"] = collisions
    return body


def _front_left_y(spec: CupboardSpec, left_m: float) -> float:
    """y of a front's left edge as seen from in front (the installer's left is -y)."""
    return -spec.width_m / 2 + left_m


def _add_door(
    spec: CupboardSpec,
    i: int,
    body: bpy.types.Object,
    door_material: bpy.types.Material,
    handle_material: bpy.types.Material,
    assembly: Assembly,
) -> None:
    door = spec.doors[i]
    link = f"door_{i}"
    thick = spec.door_thickness_m
    left_y = _front_left_y(spec, door.left_m)
    hinge_y = left_y if door.hinge == "left" else left_y + door.width_m
    body_from_door = translation_transform((spec.depth_m / 2 + spec.door_gap_m + thick, hinge_y, door.bottom_m))
    # The free edge lies towards +y from a left hinge; opening swings it towards +x, which
    # is a turn about -z. Mirrored for a right hinge.
    towards_free = 1.0 if door.hinge == "left" else -1.0
    size = (thick, door.width_m, door.height_m)
    centre = (-thick / 2, towards_free * door.width_m / 2, door.height_m / 2)
    door_obj = add_object(
        link,
        box_mesh(link, size, centre),
        link=link,
        material=door_material,
        parent=body,
        parent_from_object=body_from_door,
    )
    assembly.collisions[link] = [box_collision(link, size, centre)]
    assembly.joints.append(
        Joint(
            name=f"{link}_hinge",
            type="revolute",
            parent="body",
            child=link,
            parent_from_joint=body_from_door,
            axis=np.array([0.0, 0.0, -towards_free]),
            limits=JointLimits(lower=0.0, upper=math.radians(door.opening_limit_deg)),
        )
    )
    across, up = door.handle_offset_m()
    door_from_handle = translation_transform((door.handle.standoff_m, left_y + across - hinge_y, up))
    _add_handle(f"{link}_handle", link, door_obj, door_from_handle, door.handle, handle_material, assembly)


def _add_drawer(
    spec: CupboardSpec,
    i: int,
    body: bpy.types.Object,
    drawer_material: bpy.types.Material,
    handle_material: bpy.types.Material,
    assembly: Assembly,
) -> None:
    drawer = spec.drawers[i]
    link = f"drawer_{i}"
    thick, gap = spec.door_thickness_m, spec.door_gap_m
    left_y = _front_left_y(spec, drawer.left_m)
    middle_y = left_y + drawer.width_m / 2
    body_from_drawer = translation_transform((spec.depth_m / 2, middle_y, drawer.bottom_m))
    front_size = (thick, drawer.width_m, drawer.height_m)
    front_centre = (gap + thick / 2, 0.0, drawer.height_m / 2)
    drawer_obj = add_object(
        link,
        box_mesh(link, front_size, front_centre),
        link=link,
        material=drawer_material,
        parent=body,
        parent_from_object=body_from_drawer,
    )
    collisions = [box_collision(f"{link}_front", front_size, front_centre)]

    # The box behind the front, inside the body: a box without its top, walls inward.
    y_min, y_max, z_min, z_max = spec.drawer_box_bounds_m(drawer)
    box_size = (drawer.depth_m, y_max - y_min, z_max - z_min)
    box_centre = (gap - drawer.depth_m / 2, (y_min + y_max) / 2 - middle_y, (z_min + z_max) / 2 - drawer.bottom_m)
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
    add_solidify(box, spec.wall_thickness_m)
    walls = ["+x", "-x", "+y", "-y", "-z"]
    collisions += wall_collisions(f"{link}_box", box_size, box_centre, walls, spec.wall_thickness_m)
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
        )
    )
    across, up = drawer.handle_offset_m()
    drawer_from_handle = translation_transform((gap + thick + drawer.handle.standoff_m, left_y + across - middle_y, up))
    _add_handle(f"{link}_handle", link, drawer_obj, drawer_from_handle, drawer.handle, handle_material, assembly)


def _add_handle(
    link: str,
    parent_link: str,
    parent: bpy.types.Object,
    parent_from_handle: np.ndarray,
    handle: BarHandle,
    handle_material: bpy.types.Material,
    assembly: Assembly,
) -> None:
    """A bar (the link's object, along y or z) on two posts reaching back to the front's face."""
    along = "z" if handle.orientation == "vertical" else "y"
    along_vector = np.array([0.0, 0.0, 1.0]) if along == "z" else np.array([0.0, 1.0, 0.0])
    bar = add_object(
        link,
        cylinder_mesh(link, handle.diameter_m / 2, handle.length_m, axis=along),
        link=link,
        material=handle_material,
        parent=parent,
        parent_from_object=parent_from_handle,
    )
    post_offset = handle.length_m / 2 - _POST_INSET_DIAMETERS * handle.diameter_m
    post_radius = _POST_DIAMETER_RATIO * handle.diameter_m / 2
    for k, sign in enumerate((-1.0, 1.0)):
        post_centre = np.array([-handle.standoff_m / 2, 0.0, 0.0]) + sign * post_offset * along_vector
        add_object(
            f"{link}.post_{k}",
            cylinder_mesh(f"{link}.post_{k}", post_radius, handle.standoff_m, axis="x"),
            link=link,
            material=handle_material,
            parent=bar,
            parent_from_object=translation_transform(post_centre),
        )
    # One box around bar and posts, from the front's face to the bar's far side.
    depth = handle.standoff_m + handle.diameter_m / 2
    size = np.full(3, handle.diameter_m)
    size[0] = depth
    size["xyz".index(along)] = handle.length_m
    assembly.collisions[link] = [box_collision(link, size, (handle.diameter_m / 2 - depth / 2, 0.0, 0.0))]
    assembly.joints.append(
        Joint(name=f"{link}_mount", type="fixed", parent=parent_link, child=link, parent_from_joint=parent_from_handle)
    )
    # The hand comes at the bar from in front (-x) and closes round it.
    link_from_grasp = grasp_frame((0, 0, 0), (-1, 0, 0), along_vector)
    assembly.grasp_points.append(GraspPoint(name=link, link=link, link_from_grasp=link_from_grasp, kind="handle"))

