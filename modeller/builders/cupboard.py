"""Cupboards, wall cabinets and wardrobes: the cabinet machinery of
`modeller.builders.cabinet` (frames and joint names are described there), with a
wardrobe's hanging rails added to the body.
"""

from __future__ import annotations

from modeller.blender_scene import cylinder_mesh
from modeller.blender_to_model import Assembly
from modeller.builders.cabinet import build_cabinet
from modeller.builders.handles import cylinder_collision
from modeller.specs import CupboardSpec, WallCabinetSpec, WardrobeSpec

_STORAGE_AFFORDANCES = ["container", "openable", "supporting_surface"]


def build_cupboard(spec: CupboardSpec, name: str) -> Assembly:
    return build_cabinet(spec, name, category="cupboard", affordances=_STORAGE_AFFORDANCES).assembly


def build_wall_cabinet(spec: WallCabinetSpec, name: str) -> Assembly:
    # Its top is out of reach as a surface to put things on; its shelves are the containers.
    return build_cabinet(spec, name, category="wall_cabinet", affordances=["container", "openable"]).assembly


def build_wardrobe(spec: WardrobeSpec, name: str) -> Assembly:
    cabinet = build_cabinet(spec, name, category="wardrobe", affordances=["container", "openable"])
    for i, rail in enumerate(spec.rails):
        left, right, x = spec.rail_span_m(rail)
        centre = (x, -spec.width_m / 2 + (left + right) / 2, rail.height_m)
        mesh = cylinder_mesh(f"body.rail_{i}", rail.diameter_m / 2, right - left, axis="y")
        cabinet.add_to_body(f"rail_{i}", mesh, centre, spec.handle_colour)
        collision = cylinder_collision(f"rail_{i}", rail.diameter_m / 2, right - left, centre, "y")
        cabinet.body_collisions.append(collision)
    return cabinet.assembly
