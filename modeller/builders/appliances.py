"""Appliances on the cabinet machinery of `modeller.builders.cabinet` (frames and joint
names are described there), each with its own fixed parts on the body: an oven's hob and
burners, a dishwasher's racks, a washing machine's drum, a microwave's turntable plate.
"""

from __future__ import annotations

import math

import numpy as np

from articulation.model import Box, Collision, Joint
from homemodel.core.transforms import axis_angle_transform, translation_transform
from modeller.blender_scene import (
    add_object,
    add_solidify,
    box_mesh,
    cylinder_mesh,
    hollow_cylinder_mesh,
    remove_faces,
)
from modeller.blender_to_model import Assembly
from modeller.builders import FACE_NORMALS, box_collision, wall_collisions
from modeller.builders.cabinet import build_cabinet, material
from modeller.builders.handles import blender_matrix, cylinder_collision
from modeller.specs import (
    DishwasherSpec,
    FridgeSpec,
    MicrowaveSpec,
    OvenSpec,
    WashingMachineSpec,
)

# Burners are flat discs this thick on the hob plate (above the spec's height_m).
_BURNER_THICKNESS_M = 0.003
# Wire of a dishwasher's racks, as sheet walls of this thickness.
_RACK_WIRE_M = 0.004
# The drum's wall as this many boxes, so it stays hollow for a simulator.
_DRUM_WALL_BOXES = 12
_TURNTABLE_THICKNESS_M = 0.006
# The drive coupler a raised plate rests on, at its centre.
_COUPLER_RADIUS_M = 0.02
_RACK_COLOUR = "grey"

_APPLIANCE_AFFORDANCES = ["container", "openable"]


def build_fridge(spec: FridgeSpec, name: str) -> Assembly:
    return build_cabinet(spec, name, category="fridge", affordances=_APPLIANCE_AFFORDANCES).assembly


def build_oven(spec: OvenSpec, name: str) -> Assembly:
    affordances = _APPLIANCE_AFFORDANCES + (["supporting_surface"] if spec.hob is not None else [])
    cabinet = build_cabinet(spec, name, category="oven", affordances=affordances)
    if spec.hob is None:
        return cabinet.assembly
    plate = spec.hob.thickness_m
    size, centre = (spec.depth_m, spec.width_m, plate), (0.0, 0.0, spec.height_m - plate / 2)
    cabinet.add_to_body("hob", box_mesh("body.hob", size), centre, spec.hob.colour)
    cabinet.body_collisions.append(box_collision("hob", size, centre))
    for i, burner in enumerate(spec.burners()):
        burner_centre = (
            spec.depth_m / 2 - burner.from_front_m,
            -spec.width_m / 2 + burner.from_left_m,
            spec.height_m + _BURNER_THICKNESS_M / 2,
        )
        mesh = cylinder_mesh(f"body.burner_{i}", burner.diameter_m / 2, _BURNER_THICKNESS_M)
        cabinet.add_to_body(f"burner_{i}", mesh, burner_centre, spec.hob.burner_colour)
    return cabinet.assembly


def build_dishwasher(spec: DishwasherSpec, name: str) -> Assembly:
    cabinet = build_cabinet(spec, name, category="dishwasher", affordances=_APPLIANCE_AFFORDANCES)
    for i, rack in enumerate(spec.racks):
        x0, x1, y0, y1, z0, z1 = spec.rack_bounds_m(rack)
        size, centre = (x1 - x0, y1 - y0, z1 - z0), ((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2)
        mesh = box_mesh(f"body.rack_{i}", size)
        remove_faces(mesh, [FACE_NORMALS["+z"]])
        basket = cabinet.add_to_body(f"rack_{i}", mesh, centre, _RACK_COLOUR)
        add_solidify(basket, _RACK_WIRE_M)
        walls = ["+x", "-x", "+y", "-y", "-z"]
        cabinet.body_collisions.extend(wall_collisions(f"rack_{i}", size, centre, walls, _RACK_WIRE_M))
    return cabinet.assembly


def build_washing_machine(spec: WashingMachineSpec, name: str) -> Assembly:
    cabinet = build_cabinet(spec, name, category="washing_machine", affordances=_APPLIANCE_AFFORDANCES)
    if spec.drum is None:
        return cabinet.assembly
    x_back, x_front, y, z, radius = spec.drum_bounds_m()
    depth, wall = x_front - x_back, spec.drum.wall_thickness_m
    # A cup standing on z = 0 turned so its opening faces +x, its base at x_back.
    mesh = hollow_cylinder_mesh("body.drum", radius, radius - wall, depth, wall)
    mesh.transform(blender_matrix(axis_angle_transform((0, 1, 0), math.pi / 2)))
    cabinet.add_to_body("drum", mesh, (x_back, y, z), "silver")
    collisions: list[Collision] = [cylinder_collision("drum_back", radius, wall, (x_back + wall / 2, y, z))]
    chord = 2 * radius * np.tan(np.pi / _DRUM_WALL_BOXES)
    for k in range(_DRUM_WALL_BOXES):
        angle = 2 * np.pi * k / _DRUM_WALL_BOXES
        body_from_box = (
            translation_transform(((x_back + x_front + wall) / 2, y, z))
            @ axis_angle_transform((1, 0, 0), angle)
            @ translation_transform((0, 0, radius - wall / 2))
        )
        collisions.append(
            Collision(
                name=f"drum_wall_{k}",
                geometry=Box(size_m=(depth - wall, chord, wall)),
                link_from_collision=body_from_box,
            )
        )
    cabinet.body_collisions.extend(collisions)
    return cabinet.assembly


def build_microwave(spec: MicrowaveSpec, name: str) -> Assembly:
    """The plate sits on the cavity floor, or `turntable_raise_m` above it on a coupler (fixed
    to the body); a turning plate is link `turntable` on the continuous joint `turntable_spin`."""
    cabinet = build_cabinet(spec, name, category="microwave", affordances=_APPLIANCE_AFFORDANCES)
    if spec.turntable_diameter_m is None:
        return cabinet.assembly
    radius, lift = spec.turntable_diameter_m / 2, spec.turntable_raise_m
    axis_x, axis_y = spec.turntable_centre_m()
    if lift > 0:
        hub_centre = (axis_x, axis_y, spec.inner_floor_m + lift / 2)
        hub = cylinder_mesh("body.turntable_coupler", _COUPLER_RADIUS_M, lift, segments=24)
        cabinet.add_to_body("turntable_coupler", hub, hub_centre, "grey")
        cabinet.body_collisions.append(cylinder_collision("turntable_coupler", _COUPLER_RADIUS_M, lift, hub_centre, "z"))
    centre = (axis_x, axis_y, spec.inner_floor_m + lift + _TURNTABLE_THICKNESS_M / 2)
    mesh = cylinder_mesh("body.turntable", radius, _TURNTABLE_THICKNESS_M, segments=48)
    if not spec.turntable_turns:
        cabinet.add_to_body("turntable", mesh, centre, spec.turntable_colour)
        cabinet.body_collisions.append(cylinder_collision("turntable", radius, _TURNTABLE_THICKNESS_M, centre, "z"))
        return cabinet.assembly
    body_from_plate = translation_transform((axis_x, axis_y, spec.inner_floor_m + lift))
    plate_centre = (0.0, 0.0, _TURNTABLE_THICKNESS_M / 2)
    mesh.transform(blender_matrix(translation_transform(plate_centre)))
    add_object(
        "turntable",
        mesh,
        link="turntable",
        material=material(spec.turntable_colour),
        parent=cabinet.body,
        parent_from_object=body_from_plate,
    )
    cabinet.assembly.collisions["turntable"] = [
        cylinder_collision("turntable", radius, _TURNTABLE_THICKNESS_M, plate_centre, "z")
    ]
    cabinet.assembly.joints.append(
        Joint(
            name="turntable_spin",
            type="continuous",
            parent="body",
            child="turntable",
            parent_from_joint=body_from_plate,
            axis=np.array([0.0, 0.0, 1.0]),
        )
    )
    return cabinet.assembly
