"""Mesh shapes the furniture and small-object builders need beyond `modeller.blender_scene`'s
primitives: extruded outlines (flat parts of cutlery, a remote's rounded body), a set of
equal cylinders in one mesh (buttons), and the outlines and profiles that feed them.

Outlines are (N, 2) arrays of (x, y) counter-clockwise seen from above; profiles are
(N, 2) arrays of (r, z) for `modeller.blender_scene._revolve`. Profile and outline helpers
are plain numpy, so specs and collision shapes can use them without Blender.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import bpy


def prism_mesh(
    name: str, outline_xy: np.ndarray, thickness_m: float, *, bottom_z_m: float = 0.0, rise: float = 0.0
) -> bpy.types.Mesh:
    """The convex or concave polygon `outline_xy` extruded up by `thickness_m` from `bottom_z_m`.

    With `rise` (metres per metre along x, from the outline's smallest x) the bottom climbs
    linearly along x, giving a ramp of the same vertical thickness throughout (a spoon's
    handle rising from the table to its bowl).
    """
    import bpy

    outline = np.asarray(outline_xy, dtype=np.float64)
    if outline.ndim != 2 or outline.shape[1] != 2 or len(outline) < 3:
        raise ValueError(f"{outline.shape=} but expected (N >= 3, 2)")
    n = len(outline)
    bottom = bottom_z_m + rise * (outline[:, 0] - outline[:, 0].min())
    verts = np.vstack([np.column_stack([outline, bottom]), np.column_stack([outline, bottom + thickness_m])])
    sides = [(i, (i + 1) % n, n + (i + 1) % n, n + i) for i in range(n)]  # outward for a CCW outline
    faces = [tuple(range(n - 1, -1, -1)), tuple(range(n, 2 * n)), *sides]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts.tolist(), [], faces)
    mesh.validate()
    return mesh


def cylinders_mesh(
    name: str, centres_m: Sequence[Sequence[float]], radius_m: float, height_m: float, *, segments: int = 16
) -> bpy.types.Mesh:
    """Closed upright cylinders in one mesh, each standing on its (x, y, z) centre of base."""
    import bmesh
    import bpy
    from mathutils import Matrix

    bm = bmesh.new()
    for x, y, z in centres_m:
        bmesh.ops.create_cone(
            bm,
            cap_ends=True,
            segments=segments,
            radius1=radius_m,
            radius2=radius_m,
            depth=height_m,
            matrix=Matrix.Translation((x, y, z + height_m / 2)),
        )
    mesh = bpy.data.meshes.new(name)
    bm.to_mesh(mesh)
    bm.free()
    return mesh


def rounded_rectangle_xy(
    size_x_m: float, size_y_m: float, radius_m: float, *, centre_x_m: float = 0.0, corner_segments: int = 6
) -> np.ndarray:
    """A rectangle centred on (centre_x_m, 0) with corners rounded to `radius_m`, counter-clockwise."""
    hx, hy = size_x_m / 2, size_y_m / 2
    radius = min(radius_m, hx, hy)
    points = []
    for (cx, cy), start in (((hx, hy), 0.0), ((-hx, hy), 90.0), ((-hx, -hy), 180.0), ((hx, -hy), 270.0)):
        angles = np.radians(start + np.linspace(0, 90, corner_segments + 1))
        corner = np.array([cx - np.sign(cx) * radius, cy - np.sign(cy) * radius])
        points.append(corner + radius * np.column_stack([np.cos(angles), np.sin(angles)]))
    outline = np.vstack(points)
    # A radius of half a side makes neighbouring corners meet: drop the repeated points.
    keep = np.linalg.norm(outline - np.roll(outline, 1, axis=0), axis=1) > 1e-12
    outline = outline[keep]
    outline[:, 0] += centre_x_m
    return outline


def tapered_outline_xy(x_start_m: float, x_end_m: float, width_start_m: float, width_end_m: float) -> np.ndarray:
    """A trapezoid along x, symmetric about y = 0, `width_start_m` wide at x_start_m."""
    hs, he = width_start_m / 2, width_end_m / 2
    return np.array([(x_start_m, -hs), (x_end_m, -he), (x_end_m, he), (x_start_m, hs)])


def round_tip_outline_xy(x_start_m: float, x_end_m: float, width_m: float, *, tip_segments: int = 12) -> np.ndarray:
    """A strip along x, `width_m` wide, ending at x_end_m in a half disc (a table knife's blade)."""
    r = width_m / 2
    angles = np.linspace(-np.pi / 2, np.pi / 2, tip_segments + 1)
    tip = np.column_stack([x_end_m - r + r * np.cos(angles), r * np.sin(angles)])
    return np.vstack([[(x_start_m, -r)], tip, [(x_start_m, r)]])


def quarter_ellipse_rz(start_rz: Sequence[float], end_rz: Sequence[float], points: int) -> np.ndarray:
    """A quarter ellipse from `start_rz` (horizontal there) to `end_rz` (vertical there), as a bowl's wall."""
    (r0, z0), (r1, z1) = start_rz, end_rz
    phi = np.linspace(0, np.pi / 2, points)
    return np.column_stack([r0 + (r1 - r0) * np.sin(phi), z1 - (z1 - z0) * np.cos(phi)])


def bowl_profile_rz(
    radius_m: float, height_m: float, foot_radius_m: float, wall_m: float, bottom_m: float, *, arc_points: int = 12
) -> tuple[np.ndarray, np.ndarray]:
    """(profile, outer wall) of a bowl: a flat foot, a wall curving up to a vertical rim.

    The outer surface is a quarter ellipse from the foot's edge to the rim; the inner one a
    quarter ellipse about the same centre, `bottom_m` above the outer at the middle and
    `wall_m` inside it at the rim.
    """
    outer = quarter_ellipse_rz((foot_radius_m, 0.0), (radius_m, height_m), arc_points)
    inner = quarter_ellipse_rz((foot_radius_m, bottom_m), (radius_m - wall_m, height_m), arc_points)
    return np.vstack([outer, inner[::-1]]), outer


def smooth_step_rz(start_rz: Sequence[float], end_rz: Sequence[float], points: int) -> np.ndarray:
    """A cosine blend from `start_rz` to `end_rz`, vertical at both ends (a bottle's shoulder)."""
    (r0, z0), (r1, z1) = start_rz, end_rz
    t = np.linspace(0, 1, points)
    return np.column_stack([r0 + (r1 - r0) * (1 - np.cos(np.pi * t)) / 2, z0 + (z1 - z0) * t])
