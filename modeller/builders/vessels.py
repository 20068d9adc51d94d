"""Glasses, plates, bowls, bottles and jars: solids of revolution turned from an (r, z)
profile by `modeller.blender_scene._revolve`, in the link `body` (a jar's lid in `lid`, on
the prismatic joint `lid_lift` along +z: it rests on the jar and lifts off, up to
`LID_LIFT_M` above it).

Origin at the centre of the base, z up. Hollow vessels get collision shapes that keep them
hollow (`shell_collisions`): a cylinder for the floor and a ring of boxes along the wall,
so a simulator can put something inside; a closed bottle is its convex hull.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from articulation.model import Box, Collision, Cylinder, GraspPoint, Joint, JointLimits, MeshGeometry
from homemodel.core.transforms import axis_angle_transform, translation_transform
from modeller.blender_scene import (
    _revolve,
    add_object,
    cylinder_mesh,
    hollow_cylinder_mesh,
)
from modeller.blender_to_model import Assembly
from modeller.builders import grasp_frame
from modeller.builders.rigid import (
    ROOT_LINK,
    assembly,
    colour_property,
    contents_property,
    material,
)
from modeller.builders.shapes import bowl_profile_rz, smooth_step_rz
from modeller.part_masses import jar_lid_mass_kg
from modeller.specs import BottleSpec, BowlSpec, GlassSpec, JarSpec, PlateSpec

if TYPE_CHECKING:
    import trimesh

SEGMENTS = 64  # around the axis; a multiple of 4 puts vertices on the x and y extremes
# How far a jar's lid lifts: clear of the jar for a hand to take it away.
LID_LIFT_M = 0.2
_WALL_SECTORS = 16


def shell_collisions(
    outer_rz: np.ndarray,
    inner_rz: np.ndarray,
    floor_radius_m: float,
    floor_thickness_m: float,
    *,
    corners: Sequence[int] | None = None,
    sectors: int = _WALL_SECTORS,
) -> list[Collision]:
    """A vessel's collision shapes: its floor as a cylinder on z = 0 up to `floor_thickness_m`,
    and rings of boxes lying in its wall. A cylinder or a convex hull would fill the vessel.

    `outer_rz` and `inner_rz` are the wall's outer and inner surfaces as (r, z) polylines from
    the bottom to the rim, point for point (the i-th of each at the same place along the
    wall). One ring of boxes spans each stretch between consecutive `corners` (indices into
    the polylines; default: every point). Each box's inner face lies on the tangent to the
    inner surface parallel to that stretch's chord, so no box reaches into the cavity, and
    it is as thick as the wall allows there.
    """
    shapes = [
        Collision(
            name="bottom",
            geometry=Cylinder(radius_m=floor_radius_m, length_m=floor_thickness_m),
            link_from_collision=translation_transform((0, 0, floor_thickness_m / 2)),
        )
    ]
    outer, inner = np.asarray(outer_rz, dtype=np.float64), np.asarray(inner_rz, dtype=np.float64)
    if outer.shape != inner.shape or outer.ndim != 2 or outer.shape[1] != 2:
        raise ValueError(f"{outer.shape=} and {inner.shape=} but expected the same (N, 2)")
    corners = list(range(len(inner))) if corners is None else list(corners)
    for s, (a, b) in enumerate(zip(corners[:-1], corners[1:])):
        along = inner[b] - inner[a]
        length = float(np.linalg.norm(along))
        along /= length
        into_wall = np.array([along[1], -along[0]])  # right of the upward path, away from the cavity
        # How far the inner surface bulges into the wall beyond the chord, and how much wall is left.
        bulge = max(0.0, float(((inner[a : b + 1] - inner[a]) @ into_wall).max()))
        thickness = float(((outer[a : b + 1] - inner[a]) @ into_wall).min()) - bulge
        if thickness <= 0:
            raise ValueError(f"wall stretch {s} leaves no room for a collision box ({thickness=:.2g} m)")
        centre = (inner[a] + inner[b]) / 2 + into_wall * (bulge + thickness / 2)
        sector_from_box = np.eye(4)
        # Box x across the wall, y round the axis, z along the wall (a right-handed frame).
        sector_from_box[:3, 0] = (into_wall[0], 0.0, into_wall[1])
        sector_from_box[:3, 1] = (0.0, 1.0, 0.0)
        sector_from_box[:3, 2] = (along[0], 0.0, along[1])
        sector_from_box[:3, 3] = (centre[0], 0.0, centre[1])
        # Wide enough round the axis to close the ring at the stretch's widest.
        width = 2 * float(outer[a : b + 1, 0].max()) * np.tan(np.pi / sectors)
        for k in range(sectors):
            shapes.append(
                Collision(
                    name=f"wall_{s}_{k}",
                    geometry=Box(size_m=(thickness, width, length)),
                    link_from_collision=axis_angle_transform((0, 0, 1), 2 * np.pi * k / sectors) @ sector_from_box,
                )
            )
    return shapes


def cup_wall_collisions(radius_m: float, wall_m: float, bottom_m: float, height_m: float) -> list[Collision]:
    """A straight-sided vessel's shell (a cup, a jar): `shell_collisions` of its vertical wall."""
    outer = np.array([(radius_m, bottom_m), (radius_m, height_m)])
    return shell_collisions(outer, outer - (wall_m, 0.0), radius_m, bottom_m)


def side_grasp(name: str, height_m: float, link: str = ROOT_LINK) -> GraspPoint:
    """A grasp round the body at `height_m` on the axis, approaching along +x, fingers across y."""
    return GraspPoint(
        name=name, link=link, link_from_grasp=grasp_frame((0, 0, height_m), (1, 0, 0), (0, 0, 1)), kind="body"
    )


def rim_grasp(radius_m: float, height_m: float, *, link: str = ROOT_LINK, name: str = "rim") -> GraspPoint:
    """A pinch on the rim at +x, approaching inward, the fingers closing vertically on it."""
    frame = grasp_frame((radius_m, 0, height_m), (-1, 0, 0), (0, 1, 0))
    return GraspPoint(name=name, link=link, link_from_grasp=frame, kind="rim")


def _revolved_body(profile_rz: np.ndarray, colour) -> None:
    add_object(ROOT_LINK, _revolve(ROOT_LINK, profile_rz, SEGMENTS), link=ROOT_LINK, material=material(colour))


def build_glass(spec: GlassSpec, name: str) -> Assembly:
    rb, rt, h = spec.bottom_diameter_m / 2, spec.top_diameter_m / 2, spec.height_m
    wall, base = spec.wall_thickness_m, spec.base_thickness_m
    # The inner wall is the outer one moved in horizontally by the wall's thickness.
    inner_bottom = rb - wall + (rt - rb) * base / h
    _revolved_body(np.array([(rb, 0.0), (rt, h), (rt - wall, h), (inner_bottom, base)]), spec.colour)
    outer = np.array([(inner_bottom + wall, base), (rt, h)])
    return assembly(
        spec,
        name,
        category="glass",
        collisions={ROOT_LINK: shell_collisions(outer, outer - (wall, 0.0), rb, base)},
        grasp_points=[side_grasp("body", h / 2)],
        affordances=["container"],
        properties=colour_property(spec.colour),
    )


def build_plate(spec: PlateSpec, name: str) -> Assembly:
    radius, well, h, t = spec.diameter_m / 2, spec.well_diameter_m / 2, spec.height_or_default_m, spec.thickness_m
    # Underside: the flat well, then the rim sloping up; the top surface is the same raised by t.
    _revolved_body(np.array([(well, 0.0), (radius, h - t), (radius, h), (well, t)]), spec.colour)
    outer = np.array([(well, 0.0), (radius, h - t)])
    return assembly(
        spec,
        name,
        category="plate",
        collisions={ROOT_LINK: shell_collisions(outer, outer + (0.0, t), well, t)},
        grasp_points=[rim_grasp(radius, h - t / 2)],
        affordances=["supporting_surface"] if spec.style == "flat" else ["container"],
        properties={**colour_property(spec.colour), "style": spec.style},
    )


def build_bowl(spec: BowlSpec, name: str) -> Assembly:
    radius, foot = spec.diameter_m / 2, spec.foot_diameter_m / 2
    profile, outer = bowl_profile_rz(radius, spec.height_m, foot, spec.wall_thickness_m, spec.bottom_thickness_m)
    _revolved_body(profile, spec.colour)
    inner = profile[len(outer) :][::-1]
    corners = np.linspace(0, len(outer) - 1, 7).round().astype(int)  # six rings along the curve
    return assembly(
        spec,
        name,
        category="bowl",
        collisions={ROOT_LINK: shell_collisions(outer, inner, foot, spec.bottom_thickness_m, corners=corners)},
        grasp_points=[rim_grasp(radius, spec.height_m - spec.wall_thickness_m)],
        affordances=["container"],
        properties=colour_property(spec.colour),
    )


def bottle_profile_rz(spec: BottleSpec) -> np.ndarray:
    """The bottle without its cap: body, shoulder and neck, closed at both ends."""
    r, neck = spec.diameter_m / 2, spec.neck_diameter_m / 2
    shoulder = smooth_step_rz((r, spec.shoulder_height_m), (neck, spec.neck_height_m), 10)
    return np.vstack([[(r, 0.0)], shoulder, [(neck, spec.height_m - spec.cap_height_m)]])


def _convex_hull(profile_rz: np.ndarray, segments: int = 32) -> trimesh.Trimesh:
    import trimesh

    angles = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    r, z = profile_rz[:, :1], profile_rz[:, 1:]
    points = np.stack([r * np.cos(angles), r * np.sin(angles), np.broadcast_to(z, (len(z), segments))], -1)
    return trimesh.convex.convex_hull(points.reshape(-1, 3))


def build_bottle(spec: BottleSpec, name: str) -> Assembly:
    profile = bottle_profile_rz(spec)
    body = add_object(ROOT_LINK, _revolve(ROOT_LINK, profile, SEGMENTS), link=ROOT_LINK, material=material(spec.colour))
    cap_bottom = spec.height_m - spec.cap_height_m
    add_object(
        "body.cap",
        cylinder_mesh("body.cap", spec.cap_diameter_m / 2, spec.cap_height_m, segments=SEGMENTS),
        link=ROOT_LINK,
        material=material(spec.cap_colour),
        parent=body,
        parent_from_object=translation_transform((0, 0, cap_bottom + spec.cap_height_m / 2)),
    )
    cap_rz = np.array([(spec.cap_diameter_m / 2, cap_bottom), (spec.cap_diameter_m / 2, spec.height_m)])
    hull = _convex_hull(np.vstack([profile, cap_rz]))
    cap_grasp = grasp_frame((0, 0, cap_bottom + spec.cap_height_m / 2), (0, 0, -1), (1, 0, 0))
    return assembly(
        spec,
        name,
        category="bottle",
        collisions={ROOT_LINK: [Collision(name="hull", geometry=MeshGeometry(mesh=hull))]},
        grasp_points=[
            side_grasp("body", spec.shoulder_height_m / 2),
            GraspPoint(name="cap", link=ROOT_LINK, link_from_grasp=cap_grasp, kind="knob"),
        ],
        affordances=["container"],
        properties={**colour_property(spec.colour), **contents_property(spec.contents)},
    )


def build_jar(spec: JarSpec, name: str) -> Assembly:
    radius, wall, bottom, body_h = (
        spec.diameter_m / 2,
        spec.wall_thickness_m,
        spec.bottom_thickness_m,
        spec.body_height_m,
    )
    body = add_object(
        ROOT_LINK,
        hollow_cylinder_mesh(ROOT_LINK, radius, radius - wall, body_h, bottom, segments=SEGMENTS),
        link=ROOT_LINK,
        material=material(spec.colour),
    )
    lid_radius, lid_t = spec.lid_diameter_or_default_m / 2, spec.lid_thickness_m
    body_from_lid = translation_transform((0, 0, body_h))
    lid = add_object(
        "lid",
        _revolve("lid", np.array([(lid_radius, 0.0), (lid_radius, lid_t)]), SEGMENTS),
        link="lid",
        material=material(spec.lid_colour),
        parent=body,
        parent_from_object=body_from_lid,
    )
    lid_collisions = [
        Collision(
            name="lid",
            geometry=Cylinder(radius_m=lid_radius, length_m=lid_t),
            link_from_collision=translation_transform((0, 0, lid_t / 2)),
        )
    ]
    if spec.knob_height_m > 0:
        knob_r, knob_h = spec.knob_diameter_m / 2, spec.knob_height_m
        add_object(
            "lid.knob",
            _revolve("lid.knob", np.array([(knob_r, lid_t), (knob_r, lid_t + knob_h)]), SEGMENTS // 2),
            link="lid",
            material=material(spec.lid_colour),
            parent=lid,
        )
        lid_collisions.append(
            Collision(
                name="knob",
                geometry=Cylinder(radius_m=knob_r, length_m=knob_h),
                link_from_collision=translation_transform((0, 0, lid_t + knob_h / 2)),
            )
        )
        frame = grasp_frame((0, 0, lid_t + knob_h / 2), (0, 0, -1), (1, 0, 0))
        lid_grasp = GraspPoint(name="lid_knob", link="lid", link_from_grasp=frame, kind="knob")
    else:
        lid_grasp = rim_grasp(lid_radius, lid_t / 2, link="lid", name="lid_rim")
    lift = Joint(
        name="lid_lift",
        type="prismatic",
        parent=ROOT_LINK,
        child="lid",
        parent_from_joint=body_from_lid,
        axis=np.array([0.0, 0.0, 1.0]),
        limits=JointLimits(lower=0.0, upper=LID_LIFT_M),
    )
    jar = assembly(
        spec,
        name,
        category=spec.category,
        collisions={ROOT_LINK: cup_wall_collisions(radius, wall, bottom, body_h), "lid": lid_collisions},
        joints=[lift],
        grasp_points=[side_grasp("body", body_h / 2), lid_grasp],
        affordances=["container"],
        properties={**colour_property(spec.colour), **contents_property(spec.contents)},
    )
    jar.link_masses_kg = {"lid": jar_lid_mass_kg(spec)}
    return jar
