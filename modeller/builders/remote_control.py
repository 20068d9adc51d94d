"""A remote control: one link `body`, a flat body with rounded corners (seen from above)
lying on z = 0, and its buttons standing out of the top face, all in one mesh
`body.buttons`. The end it points with is +x.
"""

from __future__ import annotations

from articulation.model import Collision, GraspPoint
from modeller.blender_scene import add_object
from modeller.blender_to_model import Assembly
from modeller.builders import box_collision, grasp_frame
from modeller.builders.rigid import ROOT_LINK, assembly, colour_property, material
from modeller.builders.shapes import cylinders_mesh, prism_mesh, rounded_rectangle_xy
from modeller.specs import RemoteControlSpec


def button_centres_m(spec: RemoteControlSpec) -> list[tuple[float, float, float]]:
    """Each button's centre on the top face (x, y, z of its base), front row first."""
    grid = spec.buttons
    front = spec.length_m / 2 - grid.from_front_m
    return [
        (front - row * grid.pitch_m, (column - (grid.columns - 1) / 2) * grid.pitch_m, spec.thickness_m)
        for row in range(grid.rows)
        for column in range(grid.columns)
    ]


def build_remote_control(spec: RemoteControlSpec, name: str) -> Assembly:
    outline = rounded_rectangle_xy(spec.length_m, spec.width_m, spec.corner_radius_m)
    body = add_object(
        ROOT_LINK, prism_mesh(ROOT_LINK, outline, spec.thickness_m), link=ROOT_LINK, material=material(spec.colour)
    )
    # The collision box includes the rounded-off corners: a few square millimetres.
    collisions: list[Collision] = [
        box_collision("body", (spec.length_m, spec.width_m, spec.thickness_m), (0, 0, spec.thickness_m / 2))
    ]
    centres = button_centres_m(spec)
    grid = spec.buttons
    if centres:
        add_object(
            "body.buttons",
            cylinders_mesh("body.buttons", centres, grid.diameter_m / 2, grid.height_m),
            link=ROOT_LINK,
            material=material(spec.button_colour),
            parent=body,
        )
        xs, ys = [c[0] for c in centres], [c[1] for c in centres]
        size = (max(xs) - min(xs) + grid.diameter_m, max(ys) - min(ys) + grid.diameter_m, grid.height_m)
        centre = ((max(xs) + min(xs)) / 2, 0.0, spec.thickness_m + grid.height_m / 2)
        collisions.append(box_collision("buttons", size, centre))
    # From above, the fingers closing across its width.
    grasp = grasp_frame((0, 0, spec.thickness_m / 2), (0, 0, -1), (1, 0, 0))
    return assembly(
        spec,
        name,
        category="remote_control",
        collisions={ROOT_LINK: collisions},
        grasp_points=[GraspPoint(name="body", link=ROOT_LINK, link_from_grasp=grasp, kind="body")],
        properties={**colour_property(spec.colour), "buttons": str(len(centres))},
    )
