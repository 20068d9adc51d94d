"""Spoons, forks and knives: one link `body` each, lying on z = 0 along x, the working end
towards +x (see `modeller.specs.cutlery`). Thin parts are extruded outlines; a spoon's bowl
is the bowl profile of `modeller.builders.shapes` turned and stretched to an ellipse.

Grasp point `handle` (kind handle) on the middle of the handle, approached from above,
the fingers closing across it.
"""

from __future__ import annotations

import math

import numpy as np

from articulation.model import Box, Collision, GraspPoint
from homemodel.core.transforms import axis_angle_transform, translation_transform
from modeller.blender_scene import _revolve, add_object
from modeller.blender_to_model import Assembly
from modeller.builders import box_collision, grasp_frame
from modeller.builders.rigid import (
    ROOT_LINK,
    add_box_part,
    assembly,
    colour_property,
    material,
)
from modeller.builders.shapes import (
    bowl_profile_rz,
    prism_mesh,
    round_tip_outline_xy,
    rounded_rectangle_xy,
    tapered_outline_xy,
)
from modeller.specs import ForkSpec, KnifeSpec, SpoonSpec
from modeller.specs.cutlery import _Cutlery

_BOWL_SEGMENTS = 48
_SPOON_FOOT_FRACTION = 0.35  # the flat of the bowl, as a fraction of its half-width


def _handle_grasp(x_m: float, z_m: float) -> GraspPoint:
    frame = grasp_frame((x_m, 0.0, z_m), (0, 0, -1), (1, 0, 0))
    return GraspPoint(name="handle", link=ROOT_LINK, link_from_grasp=frame, kind="handle")


def _cutlery_assembly(spec: _Cutlery, name: str, collisions: list[Collision], grasp: GraspPoint) -> Assembly:
    return assembly(
        spec,
        name,
        category=spec.kind,  # type: ignore[attr-defined]
        collisions={ROOT_LINK: collisions},
        grasp_points=[grasp],
        properties=colour_property(spec.colour),
    )


def build_spoon(spec: SpoonSpec, name: str) -> Assembly:
    half, t = spec.length_m / 2, spec.handle_thickness_m
    bowl_back = half - spec.bowl_length_m
    # The handle climbs from the table at its end to the bowl's back rim.
    rise = (spec.bowl_depth_m - t) / (bowl_back + half)
    outline = tapered_outline_xy(-half, bowl_back, spec.handle_width_m, spec.neck_width_m)
    body = add_object(
        ROOT_LINK, prism_mesh(ROOT_LINK, outline, t, rise=rise), link=ROOT_LINK, material=material(spec.colour)
    )
    radius = spec.bowl_width_m / 2
    profile, _ = bowl_profile_rz(
        radius, spec.bowl_depth_m, _SPOON_FOOT_FRACTION * radius, spec.bowl_thickness_m, spec.bowl_thickness_m
    )
    bowl_centre_x = half - spec.bowl_length_m / 2
    stretch = np.diag([spec.bowl_length_m / spec.bowl_width_m, 1.0, 1.0, 1.0])
    add_object(
        "body.bowl",
        _revolve("body.bowl", profile, _BOWL_SEGMENTS),
        link=ROOT_LINK,
        material=material(spec.colour),
        parent=body,
        parent_from_object=translation_transform((bowl_centre_x, 0.0, 0.0)) @ stretch,
    )
    run = bowl_back + half
    slope = math.atan2(spec.bowl_depth_m - t, run)
    handle_box = translation_transform(((bowl_back - half) / 2, 0.0, spec.bowl_depth_m / 2)) @ axis_angle_transform(
        (0, 1, 0), -slope
    )
    collisions = [
        Collision(
            name="handle",
            geometry=Box(size_m=(math.hypot(run, spec.bowl_depth_m - t), spec.handle_width_m, t)),
            link_from_collision=handle_box,
        ),
        box_collision(
            "bowl",
            (spec.bowl_length_m, spec.bowl_width_m, spec.bowl_depth_m),
            (bowl_centre_x, 0, spec.bowl_depth_m / 2),
        ),
    ]
    grasp_x = (bowl_back - half) / 2
    return _cutlery_assembly(spec, name, collisions, _handle_grasp(grasp_x, rise * (grasp_x + half) + t / 2))


def build_fork(spec: ForkSpec, name: str) -> Assembly:
    half, t = spec.length_m / 2, spec.thickness_m
    neck_x, roots_x = half - spec.head_length_m, half - spec.tine_length_m
    handle_outline = tapered_outline_xy(-half, neck_x, spec.handle_width_m, spec.neck_width_m)
    body = add_object(
        ROOT_LINK,
        prism_mesh(ROOT_LINK, handle_outline, spec.handle_thickness_m),
        link=ROOT_LINK,
        material=material(spec.colour),
    )
    add_object(
        "body.head",
        prism_mesh("body.head", tapered_outline_xy(neck_x, roots_x, spec.neck_width_m, spec.head_width_m), t),
        link=ROOT_LINK,
        material=material(spec.colour),
        parent=body,
    )
    collisions = [
        box_collision(
            "handle",
            (neck_x + half, spec.handle_width_m, spec.handle_thickness_m),
            ((neck_x - half) / 2, 0, spec.handle_thickness_m / 2),
        ),
        box_collision("head", (spec.head_length_m, spec.head_width_m, t), (half - spec.head_length_m / 2, 0, t / 2)),
    ]
    tine_w = spec.tine_width_m
    for k in range(spec.tines):
        y = -spec.head_width_m / 2 + tine_w / 2 + 2 * k * tine_w
        # The tines' collision is the head's box; each tine is a visual only.
        add_box_part(
            f"body.tine_{k}", (spec.tine_length_m, tine_w, t), (half - spec.tine_length_m / 2, y, t / 2),
            colour=spec.colour, collisions=[], parent=body,
        )  # fmt: skip
    return _cutlery_assembly(spec, name, collisions, _handle_grasp((neck_x - half) / 2, spec.handle_thickness_m / 2))


def build_knife(spec: KnifeSpec, name: str) -> Assembly:
    half = spec.length_m / 2
    blade_x = half - spec.blade_length_m
    handle_length, handle_t = blade_x + half, spec.handle_thickness_m
    handle_outline = rounded_rectangle_xy(
        handle_length, spec.handle_width_m, spec.handle_width_m / 4, centre_x_m=(blade_x - half) / 2
    )
    body = add_object(
        ROOT_LINK, prism_mesh(ROOT_LINK, handle_outline, handle_t), link=ROOT_LINK, material=material(spec.colour)
    )
    add_object(
        "body.blade",
        prism_mesh("body.blade", round_tip_outline_xy(blade_x, half, spec.blade_width_m), spec.blade_thickness_m),
        link=ROOT_LINK,
        material=material(spec.colour),
        parent=body,
    )
    collisions = [
        box_collision(
            "handle", (handle_length, spec.handle_width_m, handle_t), ((blade_x - half) / 2, 0, handle_t / 2)
        ),
        box_collision(
            "blade",
            (spec.blade_length_m, spec.blade_width_m, spec.blade_thickness_m),
            (half - spec.blade_length_m / 2, 0, spec.blade_thickness_m / 2),
        ),
    ]
    return _cutlery_assembly(spec, name, collisions, _handle_grasp((blade_x - half) / 2, handle_t / 2))
