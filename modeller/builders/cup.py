"""A cup (or a mug) as D3.1's Figure 11 shows it: two cylinders, a hollow body (open top,
closed bottom) and a handle bent round into a torus segment.

One link `body`; origin at the centre of the bottom, z up, the handle on the +x side. Its
half-torus stands in the x-z plane with its centre in the middle of the wall, so the
handle's ends are buried in the wall: no gap outside, nothing poking into the cup.
Grasp points: `handle` on the handle's centreline at its outermost point (approach -x, z up),
`body` on the axis at half height (approach +x, from the side away from the handle).
"""

from __future__ import annotations

from articulation.model import GraspPoint
from homemodel.core.transforms import translation_transform
from modeller.blender_scene import add_object, hollow_cylinder_mesh, torus_segment_mesh
from modeller.blender_to_model import Assembly
from modeller.builders import box_collision, grasp_frame
from modeller.builders.rigid import ROOT_LINK, assembly, colour_property, material
from modeller.builders.vessels import cup_wall_collisions, side_grasp
from modeller.specs import CupSpec


def build_cup(spec: CupSpec, name: str) -> Assembly:
    """A cup or a mug (`spec.kind` is its category)."""
    cup_material = material(spec.colour)
    radius, wall = spec.outer_diameter_m / 2, spec.wall_thickness_m
    bottom, height = spec.bottom_thickness_m, spec.height_m
    body = add_object(
        ROOT_LINK,
        hollow_cylinder_mesh(ROOT_LINK, radius, radius - wall, height, bottom),
        link=ROOT_LINK,
        material=cup_material,
    )
    collisions = cup_wall_collisions(radius, wall, bottom, height)
    grasp_points = [side_grasp("body", height / 2)]
    if spec.handle is not None:
        centre_x, major, minor = spec.handle_ring_m()
        handle_z = spec.handle_height_m
        add_object(
            "body.handle",
            torus_segment_mesh("body.handle", major, minor, 180.0),
            link=ROOT_LINK,
            material=cup_material,
            parent=body,
            parent_from_object=translation_transform((centre_x, 0.0, handle_z)),
        )
        reach = major + minor
        collisions.append(box_collision("handle", (reach, 2 * minor, 2 * reach), (centre_x + reach / 2, 0.0, handle_z)))
        grasp_points.append(
            GraspPoint(
                name="handle",
                link=ROOT_LINK,
                link_from_grasp=grasp_frame((centre_x + major, 0.0, handle_z), (-1, 0, 0), (0, 0, 1)),
                kind="handle",
            )
        )
    return assembly(
        spec,
        name,
        category=spec.kind,
        collisions={ROOT_LINK: collisions},
        grasp_points=grasp_points,
        affordances=["container"],
        properties=colour_property(spec.colour),
    )
