"""A table: one link `body`, a top slab (a rectangle or a disc) on four legs or a pedestal.

A rectangular top's `length_m` runs side to side as seen from the front (along y), its
`width_m` front to back (along x); the top surface is at z = `height_m`. Under a round top
the legs stand on its diagonals. `four_legs` also carries chairs' seats.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from articulation.model import Box, Collision, Cylinder
from homemodel.core.transforms import axis_angle_transform, translation_transform
from modeller.blender_scene import _revolve, add_object, box_mesh, cylinder_mesh
from modeller.blender_to_model import Assembly
from modeller.builders.rigid import (
    ROOT_LINK,
    add_box_part,
    assembly,
    colour_property,
    material,
    surface_heights_property,
)
from modeller.specs import TableSpec
from modeller.specs.common import Colour
from modeller.specs.furniture import Legs

if TYPE_CHECKING:
    import bpy

_ROUND_SEGMENTS = 64


def four_legs(
    legs: Legs,
    size_xy_m: tuple[float, float],
    length_m: float,
    *,
    round_top: bool,
    colour: Colour,
    parent: bpy.types.Object,
    collisions: list[Collision],
    centre_x_m: float = 0.0,
) -> None:
    """Four legs from the floor up to `length_m`, under a top of `size_xy_m` (x, y) centred
    on (centre_x_m, 0), named `body.leg_<k>`."""
    section = legs.section_m
    if round_top:
        centre_radius = size_xy_m[0] / 2 - legs.inset_m - section / 2
        angles = [math.pi / 4 + k * math.pi / 2 for k in range(4)]
        # Each leg's frame is turned to face the rim, so a square leg's outer face looks out.
        frames = [
            translation_transform((centre_radius * math.cos(a), centre_radius * math.sin(a), length_m / 2))
            @ axis_angle_transform((0, 0, 1), a)
            for a in angles
        ]
    else:
        x = size_xy_m[0] / 2 - legs.inset_m - section / 2
        y = size_xy_m[1] / 2 - legs.inset_m - section / 2
        frames = [
            translation_transform((sx * x, sy * y, length_m / 2)) for sx, sy in ((1, -1), (1, 1), (-1, -1), (-1, 1))
        ]
    for k, top_from_leg in enumerate(frames):
        body_from_leg = translation_transform((centre_x_m, 0.0, 0.0)) @ top_from_leg
        leg_name = f"body.leg_{k}"
        if legs.diameter_m is not None:
            mesh = cylinder_mesh(leg_name, section / 2, length_m)
            geometry = Cylinder(radius_m=section / 2, length_m=length_m)
        else:
            mesh = box_mesh(leg_name, (section, section, length_m))
            geometry = Box(size_m=(section, section, length_m))
        add_object(
            leg_name, mesh, link=ROOT_LINK, material=material(colour), parent=parent, parent_from_object=body_from_leg
        )
        collisions.append(Collision(name=f"leg_{k}", geometry=geometry, link_from_collision=body_from_leg))


def _disc(
    name: str, radius_m: float, bottom_m: float, top_m: float, *, parent: bpy.types.Object | None, colour: Colour
):
    """An upright cylinder placed by its mesh coordinates (a round top, a pedestal's foot or column)."""
    profile = np.array([(radius_m, bottom_m), (radius_m, top_m)])
    return add_object(
        name, _revolve(name, profile, _ROUND_SEGMENTS), link=ROOT_LINK, material=material(colour), parent=parent
    )


def _cylinder_collision(name: str, radius_m: float, bottom_m: float, top_m: float) -> Collision:
    return Collision(
        name=name,
        geometry=Cylinder(radius_m=radius_m, length_m=top_m - bottom_m),
        link_from_collision=translation_transform((0, 0, (bottom_m + top_m) / 2)),
    )


def build_table(spec: TableSpec, name: str) -> Assembly:
    top = spec.top
    top_bottom = spec.height_m - top.thickness_m
    collisions: list[Collision] = []
    if top.shape == "round":
        radius = top.diameter_m / 2
        body = _disc(ROOT_LINK, radius, top_bottom, spec.height_m, parent=None, colour=spec.colour)
        collisions.append(_cylinder_collision("top", radius, top_bottom, spec.height_m))
    else:
        size = (top.width_m, top.length_m, top.thickness_m)
        body = add_box_part(
            ROOT_LINK,
            size,
            (0.0, 0.0, spec.height_m - top.thickness_m / 2),
            colour=spec.colour,
            collisions=collisions,
            collision_name="top",
        )
    if spec.pedestal is None:
        four_legs(
            spec.legs_or_default,
            top.size_xy_m,
            top_bottom,
            round_top=top.shape == "round",
            colour=spec.colour,
            parent=body,
            collisions=collisions,
        )
    else:
        pedestal = spec.pedestal
        foot_r, column_r, foot_t = (
            pedestal.foot_diameter_m / 2,
            pedestal.column_diameter_m / 2,
            pedestal.foot_thickness_m,
        )
        _disc("body.foot", foot_r, 0.0, foot_t, parent=body, colour=spec.colour)
        _disc("body.column", column_r, foot_t, top_bottom, parent=body, colour=spec.colour)
        collisions += [
            _cylinder_collision("foot", foot_r, 0.0, foot_t),
            _cylinder_collision("column", column_r, foot_t, top_bottom),
        ]
    return assembly(
        spec,
        name,
        category="table",
        collisions={ROOT_LINK: collisions},
        affordances=["supporting_surface"],
        properties={**colour_property(spec.colour), **surface_heights_property([spec.height_m]), "shape": top.shape},
    )
