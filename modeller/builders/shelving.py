"""Open shelving: one link `body`; two side panels from the floor to the top, a top board and
shelves between them, and an optional back panel between them at the rear (-x).

Every shelf's top surface and the top board's are supporting surfaces; their heights go
into the map's `surface_heights_m` property.
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
from modeller.specs import ShelvingSpec


def build_shelving(spec: ShelvingSpec, name: str) -> Assembly:
    collisions: list[Collision] = []
    w, d, h, t = spec.width_m, spec.depth_m, spec.height_m, spec.board_thickness_m
    side_y = (w - t) / 2
    body = add_box_part(
        ROOT_LINK,
        (d, t, h),
        (0.0, -side_y, h / 2),
        colour=spec.colour,
        collisions=collisions,
        collision_name="side_left",
    )
    add_box_part(
        "body.side_right", (d, t, h), (0.0, side_y, h / 2), colour=spec.colour, collisions=collisions, parent=body
    )
    back_t = spec.back_thickness_or_zero_m
    if spec.back:
        add_box_part(
            "body.back",
            (back_t, w - 2 * t, h - t),
            (-d / 2 + back_t / 2, 0.0, (h - t) / 2),
            colour=spec.colour,
            collisions=collisions,
            parent=body,
        )
    board_size = (d - back_t, w - 2 * t, t)
    board_x = back_t / 2  # the boards fill the depth in front of the back panel
    boards = [("body.top", h), *((f"body.shelf_{i}", height) for i, height in enumerate(spec.shelf_heights_m))]
    for part, top_z in boards:
        add_box_part(
            part, board_size, (board_x, 0.0, top_z - t / 2), colour=spec.colour, collisions=collisions, parent=body
        )
    return assembly(
        spec,
        name,
        category="shelving",
        collisions={ROOT_LINK: collisions},
        affordances=["supporting_surface"],
        properties={**colour_property(spec.colour), **surface_heights_property([h, *spec.shelf_heights_m])},
    )
