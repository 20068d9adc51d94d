"""Boxes: a closed food packet, and a pill box whose lid turns on a hinge.

A packet is one link `body`, a closed cuboid whose six faces are planar (`front` is +x), so
photos of the real packet can be put on them. A pill box is a link `body`, a box open at
the top (walls of the measured thickness, dividers between compartments), and a link
`lid` on the revolute joint `lid_hinge`: its axis runs along the body's back top edge
(-x, z = the body's height), and a positive angle lifts the lid's front edge.
"""

from __future__ import annotations

import math

from articulation.model import Collision, GraspPoint, Joint, JointLimits
from homemodel.core.transforms import translation_transform
from modeller.blender_scene import add_solidify, remove_faces
from modeller.blender_to_model import Assembly
from modeller.builders import FACE_NORMALS, grasp_frame, wall_collisions
from modeller.builders.rigid import (
    ROOT_LINK,
    add_box_part,
    assembly,
    colour_property,
    contents_property,
)
from modeller.specs import BoxSpec, PillBoxSpec


def side_pinch(height_m: float) -> GraspPoint:
    """A grasp on a box's middle from its +y side, the fingers closing front to back (x)."""
    return GraspPoint(
        name="body", link=ROOT_LINK, link_from_grasp=grasp_frame((0, 0, height_m), (0, -1, 0), (0, 0, 1)), kind="body"
    )


def build_box(spec: BoxSpec, name: str) -> Assembly:
    collisions: list[Collision] = []
    size = (spec.depth_m, spec.width_m, spec.height_m)
    add_box_part(ROOT_LINK, size, (0.0, 0.0, spec.height_m / 2), colour=spec.colour, collisions=collisions)
    return assembly(
        spec,
        name,
        category="box",
        collisions={ROOT_LINK: collisions},
        grasp_points=[side_pinch(spec.height_m / 2)],
        affordances=["container"],
        properties={**colour_property(spec.colour), **contents_property(spec.contents)},
    )


def build_pill_box(spec: PillBoxSpec, name: str) -> Assembly:
    d, w, t = spec.depth_m, spec.width_m, spec.wall_thickness_m
    body_h, lid_t = spec.body_height_m, spec.lid_thickness_m
    lid_colour = spec.lid_colour if spec.lid_colour is not None else spec.colour

    # The body: a closed box with its top face removed, given walls inward (the cupboard's way).
    body_collisions: list[Collision] = []
    body = add_box_part(
        ROOT_LINK, (d, w, body_h), (0.0, 0.0, body_h / 2), colour=spec.colour, collisions=body_collisions
    )
    remove_faces(body.data, [FACE_NORMALS["+z"]])
    add_solidify(body, t)
    body_collisions[:] = wall_collisions("body", (d, w, body_h), (0, 0, body_h / 2), ["+x", "-x", "+y", "-y", "-z"], t)
    compartment = spec.compartment_width_m
    for k in range(1, spec.compartments):
        y = -w / 2 + t + k * compartment + (k - 0.5) * t
        add_box_part(
            f"body.divider_{k}",
            (d - 2 * t, t, body_h - t),
            (0.0, y, (body_h + t) / 2),
            colour=spec.colour,
            collisions=body_collisions,
            parent=body,
        )

    body_from_hinge = translation_transform((-d / 2, 0.0, body_h))
    lid_collisions: list[Collision] = []
    add_box_part(
        "lid",
        (d, w, lid_t),
        (d / 2, 0.0, lid_t / 2),
        colour=lid_colour,
        collisions=lid_collisions,
        link="lid",
        parent=body,
        parent_from_object=body_from_hinge,
    )
    hinge = Joint(
        name="lid_hinge",
        type="revolute",
        parent=ROOT_LINK,
        child="lid",
        parent_from_joint=body_from_hinge,
        axis=(0.0, -1.0, 0.0),  # turning about -y lifts the +x (front) edge
        limits=JointLimits(lower=0.0, upper=math.radians(spec.opening_limit_deg), effort=1.0, velocity=2.0),
    )
    # On the lid's front edge, approached from in front, the fingers closing on the edge vertically.
    edge = grasp_frame((d, 0.0, lid_t / 2), (-1, 0, 0), (0, 1, 0))
    return assembly(
        spec,
        name,
        category="pill_box",
        collisions={ROOT_LINK: body_collisions, "lid": lid_collisions},
        joints=[hinge],
        grasp_points=[
            GraspPoint(name="lid_front_edge", link="lid", link_from_grasp=edge, kind="handle"),
            side_pinch(body_h / 2),
        ],
        affordances=["container", "openable"],
        properties=colour_property(spec.colour),
    )
