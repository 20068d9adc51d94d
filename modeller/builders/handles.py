"""Handles on fronts (bar, knob, recessed pocket) and appliance control knobs.

A handle is a link `<front>_handle` on a fixed joint `<front>_handle_mount`, so its pose
reaches the map; a control knob is a link `knob_<i>` on a revolute joint `knob_<i>_turn`
with one `JointState` per named position. Each has a grasp point named like its link.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from articulation.model import (
    Collision,
    Cylinder,
    GraspPoint,
    Joint,
    JointLimits,
    JointState,
)
from homemodel.core.transforms import axis_angle_transform, translation_transform
from modeller.blender_scene import add_object, box_mesh, colour_material, cylinder_mesh, subtract
from modeller.blender_to_model import Assembly
from modeller.builders import box_collision, grasp_frame
from modeller.joint_physics import spec_dynamics
from modeller.specs import colour_name, colour_rgb
from modeller.specs.handles import ControlKnob, Handle, Orientation, PushButton

if TYPE_CHECKING:
    import bpy

# Posts of a bar handle: their diameter relative to the bar's, and how far in from the
# bar's ends (in bar diameters) they sit.
_POST_DIAMETER_RATIO = 0.7
_POST_INSET_DIAMETERS = 1.0
# A knob handle: its stem's diameter relative to the knob's, and the share of the
# projection taken by the stem (the cap takes the rest).
_KNOB_STEM_RATIO = 0.45
_KNOB_STEM_SHARE = 0.45
# The lining at the bottom of a recessed pocket (the link's visible part).
_POCKET_LINING_M = 0.001
# A control knob's marker line on its face: how far it stands proud, its width and length
# relative to the knob's diameter, and how far its centre sits above the knob's centre.
_MARKER_PROUD_M = 0.0005
_MARKER_THICKNESS_M = 0.002
_MARKER_WIDTH_RATIO = 0.12
_MARKER_LENGTH_RATIO = 0.36
_MARKER_CENTRE_RATIO = 0.25


def cylinder_collision(name: str, radius_m: float, length_m: float, centre_m, axis: str = "x") -> Collision:
    """A cylinder along `axis` (URDF cylinders lie along their frame's z)."""
    turn = {"x": axis_angle_transform((0, 1, 0), math.pi / 2), "y": axis_angle_transform((1, 0, 0), -math.pi / 2)}
    link_from_collision = translation_transform(centre_m) @ turn.get(axis, np.eye(4))
    return Collision(
        name=name, geometry=Cylinder(radius_m=radius_m, length_m=length_m), link_from_collision=link_from_collision
    )


def _along(orientation: Orientation) -> np.ndarray:
    return np.array([0.0, 0.0, 1.0]) if orientation == "vertical" else np.array([0.0, 1.0, 0.0])


def add_handle(
    link: str,
    parent_link: str,
    front: bpy.types.Object,
    front_from_face: np.ndarray,
    handle: Handle,
    orientation: Orientation,
    material: bpy.types.Material,
    assembly: Assembly,
) -> None:
    """Add `handle` to the `front` object, `front_from_face` being the point on the front's
    outer face at the handle's centre (axes as the body's, +x out of the front)."""
    along = _along(orientation)
    if handle.type == "none":
        # Push to open: nothing to add, but the robot needs to know where to press.
        push = front_from_face @ grasp_frame((0, 0, 0), (-1, 0, 0), along)
        name = link.removesuffix("_handle") + "_push"
        assembly.grasp_points.append(GraspPoint(name=name, link=parent_link, link_from_grasp=push, kind="push"))
        return
    if handle.type == "channel":
        # Fingers come down the channel and hook over the front's top edge, along it.
        grip = front_from_face @ grasp_frame((0, 0, 0), (0, 0, -1), (0, 1, 0))
        name = link.removesuffix("_handle") + "_grip"
        assembly.grasp_points.append(GraspPoint(name=name, link=parent_link, link_from_grasp=grip, kind="handle"))
        return
    if handle.type == "bar":
        front_from_handle = front_from_face @ translation_transform((handle.standoff_m, 0, 0))
        _bar(link, front, front_from_handle, handle, orientation, material, assembly)
        grasp, kind = grasp_frame((0, 0, 0), (-1, 0, 0), along), "handle"
    elif handle.type == "knob":
        front_from_handle = front_from_face
        _knob(link, front, front_from_handle, handle, material, assembly)
        cap_middle = handle.knob_projection_m * (1 + _KNOB_STEM_SHARE) / 2
        grasp, kind = grasp_frame((cap_middle, 0, 0), (-1, 0, 0), (0, 0, 1)), "knob"
    else:
        front_from_handle = front_from_face
        _pocket(link, front, front_from_handle, handle, orientation, material, assembly)
        grasp, kind = grasp_frame((-handle.recess_depth_m / 2, 0, 0), (-1, 0, 0), along), "handle"
    assembly.joints.append(
        Joint(name=f"{link}_mount", type="fixed", parent=parent_link, child=link, parent_from_joint=front_from_handle)
    )
    assembly.grasp_points.append(GraspPoint(name=link, link=link, link_from_grasp=grasp, kind=kind))


def _bar(
    link: str,
    front: bpy.types.Object,
    front_from_handle: np.ndarray,
    handle: Handle,
    orientation: Orientation,
    material: bpy.types.Material,
    assembly: Assembly,
) -> None:
    """A bar (the link's object, centred on the link origin) on two posts back to the front's face."""
    axis = "z" if orientation == "vertical" else "y"
    along = _along(orientation)
    bar = add_object(
        link,
        cylinder_mesh(link, handle.diameter_m / 2, handle.length_m, axis=axis),
        link=link,
        material=material,
        parent=front,
        parent_from_object=front_from_handle,
    )
    post_offset = handle.length_m / 2 - _POST_INSET_DIAMETERS * handle.diameter_m
    post_radius = _POST_DIAMETER_RATIO * handle.diameter_m / 2
    for k, sign in enumerate((-1.0, 1.0)):
        post_centre = np.array([-handle.standoff_m / 2, 0.0, 0.0]) + sign * post_offset * along
        add_object(
            f"{link}.post_{k}",
            cylinder_mesh(f"{link}.post_{k}", post_radius, handle.standoff_m, axis="x"),
            link=link,
            material=material,
            parent=bar,
            parent_from_object=translation_transform(post_centre),
        )
    # One box around bar and posts, from the front's face to the bar's far side.
    depth = handle.standoff_m + handle.diameter_m / 2
    size = np.full(3, handle.diameter_m)
    size[0] = depth
    size["xyz".index(axis)] = handle.length_m
    assembly.collisions[link] = [box_collision(link, size, (handle.diameter_m / 2 - depth / 2, 0.0, 0.0))]


def _knob(
    link: str,
    front: bpy.types.Object,
    front_from_handle: np.ndarray,
    handle: Handle,
    material: bpy.types.Material,
    assembly: Assembly,
) -> None:
    """A stem from the front's face and a round cap on it; the link origin on the face."""
    stem_length = _KNOB_STEM_SHARE * handle.knob_projection_m
    cap_length = handle.knob_projection_m - stem_length
    stem_radius, cap_radius = _KNOB_STEM_RATIO * handle.knob_diameter_m / 2, handle.knob_diameter_m / 2
    # The link's object sits at the link frame (on the face); its mesh is the stem in front of it.
    stem_mesh = cylinder_mesh(link, stem_radius, stem_length, axis="x")
    stem_mesh.transform(blender_matrix(translation_transform((stem_length / 2, 0, 0))))
    stem = add_object(link, stem_mesh, link=link, material=material, parent=front, parent_from_object=front_from_handle)
    add_object(
        f"{link}.cap",
        cylinder_mesh(f"{link}.cap", cap_radius, cap_length, axis="x"),
        link=link,
        material=material,
        parent=stem,
        parent_from_object=translation_transform((stem_length + cap_length / 2, 0, 0)),
    )
    assembly.collisions[link] = [
        cylinder_collision(f"{link}_stem", stem_radius, stem_length, (stem_length / 2, 0, 0)),
        cylinder_collision(f"{link}_cap", cap_radius, cap_length, (stem_length + cap_length / 2, 0, 0)),
    ]


def _pocket(
    link: str,
    front: bpy.types.Object,
    front_from_handle: np.ndarray,
    handle: Handle,
    orientation: Orientation,
    material: bpy.types.Material,
    assembly: Assembly,
) -> None:
    """A pocket cut into the front (a boolean difference), lined at its bottom by the link's plate."""
    length, width, depth = handle.length_m, handle.recess_width_m, handle.recess_depth_m
    size = np.array([2 * depth, width, length] if orientation == "vertical" else [2 * depth, length, width])
    subtract(front, f"{link} pocket", f"{link}.cutter", box_mesh(f"{link}.cutter", size), front_from_handle)
    lining_size = (_POCKET_LINING_M, *size[1:])
    lining_centre = (-depth + _POCKET_LINING_M / 2, 0.0, 0.0)
    add_object(
        link,
        box_mesh(link, lining_size, lining_centre),
        link=link,
        material=material,
        parent=front,
        parent_from_object=front_from_handle,
    )
    assembly.collisions[link] = [box_collision(link, lining_size, lining_centre)]


def blender_matrix(matrix: np.ndarray):
    """A 4x4 array as Blender's `Matrix`."""
    from mathutils import Matrix

    return Matrix(np.asarray(matrix, dtype=np.float64).tolist())


def add_control_knob(
    i: int, knob: ControlKnob, body: bpy.types.Object, body_from_knob: np.ndarray, assembly: Assembly
) -> None:
    """A turning knob: link `knob_<i>` at the panel's face, a skirt along +x, a marker line up at its first state."""
    link = f"knob_{i}"
    radius, projection = knob.diameter_m / 2, knob.projection_m
    material = colour_material(colour_name(knob.colour), colour_rgb(knob.colour))
    marker_material = colour_material(colour_name(knob.marker_colour), colour_rgb(knob.marker_colour))
    # In a pocket the skirt reaches down to the pocket's floor.
    sunk = 0.0 if knob.pocket is None else knob.pocket.depth_m
    skirt_mesh = cylinder_mesh(link, radius, projection + sunk, axis="x")
    skirt_mesh.transform(blender_matrix(translation_transform(((projection - sunk) / 2, 0, 0))))
    skirt = add_object(link, skirt_mesh, link=link, material=material, parent=body, parent_from_object=body_from_knob)
    marker_size = (_MARKER_THICKNESS_M, _MARKER_WIDTH_RATIO * knob.diameter_m, _MARKER_LENGTH_RATIO * knob.diameter_m)
    add_object(
        f"{link}.marker",
        box_mesh(f"{link}.marker", marker_size),
        link=link,
        material=marker_material,
        parent=skirt,
        parent_from_object=translation_transform(
            (projection + _MARKER_PROUD_M - _MARKER_THICKNESS_M / 2, 0, _MARKER_CENTRE_RATIO * knob.diameter_m)
        ),
    )
    assembly.collisions[link] = [cylinder_collision(link, radius, projection + sunk, ((projection - sunk) / 2, 0, 0))]
    step = math.radians(knob.step_deg)
    assembly.joints.append(
        Joint(
            name=f"{link}_turn",
            type="revolute" if knob.stops else "continuous",
            parent="body",
            child=link,
            parent_from_joint=body_from_knob,
            # Positive turns about -x are clockwise for someone looking at the front (along -x).
            axis=np.array([-1.0 if knob.turns == "clockwise" else 1.0, 0.0, 0.0]),
            limits=JointLimits(lower=0.0, upper=step * (len(knob.states) - 1)) if knob.stops else None,
            states=[JointState(name=state, position=k * step) for k, state in enumerate(knob.states)],
            dynamics=spec_dynamics(knob.dynamics),
        )
    )
    grasp = grasp_frame((projection / 2, 0, 0), (-1, 0, 0), (0, 0, 1))
    assembly.grasp_points.append(GraspPoint(name=link, link=link, link_from_grasp=grasp, kind="knob"))


def add_push_button(
    i: int, button: PushButton, body: bpy.types.Object, body_from_button: np.ndarray, assembly: Assembly
) -> None:
    """A push button: link `button_<i>` at the panel's face, a disc (or a block) along +x,
    pressed in along -x; in a pocket, its body reaches back to where, pressed, it meets the
    pocket's floor."""
    link = f"button_{i}"
    radius, projection = button.diameter_m / 2, button.projection_m
    if button.pocket is None:
        length, back = projection, 0.0
        # Pressed, the button's stem goes into a hole in the panel; its cap (what stays out) collides.
        cap = projection - button.travel_m
        collide_length, collide_centre = cap, button.travel_m + cap / 2
    else:
        length = projection + button.pocket.depth_m - button.travel_m  # pressed fully, it meets the floor
        length = length if button.body_depth_m is None else min(length, button.body_depth_m)
        back = projection - length
        collide_length, collide_centre = length, back + length / 2
    if button.shape == "round":
        mesh = cylinder_mesh(link, radius, length, axis="x")
        collision = cylinder_collision(link, radius, collide_length, (collide_centre, 0, 0))
    else:
        across, up = button.width_m, button.button_height_m
        mesh = box_mesh(link, (length, across, up))
        collision = box_collision(link, (collide_length, across, up), (collide_centre, 0, 0))
    mesh.transform(blender_matrix(translation_transform((back + length / 2, 0, 0))))
    material = colour_material(colour_name(button.colour), colour_rgb(button.colour))
    add_object(link, mesh, link=link, material=material, parent=body, parent_from_object=body_from_button)
    assembly.collisions[link] = [collision]
    assembly.joints.append(
        Joint(
            name=f"{link}_press",
            type="prismatic",
            parent="body",
            child=link,
            parent_from_joint=body_from_button,
            axis=np.array([-1.0, 0.0, 0.0]),
            limits=JointLimits(lower=0.0, upper=button.travel_m),
        )
    )
    grasp = grasp_frame((projection, 0, 0), (-1, 0, 0), (0, 0, 1))
    assembly.grasp_points.append(GraspPoint(name=link, link=link, link_from_grasp=grasp, kind="button"))
