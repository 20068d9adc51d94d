"""A worktop: one link `body`, the slab as boxes round its cut-outs (the same boxes are its
collision shapes, so a simulator's slab has the holes too), and a sink's basin, an open box
hanging in its cut-out. Its top is a supporting surface."""

from __future__ import annotations

import numpy as np

from articulation.model import Collision
from homemodel.core.transforms import translation_transform
from modeller.blender_scene import add_object, add_solidify, box_mesh, remove_faces
from modeller.blender_to_model import Assembly
from modeller.builders import FACE_NORMALS, wall_collisions
from modeller.builders.rigid import (
    ROOT_LINK,
    add_box_part,
    assembly,
    colour_property,
    material,
    surface_heights_property,
)
from modeller.specs.worktop import WorktopSpec

_BASIN_WALL_M = 0.001  # stainless steel sheet


def slab_boxes_m(spec: WorktopSpec) -> list[tuple[float, float, float, float]]:
    """(x_min, x_max, y_min, y_max) of boxes that tile the slab's footprint round its cut-outs:
    one strip per band between cut-out edges along y, split along x round the holes in it."""
    holes = [spec.cutout_box_m(cut) for cut in spec.cutouts]
    half_w, half_d = spec.width_m / 2, spec.depth_m / 2
    cuts_y = sorted({-half_w, half_w, *(y for h in holes for y in h[2:])})
    boxes = []
    for y0, y1 in zip(cuts_y, cuts_y[1:]):
        middle = (y0 + y1) / 2
        in_band = sorted((h[0], h[1]) for h in holes if h[2] < middle < h[3])
        x = -half_d
        for x0, x1 in [*in_band, (half_d, half_d)]:
            if x0 > x:
                boxes.append((x, x0, y0, y1))
            x = x1
    return boxes


def build_worktop(spec: WorktopSpec, name: str) -> Assembly:
    collisions: list[Collision] = []
    z = spec.height_m - spec.thickness_m / 2
    body = None
    for k, (x0, x1, y0, y1) in enumerate(slab_boxes_m(spec)):
        size, centre = (x1 - x0, y1 - y0, spec.thickness_m), ((x0 + x1) / 2, (y0 + y1) / 2, z)
        part = ROOT_LINK if body is None else f"body.slab_{k}"
        made = add_box_part(
            part, size, centre, colour=spec.colour, collisions=collisions, parent=body, collision_name=f"slab_{k}"
        )
        body = body or made
    for i, cut in enumerate(spec.cutouts):
        if cut.kind != "sink":
            continue
        x0, x1, y0, y1 = spec.cutout_box_m(cut)
        size = np.array([x1 - x0, y1 - y0, cut.basin_depth_m])
        centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2, spec.height_m - cut.basin_depth_m / 2])
        mesh = box_mesh(f"body.basin_{i}", size)
        remove_faces(mesh, [FACE_NORMALS["+z"]])
        basin = add_object(
            f"body.basin_{i}",
            mesh,
            link=ROOT_LINK,
            material=material(spec.basin_colour),
            parent=body,
            parent_from_object=translation_transform(centre),
        )
        add_solidify(basin, _BASIN_WALL_M)
        walls = ["+x", "-x", "+y", "-y", "-z"]
        collisions += wall_collisions(f"basin_{i}", size, centre, walls, _BASIN_WALL_M)
    return assembly(
        spec,
        name,
        category="worktop",
        collisions={ROOT_LINK: collisions},
        affordances=["supporting_surface"],
        properties={**colour_property(spec.colour), **surface_heights_property([spec.height_m])},
    )
