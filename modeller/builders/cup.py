"""A cup as the seed's Figure 11 shows it: two cylinders, a hollow body (open top, closed
bottom) and a handle bent round into a torus segment.

One link `body`; origin at the centre of the bottom, z up, the handle on the +x side. Its
half-torus stands in the x-z plane with its centre in the middle of the wall, so the
handle's ends are buried in the wall: no gap outside, nothing poking into the cup.
Grasp points: `handle` on the handle's centreline at its outermost point (approach -x, z up),
`body` on the axis at half height (approach +x, from the side away from the handle).
"""

from __future__ import annotations

import numpy as np

from articulation.model import Box, Collision, Cylinder, GraspPoint
from homemodel.transforms import axis_angle_transform, translation_transform
from modeller.blender_scene import (
    add_object,
    colour_material,
    hollow_cylinder_mesh,
    torus_segment_mesh,
)
from modeller.blender_to_model import Assembly
from modeller.builders import box_collision, grasp_frame
from modeller.specs import CupSpec, colour_name, colour_rgb

# The wall's collision is a ring of boxes, so the cup stays hollow for a simulator; a
# cylinder or a convex hull would fill it.
_WALL_COLLISION_BOXES = 16


def build_cup(spec: CupSpec, name: str) -> Assembly:
    cup_material = colour_material(colour_name(spec.colour), colour_rgb(spec.colour))
    radius, wall = spec.outer_diameter_m / 2, spec.wall_thickness_m
    bottom, height = spec.bottom_thickness_m, spec.height_m
    body = add_object(
        "body",
        hollow_cylinder_mesh("body", radius, radius - wall, height, bottom),
        link="body",
        material=cup_material,
    )
    collisions = [
        Collision(
            name="bottom",
            geometry=Cylinder(radius_m=radius, length_m=bottom),
            link_from_collision=translation_transform((0, 0, bottom / 2)),
        )
    ]
    # Each box covers one sector of the wall, its outer face tangent to the outside.
    chord = 2 * radius * np.tan(np.pi / _WALL_COLLISION_BOXES)
    for k in range(_WALL_COLLISION_BOXES):
        angle = 2 * np.pi * k / _WALL_COLLISION_BOXES
        link_from_box = axis_angle_transform((0, 0, 1), angle) @ translation_transform(
            (radius - wall / 2, 0, (bottom + height) / 2)
        )
        box = Box(size_m=(wall, chord, height - bottom))
        collisions.append(Collision(name=f"wall_{k}", geometry=box, link_from_collision=link_from_box))

    body_grasp = grasp_frame((0, 0, height / 2), (1, 0, 0), (0, 0, 1))
    grasp_points = [GraspPoint(name="body", link="body", link_from_grasp=body_grasp, kind="body")]
    if spec.handle is not None:
        centre_x, major, minor = spec.handle_ring_m()
        centre = (centre_x, 0.0, spec.handle.height_m)
        add_object(
            "body.handle",
            torus_segment_mesh("body.handle", major, minor, 180.0),
            link="body",
            material=cup_material,
            parent=body,
            parent_from_object=translation_transform(centre),
        )
        reach = major + minor
        collisions.append(
            box_collision("handle", (reach, 2 * minor, 2 * reach), (centre_x + reach / 2, 0.0, spec.handle.height_m))
        )
        grasp_points.append(
            GraspPoint(
                name="handle",
                link="body",
                link_from_grasp=grasp_frame((centre_x + major, 0.0, spec.handle.height_m), (-1, 0, 0), (0, 0, 1)),
                kind="handle",
            )
        )
    return Assembly(
        name=name,
        category="cup",
        collisions={"body": collisions},
        grasp_points=grasp_points,
        affordances=["container"],
        properties={"colour": spec.colour} if isinstance(spec.colour, str) else {},
        density_kg_m3=spec.density_or_default_kg_m3,
        mass_kg=spec.mass_kg,
    )
