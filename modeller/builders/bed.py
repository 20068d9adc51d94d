"""A bed: one link `body`; the headboard at the back (-x), the foot end towards +x.

Boxes: a headboard from the floor, a frame on four legs (none when the frame reaches the
floor), a mattress on the frame, and a footboard when it has one.
"""

from __future__ import annotations

from articulation.model import Collision
from modeller.blender_to_model import Assembly
from modeller.builders.rigid import (
    ROOT_LINK,
    add_box_part,
    assembly,
    colour_property,
    surface_heights_property,
)
from modeller.builders.table import four_legs
from modeller.specs import BedSpec
from modeller.specs.furniture import Legs


def build_bed(spec: BedSpec, name: str) -> Assembly:
    collisions: list[Collision] = []
    length, width = spec.length_m, spec.width_m
    head_t = spec.headboard_thickness_m
    body = add_box_part(
        ROOT_LINK,
        (head_t, width, spec.headboard_height_m),
        (-length / 2 + head_t / 2, 0.0, spec.headboard_height_m / 2),
        colour=spec.colour,
        collisions=collisions,
        collision_name="headboard",
    )
    frame_length = spec.frame_length_m
    frame_x = -length / 2 + head_t + frame_length / 2
    frame_bottom = spec.frame_height_m - spec.frame_thickness_m
    add_box_part(
        "body.frame",
        (frame_length, width, spec.frame_thickness_m),
        (frame_x, 0.0, frame_bottom + spec.frame_thickness_m / 2),
        colour=spec.colour,
        collisions=collisions,
        parent=body,
    )
    inset = spec.mattress_inset_m
    add_box_part(
        "body.mattress",
        (frame_length - 2 * inset, width - 2 * inset, spec.mattress_thickness_m),
        (frame_x, 0.0, spec.frame_height_m + spec.mattress_thickness_m / 2),
        colour=spec.mattress_colour,
        collisions=collisions,
        parent=body,
    )
    if spec.footboard_height_m > 0:
        foot_t = spec.footboard_thickness_m
        add_box_part(
            "body.footboard",
            (foot_t, width, spec.footboard_height_m),
            (length / 2 - foot_t / 2, 0.0, spec.footboard_height_m / 2),
            colour=spec.colour,
            collisions=collisions,
            parent=body,
        )
    if frame_bottom > 0:
        four_legs(
            Legs(size_m=spec.leg_size_m, inset_m=0.0),
            (frame_length, width),
            frame_bottom,
            round_top=False,
            colour=spec.colour,
            parent=body,
            collisions=collisions,
            centre_x_m=frame_x,
        )
    return assembly(
        spec,
        name,
        category="bed",
        collisions={ROOT_LINK: collisions},
        affordances=["supporting_surface", "sittable"],
        properties={**colour_property(spec.colour), **surface_heights_property([spec.surface_height_m])},
    )
