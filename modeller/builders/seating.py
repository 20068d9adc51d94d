"""Chairs and sofas: one link `body` each, built from boxes.

A chair's origin is under the centre of its seat (the backrest leans out behind it); a
sofa's under the centre of its whole footprint. +x points out of the front, where one sits.
"""

from __future__ import annotations

import math

from articulation.model import Box, Collision, GraspPoint
from homemodel.core.transforms import axis_angle_transform, translation_transform
from modeller.blender_scene import add_object, box_mesh
from modeller.blender_to_model import Assembly
from modeller.builders import grasp_frame
from modeller.builders.rigid import (
    ROOT_LINK,
    add_box_part,
    assembly,
    colour_property,
    material,
    surface_heights_property,
)
from modeller.builders.table import four_legs
from modeller.specs import ChairSpec, SofaSpec
from modeller.specs.furniture import Legs


def build_chair(spec: ChairSpec, name: str) -> Assembly:
    collisions: list[Collision] = []
    seat_size = (spec.seat_depth_m, spec.seat_width_m, spec.seat_thickness_m)
    seat_centre = (0.0, 0.0, spec.seat_height_m - spec.seat_thickness_m / 2)
    body = add_box_part(
        ROOT_LINK, seat_size, seat_centre, colour=spec.colour, collisions=collisions, collision_name="seat"
    )
    leg_length = spec.seat_height_m - spec.seat_thickness_m
    four_legs(
        spec.legs,
        (spec.seat_depth_m, spec.seat_width_m),
        leg_length,
        round_top=False,
        colour=spec.colour,
        parent=body,
        collisions=collisions,
    )

    # The backrest turns back about the seat's rear top edge; its frame's origin is on that edge.
    t, length = spec.backrest_thickness_m, spec.backrest_length_m
    body_from_hinge = translation_transform((-spec.seat_depth_m / 2, 0.0, spec.seat_height_m)) @ axis_angle_transform(
        (0, 1, 0), -math.radians(spec.backrest_tilt_deg)
    )
    backrest_size = (t, spec.seat_width_m, length)
    body_from_backrest = body_from_hinge @ translation_transform((t / 2, 0.0, length / 2))
    add_object(
        "body.backrest",
        box_mesh("body.backrest", backrest_size),
        link=ROOT_LINK,
        material=material(spec.colour),
        parent=body,
        parent_from_object=body_from_backrest,
    )
    collisions.append(
        Collision(name="backrest", geometry=Box(size_m=backrest_size), link_from_collision=body_from_backrest)
    )
    top_rail = body_from_hinge @ translation_transform((t / 2, 0.0, length))
    grasp = grasp_frame(top_rail[:3, 3], (0, 0, -1), (0, 1, 0))  # from above, round the top rail
    return assembly(
        spec,
        name,
        category="chair",
        collisions={ROOT_LINK: collisions},
        grasp_points=[GraspPoint(name="backrest_top", link=ROOT_LINK, link_from_grasp=grasp, kind="handle")],
        affordances=["sittable"],
        properties={**colour_property(spec.colour), "seat_height_m": f"{spec.seat_height_m:g}"},
    )


def build_sofa(spec: SofaSpec, name: str) -> Assembly:
    collisions: list[Collision] = []
    w, d = spec.width_m, spec.depth_m
    legs_top, base_top, arm_w = spec.leg_height_m, spec.base_top_m, spec.arm_width_m
    body = add_box_part(
        ROOT_LINK, (d, w, base_top - legs_top), (0.0, 0.0, (legs_top + base_top) / 2), colour=spec.colour,
        collisions=collisions, collision_name="base",
    )  # fmt: skip
    if legs_top > 0:
        legs = Legs(size_m=spec.leg_size_m, inset_m=0.0)
        four_legs(legs, (d, w), legs_top, round_top=False, colour=spec.leg_colour, parent=body, collisions=collisions)

    inner_w = w - 2 * arm_w
    back_front = -d / 2 + spec.back_thickness_m
    parts = [
        ("body.back", (spec.back_thickness_m, inner_w, spec.height_m - base_top), ((-d / 2 + back_front) / 2, 0.0))
    ]
    cushion_w, seat_d = inner_w / spec.cushions, d / 2 - back_front
    for k in range(spec.cushions):
        y = -inner_w / 2 + (k + 0.5) * cushion_w
        parts.append(
            (f"body.cushion_{k}", (seat_d, cushion_w, spec.cushion_thickness_m), ((back_front + d / 2) / 2, y))
        )
    if spec.arms is not None:
        arm_size = (d, arm_w, spec.arms.height_m - base_top)
        parts += [
            ("body.arm_left", arm_size, (0.0, -(w - arm_w) / 2)),
            ("body.arm_right", arm_size, (0.0, (w - arm_w) / 2)),
        ]
    for part, size, (x, y) in parts:
        add_box_part(part, size, (x, y, base_top + size[2] / 2), colour=spec.colour, collisions=collisions, parent=body)
    return assembly(
        spec,
        name,
        category="sofa",
        collisions={ROOT_LINK: collisions},
        affordances=["sittable", "supporting_surface"],
        properties={**colour_property(spec.colour), **surface_heights_property([spec.seat_height_m])},
    )
