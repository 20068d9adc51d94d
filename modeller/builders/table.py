"""A table: one link `body`, a top slab on four legs.

The top's `length_m` runs side to side as seen from the front (along y), its `width_m`
front to back (along x); the top surface is at z = `height_m`.
"""

from __future__ import annotations

from articulation.model import Collision, Cylinder
from homemodel.transforms import translation_transform
from modeller.blender_scene import add_object, box_mesh, colour_material, cylinder_mesh
from modeller.blender_to_model import Assembly
from modeller.builders import box_collision
from modeller.specs import TableSpec, colour_name, colour_rgb


def build_table(spec: TableSpec, name: str) -> Assembly:
    table_material = colour_material(colour_name(spec.colour), colour_rgb(spec.colour))
    top, legs = spec.top, spec.legs
    top_size = (top.width_m, top.length_m, top.thickness_m)
    top_centre = (0.0, 0.0, spec.height_m - top.thickness_m / 2)
    body = add_object("body", box_mesh("body", top_size, top_centre), link="body", material=table_material)
    collisions = [box_collision("top", top_size, top_centre)]

    section = legs.section_m
    leg_length = spec.height_m - top.thickness_m
    x = top.width_m / 2 - legs.inset_m - section / 2
    y = top.length_m / 2 - legs.inset_m - section / 2
    for k, (sx, sy) in enumerate(((1, -1), (1, 1), (-1, -1), (-1, 1))):
        leg_name = f"body.leg_{k}"
        leg_centre = (sx * x, sy * y, leg_length / 2)
        if legs.diameter_m is not None:
            mesh = cylinder_mesh(leg_name, section / 2, leg_length)
            collisions.append(
                Collision(
                    name=f"leg_{k}",
                    geometry=Cylinder(radius_m=section / 2, length_m=leg_length),
                    link_from_collision=translation_transform(leg_centre),
                )
            )
        else:
            mesh = box_mesh(leg_name, (section, section, leg_length))
            collisions.append(box_collision(f"leg_{k}", (section, section, leg_length), leg_centre))
        add_object(
            leg_name,
            mesh,
            link="body",
            material=table_material,
            parent=body,
            parent_from_object=translation_transform(leg_centre),
        )
    return Assembly(
        name=name,
        category="table",
        collisions={"body": collisions},
        affordances=["supporting_surface"],
        density_kg_m3=spec.density_or_default_kg_m3,
        mass_kg=spec.mass_kg,
    )
