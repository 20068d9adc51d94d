"""A second independent check of `homemodel map observe` (issue 26's "Done when"), written apart
from the project's stand-ins (`real_piece_views`, `unseen_pieces`, `unseen_home_views`) and from
`tracking`: its furniture, tape readings, ray casting, noise, observation writer and scoring are
its own.

A kitchen the stand-ins do not have. Real pieces, made here of trimesh boxes and cylinders:
- a fridge-freezer: two thick doors one above the other (bins inside the upper one) over a
  freezer drawer, glass shelves inside (seen through);
- a tall larder: one full-height door on concealed hinges (read square, `open_at_90`), five
  shelves inside;
- a base unit with a drawer over a door, and above it a glass-fronted wall cabinet (the pane
  seen through to the glasses inside, or no reading);
- a cooker: a drop-down door with a dark window, a storage drawer, four control knobs each with
  a raised marker, turned to their own states;
- a sideboard with three doors on knobs, the middle one hung on a divider;
- a chest of four drawers with recessed grips cut into the fronts;
- clutter the map does not have (a kettle, a toaster, bottles, glasses); a cup, a bowl and a
  pill box the map has, moved between surfaces, onto a shelf inside the open larder, or gone.

The installer: every length read with a tape (about 1.2 mm off, to the mm), hinge lines by the
README's guide, written as specs and a `home.yaml` whose poses are 2-3.2 cm and 2-3 degrees
off; `homemodel build` makes the map.

Views: three camera set-ups (a Kinect v2's 512x424 with depth in 0.2 mm units, a RealSense's
848x480 in 0.1 mm units, an Azure Kinect's 640x576 with no colour image), the camera 0.8 m to
1.7 m up, 1.0 m to 3 m from a piece, at bearings up to 60 degrees; a person or a chair in
front; the issue's noise model, and flying pixels at depth edges for the time-of-flight ones.

    python tests/unseen_home2_views.py OUT [--views 28] [--seed 0]

builds the home in OUT, writes OUT/views/vNN/obs (the truth beside it), runs exactly
`homemodel map observe MAP.xml OBS_DIR --out NEW_MAP.xml --report REPORT.json` on each and
prints every fault and a tally (`score_view`).
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import subprocess
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import open3d as o3d
import trimesh
import yaml
from PIL import Image

from homemodel.geometry.camera import Camera

HOMEMODEL = Path(sys.executable).with_name("homemodel")
ROOM = (4.6, 3.6)  # x 0..4.6, y 0..3.6 m
DOOR_TOL, DRAWER_TOL, SMALL_TOL = math.radians(2.0), 0.005, 0.01
SAME_M = 0.002  # a written pose within this of the map's error is neither better nor worse
HALF = 0.5  # a part at least this visible should be written

# ------------------------------------------------------------------------------ solids


def cuboid(lo, hi) -> trimesh.Trimesh:
    return trimesh.creation.box(bounds=[lo, hi])


def bevelled(lo, hi, r: float) -> trimesh.Trimesh:
    """A front with its edges bevelled by `r`: the hull of the box shrunk along each axis in turn."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    pts = []
    for axis in range(3):
        a, b = lo + r, hi - r
        a[axis], b[axis] = lo[axis], hi[axis]
        pts.append(trimesh.bounds.corners([a, b]))
    return trimesh.Trimesh(np.concatenate(pts)).convex_hull


def rod(p, q, r: float, sections: int = 20) -> trimesh.Trimesh:
    return trimesh.creation.cylinder(radius=r, segment=np.array([p, q], float), sections=sections)


def frame_with_hole(lo, hi, hole_lo, hole_hi) -> list[trimesh.Trimesh]:
    """A slab (thin along x) with a rectangular hole in y-z: four boxes round it."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    (_, hy0, hz0), (_, hy1, hz1) = hole_lo, hole_hi
    return [cuboid((x0, y0, z0), (x1, hy0, z1)), cuboid((x0, hy1, z0), (x1, y1, z1)),
            cuboid((x0, hy0, z0), (x1, hy1, hz0)), cuboid((x0, hy0, hz1), (x1, hy1, z1))]


@dataclass
class Part:
    mesh: trimesh.Trimesh
    rgb: tuple
    finish: str = "matt"  # "dark": 8 % dropouts; "steel": 3 %; "glass": seen through or no reading


@dataclass
class Joint:
    """A real moving part: its parts shut, in its piece's frame, and its real axis."""

    name: str
    parts: list[Part]
    point: np.ndarray
    direction: np.ndarray
    revolute: bool
    limit: float
    kind: str = "door"  # "door", "drawer" or "knob"

    def motion(self, q: float) -> np.ndarray:
        """The part's move from shut to position q (rad about the axis, or m along it)."""
        if self.revolute:
            return trimesh.transformations.rotation_matrix(q, self.direction, self.point)
        return trimesh.transformations.translation_matrix(self.direction * q)


@dataclass
class Piece:
    id: str
    spec: dict | None  # None: clutter the map does not have
    body: list[Part]
    joints: list[Joint] = field(default_factory=list)
    surfaces: dict[str, float] = field(default_factory=dict)  # name -> height things stand on


def tape(rng, v: float, sd: float = 0.0012) -> float:
    return round(float(v + rng.normal(0, sd)), 3)


def half_mm(rng, v: float) -> float:
    return round(round(float(v + rng.normal(0, 0.0004)) * 2000) / 2000, 4)


def tilted(rng, d, deg: float = 0.25) -> np.ndarray:
    d = np.asarray(d, float)
    d = d + np.cross(rng.normal(0, math.radians(deg), 3), d)
    return d / np.linalg.norm(d)


def shell(w, d, h, t, z0, rgb, back=0.006) -> list[Part]:
    """Sides, top, bottom and back of a carcass from z0 to h, origin at its footprint centre."""
    x0, x1, y0, y1 = -d / 2, d / 2, -w / 2, w / 2
    boxes = [((x0, y0, z0), (x1, y0 + t, h)), ((x0, y1 - t, z0), (x1, y1, h)),
             ((x0, y0 + t, h - t), (x1, y1 - t, h)), ((x0, y0 + t, z0), (x1, y1 - t, z0 + t)),
             ((x0, y0 + t, z0 + t), (x0 + back, y1 - t, h - t))]
    return [Part(cuboid(a, b), rgb) for a, b in boxes]


def shelf(w, d, t, z, rgb, setback=0.02, finish="matt") -> Part:
    return Part(cuboid((-d / 2 + 0.006, -w / 2 + t, z - 0.018), (d / 2 - setback, w / 2 - t, z)), rgb, finish)


def bar(face_x, p, q, standoff=0.035, r=0.006, rgb=(0.72, 0.72, 0.74)) -> list[Part]:
    """A bar handle from p to q (y, z) on two posts."""
    a, b = np.array([face_x + standoff, *p]), np.array([face_x + standoff, *q])
    out = [Part(rod(a, b, r), rgb, "steel")]
    for s in (0.15, 0.85):
        c = a + (b - a) * s
        out.append(Part(cuboid((face_x, c[1] - 0.005, c[2] - 0.005), (c[0], c[1] + 0.005, c[2] + 0.005)), rgb, "steel"))
    return out


def knob(face_x, y, z, rgb=(0.6, 0.5, 0.35)) -> Part:
    return Part(trimesh.util.concatenate([rod((face_x, y, z), (face_x + 0.02, y, z), 0.007),
                                          trimesh.creation.icosphere(2, 0.014).apply_translation((face_x + 0.026, y, z))]), rgb)


def side_door(name, y0, y1, z0, z1, front_x, thick, hinge, axis_back, axis_in, parts_extra, limit_deg, rgb, rng,
              gap=0.002) -> Joint:
    """A door from y0 to y1 hung on `hinge` ("left": -y side), its axis `axis_back` behind its face
    and `axis_in` in from its hinge-side edge."""
    face = front_x + gap + thick
    slab = Part(bevelled((front_x + gap, y0, z0), (face, y1, z1), 0.002), rgb)
    y = y0 + axis_in if hinge == "left" else y1 - axis_in
    return Joint(f"{name}_hinge", [slab, *parts_extra], np.array([face - axis_back, y, z0]),
                 tilted(rng, (0, 0, -1) if hinge == "left" else (0, 0, 1)), True, math.radians(limit_deg))


def corner_readings(joint: Joint, corner, front_x, out_of) -> list[dict]:
    """`free_corner`: the free bottom corner at 50 and 85 degrees, forward from the front plane and
    out from the hinge side's outer face (`out_of(point)`), to the half mm."""
    rng = np.random.default_rng(int(abs(corner[1]) * 1e5))
    out = []
    for deg in (50.0, 85.0):
        p = trimesh.transform_points([corner], joint.motion(math.radians(deg)))[0]
        out.append({"forward_m": half_mm(rng, p[0] - front_x), "out_m": half_mm(rng, out_of(p))})
    return out


def drawer(name, y0, y1, z0, z1, d, thick, rgb, box_depth, travel, rng, grip=None, handle_parts=(), gap=0.002,
           finish="matt") -> Joint:
    """A drawer front on a box 15 mm inside it (12 mm walls); `grip`: a recessed pocket (length,
    width, depth) cut at the front's middle."""
    x0, face = d / 2 + gap, d / 2 + gap + thick
    if grip:
        ln, wd, dp = grip
        yc, zc = (y0 + y1) / 2, (z0 + z1) / 2
        hole = ((x0, yc - ln / 2, zc - wd / 2), (face, yc + ln / 2, zc + wd / 2))
        front = [Part(m, rgb, finish) for m in frame_with_hole((x0, y0, z0), (face, y1, z1), *hole)]
        front.append(Part(cuboid((x0, yc - ln / 2, zc - wd / 2), (face - dp, yc + ln / 2, zc + wd / 2)), rgb, finish))
    else:
        front = [Part(bevelled((x0, y0, z0), (face, y1, z1), 0.002), rgb, finish)]
    bx0, by0, by1, bz0, bz1 = d / 2 - box_depth, y0 + 0.015, y1 - 0.015, z0 + 0.015, z1 - 0.04
    pale = (0.82, 0.8, 0.74)
    walls = [((bx0, by0, bz0), (x0, by0 + 0.012, bz1)), ((bx0, by1 - 0.012, bz0), (x0, by1, bz1)),
             ((bx0, by0, bz0), (bx0 + 0.012, by1, bz1)), ((bx0, by0, bz0), (x0, by1, bz0 + 0.01))]
    return Joint(f"{name}_slide", [*front, *(Part(cuboid(a, b), pale) for a, b in walls), *handle_parts],
                 np.zeros(3), tilted(rng, (1, 0, 0), 0.3), False, travel, "drawer")


# ------------------------------------------------------------------------------ the pieces


def fridge(rng) -> Piece:
    w, d, h = rng.uniform(0.595, 0.6), rng.uniform(0.62, 0.65), rng.uniform(1.84, 1.86)
    t, g, thick = 0.04, 0.003, rng.uniform(0.055, 0.062)
    white = (0.94, 0.94, 0.95)
    z_drawer, z_div = rng.uniform(0.25, 0.27), rng.uniform(0.66, 0.7)
    body = shell(w, d, h, t, 0.0, white, back=0.04)
    body.append(shelf(w, d, t, z_div + 0.02, white, setback=0.0))  # the divider, to the front
    glass = [z_div + 0.33, z_div + 0.66]
    body += [shelf(w, d, t, z, (0.7, 0.8, 0.85), setback=0.12, finish="glass") for z in glass]
    face = d / 2 + g + thick
    y_free = -w / 2 + 0.04

    def hung(name, z0, z1, bins):
        back, inside = rng.uniform(0.02, 0.03), rng.uniform(0.01, 0.016)
        extra = bar(face, (y_free, z0 + 0.1), (y_free, min(z1 - 0.1, z0 + 0.5)), 0.04)
        for zb in bins:  # door bins on the inner face
            extra.append(Part(cuboid((d / 2 + g - 0.1, -w / 2 + 0.06, zb), (d / 2 + g, w / 2 - 0.06, zb + 0.08)), white))
        return side_door(name, -w / 2 + g, w / 2 - g, z0, z1, d / 2, thick, "right", back, inside, extra, 120, white,
                         rng, g)

    upper = hung("door_0", z_div + g, h - g, [z_div + 0.25, z_div + 0.6])
    lower = hung("door_1", z_drawer + g, z_div - g, [])
    drw = drawer("drawer_0", -w / 2 + g, w / 2 - g, g, z_drawer - g, d, thick, white, 0.45, 0.4, rng,
                 handle_parts=bar(face, (-0.15, z_drawer / 2), (0.15, z_drawer / 2), 0.04), gap=g)

    def door_spec(j, z0, z1, bins):
        top = min(z1 - 0.1, z0 + 0.5)  # the bar's upper end, as `hung` puts it
        corner = np.array([face, -w / 2 + g, z0])
        return {"hinge": "right", "left_m": g, "width_m": tape(rng, w - 2 * g), "bottom_m": tape(rng, z0),
                "height_m": tape(rng, z1 - z0), "opening_limit_deg": 120,
                "handle": {"length_m": round(top - z0 - 0.1, 3), "standoff_m": 0.04, "diameter_m": 0.012,
                           "from_free_edge_m": 0.037, "height_m": round((top - z0 + 0.1) / 2, 3)},
                "shelves": [{"height_m": tape(rng, zb - z0), "depth_m": 0.1, "lip_height_m": 0.08, "margin_m": 0.06}
                            for zb in bins],
                "hinge_measured": {"free_corner": corner_readings(j, corner, d / 2, lambda p: p[1] - w / 2)}}

    spec = {"kind": "fridge", "width_m": tape(rng, w), "depth_m": tape(rng, d), "height_m": tape(rng, h),
            "wall_thickness_m": t, "freezer_fraction": 0, "door_thickness_m": tape(rng, thick), "door_gap_m": g,
            "shelves": [{"height_m": tape(rng, z_div + 0.02)}, *({"height_m": tape(rng, z), "depth_m": tape(rng, d - t - 0.12)}
                                                                 for z in glass)],
            "doors": [door_spec(upper, z_div + g, h - g, [z_div + 0.25, z_div + 0.6]),
                      door_spec(lower, z_drawer + g, z_div - g, [])],
            "drawers": [{"left_m": g, "width_m": tape(rng, w - 2 * g), "bottom_m": g, "height_m": tape(rng, z_drawer - 2 * g),
                         "depth_m": 0.45, "travel_m": 0.4, "box_wall_m": 0.012,
                         "handle": {"length_m": 0.3, "standoff_m": 0.04}}],
            "colour": "white", "handle_colour": "grey"}
    return Piece("fridge", spec, body, [upper, lower, drw], {"top": h})


def larder(rng) -> Piece:
    w, d, h = rng.uniform(0.49, 0.51), rng.uniform(0.56, 0.58), rng.uniform(2.0, 2.05)
    t, plinth, thick = 0.018, rng.uniform(0.09, 0.11), 0.019
    ash, dark = (0.8, 0.72, 0.58), (0.2, 0.2, 0.2)
    body = shell(w, d, h, t, plinth, ash)
    body.append(Part(cuboid((-d / 2 + 0.02, -w / 2 + 0.005, 0), (d / 2 - 0.05, w / 2 - 0.005, plinth)), dark, "dark"))
    levels = [plinth + t + k * (h - plinth - 2 * t) / 6 for k in range(1, 6)]
    body += [shelf(w, d, t, z + 0.018, ash) for z in levels]
    z0, z1 = plinth + 0.002, h - 0.002
    back, inside = rng.uniform(0.028, 0.031), rng.uniform(0.004, 0.005)
    face = d / 2 + 0.002 + thick
    door = side_door("door_0", -w / 2 + 0.002, w / 2 - 0.002, z0, z1, d / 2, thick, "left", back, inside,
                     bar(face, (w / 2 - 0.05, 0.85), (w / 2 - 0.05, 1.25), 0.035), 110, ash, rng)
    # open square, at the door's bottom: its inner and outer faces, and its hinge-side edge
    inner, outer, edge = trimesh.transform_points(
        [(d / 2 + 0.002, w / 2 - 0.05, z0), (face, w / 2 - 0.05, z0), (d / 2 + 0.002, -w / 2 + 0.002, z0)], door.motion(math.pi / 2))
    spec = {"kind": "cupboard", "width_m": tape(rng, w), "depth_m": tape(rng, d), "height_m": tape(rng, h),
            "plinth_height_m": tape(rng, plinth), "plinth_recess_m": 0.05, "door_thickness_m": thick,
            "back_panel": {"thickness_m": 0.006},
            "shelves": [{"height_m": tape(rng, z + 0.018), "depth_m": tape(rng, d - t - 0.02)} for z in levels],
            "doors": [{"hinge": "left", "left_m": 0.002, "width_m": tape(rng, w - 0.004), "bottom_m": tape(rng, z0),
                       "height_m": tape(rng, z1 - z0), "opening_limit_deg": 110,
                       "handle": {"length_m": 0.4, "standoff_m": 0.035, "from_free_edge_m": 0.048, "height_m": tape(rng, 1.05 - z0)},
                       "hinge_measured": {"open_at_90": {"inner_face_out_m": half_mm(rng, -w / 2 - inner[1]),
                                                         "outer_face_out_m": half_mm(rng, -w / 2 - outer[1]),
                                                         "edge_forward_m": half_mm(rng, edge[0] - d / 2)}}}],
            "drawers": [], "colour": [0.8, 0.72, 0.58]}
    return Piece("larder", spec, body, [door], {f"shelf_{k}": z + 0.018 for k, z in enumerate(levels)} | {"top": h})


def base_unit(rng) -> Piece:
    w, d, h = rng.uniform(0.595, 0.605), rng.uniform(0.56, 0.58), rng.uniform(0.87, 0.89)
    t, plinth, thick = 0.018, rng.uniform(0.095, 0.105), 0.019
    blue, grey = (0.35, 0.45, 0.6), (0.85, 0.85, 0.82)
    body = shell(w, d, h, t, plinth, grey)
    body.append(Part(cuboid((-d / 2 + 0.02, -w / 2 + 0.005, 0), (d / 2 - 0.06, w / 2 - 0.005, plinth)), (0.25, 0.25, 0.25)))
    body.append(shelf(w, d, t, plinth + 0.32, grey))
    hd = rng.uniform(0.14, 0.16)
    zd = h - 0.002 - hd
    face = d / 2 + 0.002 + thick
    drw = drawer("drawer_0", -w / 2 + 0.002, w / 2 - 0.002, zd, h - 0.002, d, thick, blue, 0.45, 0.42, rng,
                 handle_parts=bar(face, (-0.08, zd + hd / 2), (0.08, zd + hd / 2)))
    z0, z1 = plinth + 0.002, zd - 0.003
    door = side_door("door_0", -w / 2 + 0.002, w / 2 - 0.002, z0, z1, d / 2, thick, "left", rng.uniform(0.029, 0.032),
                     rng.uniform(0.004, 0.005), bar(face, (w / 2 - 0.04, z1 - 0.2), (w / 2 - 0.04, z1 - 0.04)), 105, blue, rng)
    corner = np.array([face, w / 2 - 0.002, z0])
    spec = {"kind": "cupboard", "width_m": tape(rng, w), "depth_m": tape(rng, d), "height_m": tape(rng, h),
            "plinth_height_m": tape(rng, plinth), "plinth_recess_m": 0.06, "door_thickness_m": thick,
            "back_panel": {"thickness_m": 0.006},
            "shelves": [{"height_m": tape(rng, plinth + 0.32)}],
            "doors": [{"hinge": "left", "left_m": 0.002, "width_m": tape(rng, w - 0.004), "bottom_m": tape(rng, z0),
                       "height_m": tape(rng, z1 - z0), "opening_limit_deg": 105,
                       "handle": {"length_m": 0.16, "from_free_edge_m": 0.038, "height_m": tape(rng, z1 - z0 - 0.12)},
                       "hinge_measured": {"free_corner": corner_readings(door, corner, d / 2, lambda p: -w / 2 - p[1])}}],
            "drawers": [{"left_m": 0.002, "width_m": tape(rng, w - 0.004), "bottom_m": tape(rng, zd), "height_m": tape(rng, hd),
                         "depth_m": 0.45, "travel_m": 0.42, "box_wall_m": 0.012, "handle": {"length_m": 0.16}}],
            "colour": [0.35, 0.45, 0.6], "handle_colour": "silver"}
    return Piece("base_unit", spec, body, [drw, door], {"top": h})


KNOB_STATES = [["off", *map(str, range(1, 10))]] * 3 + [["off", "50", "100", "150", "200", "250"]]
KNOB_STEP = [30.0, 30.0, 30.0, 45.0]


def cooker(rng) -> Piece:
    w, d, h = 0.6, rng.uniform(0.595, 0.605), rng.uniform(0.895, 0.905)
    steel, black = (0.78, 0.78, 0.8), (0.08, 0.08, 0.09)
    g, thick = 0.003, rng.uniform(0.04, 0.045)
    body = shell(w, d, h - 0.006, 0.02, 0.0, steel)
    body.append(Part(cuboid((-d / 2, -w / 2, h - 0.006), (d / 2, w / 2, h)), black, "dark"))  # the glass hob
    panel_h, z_door, z_drawer = 0.1, 0.18, 0.16  # the door's lower edge swings down past its axis: clear of the drawer
    body.append(Part(cuboid((d / 2 - 0.02, -w / 2, h - 0.006 - panel_h), (d / 2, w / 2, h - 0.006)), steel, "steel"))
    body.append(Part(cuboid((-d / 2 + 0.03, -w / 2 + 0.03, z_door + 0.03), (d / 2 - 0.05, w / 2 - 0.03, z_door + 0.04)), black))
    knob_z = h - 0.006 - panel_h / 2
    knob_y = [-0.21, -0.09, 0.09, 0.21]
    knobs = []
    for k, y in enumerate(knob_y):
        x0 = d / 2
        cap = rod((x0, y, knob_z), (x0 + 0.025, y, knob_z), 0.02, 28)
        mark = cuboid((x0 + 0.025, y - 0.0025, knob_z + 0.004), (x0 + 0.027, y + 0.0025, knob_z + 0.018))
        knobs.append(Joint(f"knob_{k}_turn", [Part(cap, (0.15, 0.15, 0.15)), Part(mark, (0.95, 0.95, 0.95))],
                           np.array([x0, y, knob_z]), np.array([-1.0, 0, 0]), True,
                           math.radians(KNOB_STEP[k] * (len(KNOB_STATES[k]) - 1)), "knob"))
    z0, z1 = z_door + g, h - 0.006 - panel_h - g
    face = d / 2 + g + thick
    window = frame_with_hole((d / 2 + g, -w / 2 + g, z0), (face, w / 2 - g, z1),
                             (0, -w / 2 + 0.09, z0 + 0.09), (0, w / 2 - 0.09, z1 - 0.12))
    pane = Part(cuboid((face - 0.004, -w / 2 + 0.09, z0 + 0.09), (face - 0.001, w / 2 - 0.09, z1 - 0.12)), black, "glass")
    axis_up = rng.uniform(0.01, 0.014)
    door = Joint("door_0_hinge", [*(Part(m, steel, "steel") for m in window), pane,
                                  *bar(face, (-0.22, z1 - 0.04), (0.22, z1 - 0.04), 0.045, 0.008)],
                 np.array([face - thick / 2, 0.0, z0 + axis_up]), tilted(rng, (0, 1, 0)), True, math.radians(92))
    drw = drawer("drawer_0", -w / 2 + g, w / 2 - g, g, z_drawer - g, d, 0.02, steel, 0.45, 0.32, rng,
                 grip=(0.2, 0.03, 0.015), gap=g, finish="steel")
    spec = {"kind": "oven", "width_m": w, "depth_m": tape(rng, d), "height_m": tape(rng, h), "door_thickness_m": tape(rng, 0.02),
            "back_panel": {"thickness_m": 0.006},
            "colour": "silver", "handle_colour": "silver",
            "hob": {"thickness_m": 0.006, "burners": [{"from_left_m": 0.17, "from_front_m": 0.17, "diameter_m": 0.18},
                                                     {"from_left_m": 0.43, "from_front_m": 0.43, "diameter_m": 0.18}]},
            "panels": [{"left_m": 0, "width_m": w, "bottom_m": tape(rng, h - 0.006 - panel_h), "height_m": tape(rng, panel_h),
                        "thickness_m": 0.02}],
            "knobs": [{"left_m": tape(rng, y + w / 2), "height_m": tape(rng, knob_z), "diameter_m": 0.04, "projection_m": 0.025,
                       "states": KNOB_STATES[k], "step_deg": KNOB_STEP[k]} for k, y in enumerate(knob_y)],
            "doors": [{"hinge": "bottom", "left_m": g, "width_m": w - 2 * g, "bottom_m": tape(rng, z0), "height_m": tape(rng, z1 - z0),
                       "opening_limit_deg": 92, "window": {"margin_m": 0.09}, "thickness_m": tape(rng, thick),
                       "hinge_line": {"behind_face_m": tape(rng, thick / 2), "in_from_edge_m": tape(rng, axis_up)},
                       "handle": {"length_m": 0.44, "standoff_m": 0.045, "diameter_m": 0.016, "from_free_edge_m": 0.04}}],
            "drawers": [{"left_m": g, "width_m": w - 2 * g, "bottom_m": g, "height_m": tape(rng, z_drawer - 2 * g), "depth_m": 0.45,
                         "travel_m": 0.32, "handle": {"type": "recessed", "length_m": 0.2, "recess_depth_m": 0.015}}]}
    return Piece("cooker", spec, body, [door, drw, *knobs], {"top": h})


def glass_cabinet(rng, mount: float) -> Piece:
    w, d, h = rng.uniform(0.595, 0.605), rng.uniform(0.31, 0.33), rng.uniform(0.68, 0.72)
    t, thick = 0.018, 0.02
    cream = (0.9, 0.87, 0.78)
    body = [Part(p.mesh.copy().apply_translation((0, 0, mount)), p.rgb) for p in shell(w, d, h, t, 0.0, cream)]
    z_shelf = mount + h / 2
    body.append(shelf(w, d, t, z_shelf, cream))
    z0, z1 = mount + 0.002, mount + h - 0.002
    y0, y1 = -w / 2 + 0.002, w / 2 - 0.002
    face = d / 2 + 0.002 + thick
    m = 0.06
    stiles = [Part(p, cream) for p in frame_with_hole((d / 2 + 0.002, y0, z0), (face, y1, z1), (0, y0 + m, z0 + m), (0, y1 - m, z1 - m))]
    pane = Part(cuboid((face - 0.012, y0 + m, z0 + m), (face - 0.008, y1 - m, z1 - m)), (0.6, 0.7, 0.72), "glass")
    door = side_door("door_0", y0, y1, z0, z1, d / 2, thick, "right", rng.uniform(0.028, 0.031), rng.uniform(0.004, 0.005),
                     [pane, knob(face, y0 + 0.035, z0 + 0.06)], 100, cream, rng)
    door.parts[0] = stiles[0]
    door.parts[1:1] = stiles[1:]
    corner = np.array([face, y0, z0])
    spec = {"kind": "wall_cabinet", "width_m": tape(rng, w), "depth_m": tape(rng, d), "height_m": tape(rng, h),
            "mount_height_m": tape(rng, mount), "door_thickness_m": thick, "shelves": [{"height_m": tape(rng, z_shelf)}],
            "back_panel": {"thickness_m": 0.006},
            "doors": [{"hinge": "right", "left_m": 0.002, "width_m": tape(rng, w - 0.004), "bottom_m": tape(rng, z0),
                       "height_m": tape(rng, z1 - z0), "opening_limit_deg": 100, "window": {"margin_m": m},
                       "handle": {"type": "knob", "from_free_edge_m": 0.035, "height_m": 0.06},
                       "hinge_measured": {"free_corner": corner_readings(door, corner, d / 2, lambda p: p[1] - w / 2)}}],
            "colour": [0.9, 0.87, 0.78]}
    return Piece("glass_cabinet", spec, body, [door], {"shelf": z_shelf, "top": mount + h})


def sideboard(rng) -> Piece:
    w, d, h = rng.uniform(1.45, 1.55), rng.uniform(0.44, 0.46), rng.uniform(0.78, 0.82)
    t, plinth, thick = 0.018, rng.uniform(0.07, 0.09), 0.019
    teak = (0.55, 0.35, 0.2)
    body = shell(w, d, h, t, plinth, teak)
    body.append(Part(cuboid((-d / 2 + 0.02, -w / 2 + 0.01, 0), (d / 2 - 0.04, w / 2 - 0.01, plinth)), (0.15, 0.1, 0.07), "dark"))
    third = (w - 2 * t) / 3
    div = [-w / 2 + t + third, -w / 2 + t + 2 * third]  # the dividers' left faces - t/2
    body += [Part(cuboid((-d / 2, y - t / 2, plinth + t), (d / 2, y + t / 2, h - t)), teak) for y in div]
    z0, z1 = plinth + 0.002, h - 0.002
    face = d / 2 + 0.002 + thick
    # the middle door hangs on the right divider on pivot hinges (its axis 12 mm behind its face and
    # 4 mm in from its edge: its inner face swings clear of the divider), 16 mm clear of its
    # neighbour, which its hinge-side edge passes
    edges = [(-w / 2 + 0.002, div[0] - 0.0015), (div[0] + 0.0015, div[1] - 0.008), (div[1] + 0.008, w / 2 - 0.002)]
    hinges = ["left", "right", "right"]
    doors, specs = [], []
    for k, ((y0, y1), hinge) in enumerate(zip(edges, hinges)):
        back, inside = rng.uniform(0.028, 0.031), rng.uniform(0.004, 0.006)
        if k == 1:
            back, inside = rng.uniform(0.0115, 0.0125), rng.uniform(0.0035, 0.0045)
        free_y = y1 - 0.04 if hinge == "left" else y0 + 0.04
        limit = 90 if k == 1 else 105  # the pivot's stop: further, the middle door would strike its neighbour
        j = side_door(f"door_{k}", y0, y1, z0, z1, d / 2, thick, hinge, back, inside, [knob(face, free_y, z1 - 0.1)], limit, teak, rng)
        doors.append(j)
        s = {"hinge": hinge, "left_m": tape(rng, y0 + w / 2), "width_m": tape(rng, y1 - y0), "bottom_m": tape(rng, z0),
             "height_m": tape(rng, z1 - z0), "opening_limit_deg": limit,
             "handle": {"type": "knob", "from_free_edge_m": 0.04, "height_m": tape(rng, z1 - z0 - 0.1)}}
        if k == 1:  # hung on the right divider: the installer reads the hinge hardware
            s["hinge_line"] = {"behind_face_m": tape(rng, back, 0.001), "in_from_edge_m": tape(rng, inside, 0.001)}
        else:  # cup hinges on the sides: the installer names them and the modeller places the line
            s["hinge_type"] = "concealed"
        specs.append(s)
    spec = {"kind": "cupboard", "width_m": tape(rng, w), "depth_m": tape(rng, d), "height_m": tape(rng, h),
            "plinth_height_m": tape(rng, plinth), "plinth_recess_m": 0.04, "door_thickness_m": thick,
            "back_panel": {"thickness_m": 0.006},
            "dividers": [{"left_m": tape(rng, y - t / 2 + w / 2)} for y in div],
            "doors": specs, "drawers": [], "colour": [0.55, 0.35, 0.2], "handle_colour": [0.6, 0.5, 0.35]}
    return Piece("sideboard", spec, body, doors, {"top": h})


def chest(rng) -> Piece:
    w, d, h = rng.uniform(0.88, 0.92), rng.uniform(0.48, 0.5), rng.uniform(0.98, 1.02)
    t, plinth, thick = 0.018, rng.uniform(0.055, 0.065), 0.02
    white = (0.93, 0.93, 0.9)
    body = shell(w, d, h, t, plinth, white)
    body.append(Part(cuboid((-d / 2 + 0.02, -w / 2 + 0.01, 0), (d / 2 - 0.03, w / 2 - 0.01, plinth)), white))
    n, gap = 4, 0.003
    hd = (h - plinth - (n + 1) * gap) / n
    joints, specs = [], []
    for k in range(n):
        z0 = plinth + gap + k * (hd + gap)
        joints.append(drawer(f"drawer_{k}", -w / 2 + 0.002, w / 2 - 0.002, z0, z0 + hd, d, thick, white, 0.42, 0.38, rng,
                             grip=(0.16, 0.035, 0.016)))
        specs.append({"left_m": 0.002, "width_m": tape(rng, w - 0.004), "bottom_m": tape(rng, z0), "height_m": tape(rng, hd),
                      "depth_m": 0.42, "travel_m": 0.38, "box_wall_m": 0.012,
                      "handle": {"type": "recessed", "length_m": 0.16, "recess_width_m": 0.035, "recess_depth_m": 0.016}})
    spec = {"kind": "cupboard", "width_m": tape(rng, w), "depth_m": tape(rng, d), "height_m": tape(rng, h),
            "plinth_height_m": tape(rng, plinth), "plinth_recess_m": 0.03, "door_thickness_m": thick, "doors": [],
            "back_panel": {"thickness_m": 0.006},
            "drawers": specs, "colour": "white"}
    return Piece("chest", spec, body, joints, {"top": h})


def cup(rng) -> Piece:
    r, hh = rng.uniform(0.04, 0.043), rng.uniform(0.08, 0.09)
    red = (0.8, 0.15, 0.12)
    wall = trimesh.creation.annulus(r_min=r - 0.0035, r_max=r, height=hh - 0.006).apply_translation((0, 0, 0.006 + (hh - 0.006) / 2))
    base = rod((0, 0, 0), (0, 0, 0.006), r, 32)
    handle = cuboid((r - 0.002, -0.005, hh * 0.3), (r + 0.022, 0.005, hh * 0.8))
    spec = {"kind": "cup", "height_m": tape(rng, hh), "outer_diameter_m": tape(rng, 2 * r), "wall_thickness_m": 0.0035,
            "bottom_thickness_m": 0.006, "handle": {"height_m": tape(rng, hh * 0.5), "span_m": 0.022, "thickness_m": 0.01},
            "colour": [0.8, 0.15, 0.12]}
    return Piece("cup", spec, [Part(trimesh.util.concatenate([wall, base, handle]), red)])


def bowl(rng) -> Piece:
    dia, hh = rng.uniform(0.15, 0.16), rng.uniform(0.065, 0.07)
    profile = [(0, 0), (0.036, 0), (0.036, 0.006), (dia / 2, hh), (dia / 2 - 0.004, hh), (0.034, 0.01), (0, 0.01)]
    mesh = trimesh.creation.revolve(np.array(profile), sections=48)
    spec = {"kind": "bowl", "diameter_m": tape(rng, dia), "height_m": tape(rng, hh), "foot_diameter_m": 0.072,
            "wall_thickness_m": 0.004, "bottom_thickness_m": 0.006, "colour": [0.3, 0.5, 0.8]}
    return Piece("bowl", spec, [Part(mesh, (0.3, 0.5, 0.8))])


def pill_box(rng) -> Piece:
    w, d, hh = rng.uniform(0.155, 0.165), rng.uniform(0.044, 0.048), rng.uniform(0.027, 0.03)
    spec = {"kind": "pill_box", "width_m": tape(rng, w), "depth_m": tape(rng, d), "height_m": tape(rng, hh),
            "wall_thickness_m": 0.0015, "lid_thickness_m": 0.003, "compartments": 7, "colour": "blue", "lid_colour": "white"}
    return Piece("pill_box", spec, [Part(cuboid((-d / 2, -w / 2, 0), (d / 2, w / 2, hh - 0.003)), (0.2, 0.3, 0.8)),
                                    Part(cuboid((-d / 2, -w / 2, hh - 0.003), (d / 2, w / 2, hh)), (0.95, 0.95, 0.95))])


def clutter() -> dict[str, list[Part]]:
    """Things the map does not have, in their own frames (origin under their middle)."""
    kettle = [Part(rod((0, 0, 0), (0, 0, 0.22), 0.08, 32), (0.9, 0.9, 0.9)),
              Part(cuboid((-0.11, -0.015, 0.05), (-0.08, 0.015, 0.2)), (0.2, 0.2, 0.2))]
    toaster = [Part(cuboid((-0.09, -0.14, 0), (0.09, 0.14, 0.2)), (0.75, 0.1, 0.1), "steel")]
    bottles = [Part(trimesh.util.concatenate([rod((0, y, 0), (0, y, 0.22), 0.038), rod((0, y, 0.22), (0, y, 0.3), 0.015)]),
                    (0.1, 0.4, 0.15), "glass" if y else "matt") for y in (-0.05, 0.05)]
    glasses = [Part(trimesh.creation.annulus(0.03, 0.035, 0.1).apply_translation((0, y, 0.05)), (0.8, 0.85, 0.9), "glass")
               for y in (-0.12, 0.0, 0.12)]
    return {"kettle": kettle, "toaster": toaster, "bottles": bottles, "glasses": glasses}


# ------------------------------------------------------------------------------ the home


def pose(x, y, z, yaw_deg) -> np.ndarray:
    m = trimesh.transformations.rotation_matrix(math.radians(yaw_deg), (0, 0, 1))
    m[:3, 3] = (x, y, z)
    return m


@dataclass
class Home:
    pieces: dict[str, Piece]
    truth: dict[str, np.ndarray]  # large pieces' real poses
    installer: dict[str, np.ndarray]  # as home.yaml places them
    small: dict[str, tuple[str, np.ndarray]]  # the map's small objects: parent, parent_from_object
    clutter: list[tuple[list[Part], np.ndarray]]  # (parts, map_from_thing)


def make_home(seed: int = 0) -> Home:
    rng = np.random.default_rng([seed, 26, 2])
    pieces = {p.id: p for p in (fridge(rng), larder(rng), base_unit(rng), cooker(rng), sideboard(rng), chest(rng),
                                cup(rng), bowl(rng), pill_box(rng))}
    pieces["glass_cabinet"] = glass_cabinet(rng, rng.uniform(1.45, 1.5))
    off = lambda: rng.uniform(0.005, 0.025)  # noqa: E731  off the wall
    tilt = lambda: rng.uniform(-0.6, 0.6)  # noqa: E731
    depth = {pid: p.spec["depth_m"] for pid, p in pieces.items() if p.spec and "depth_m" in p.spec and pid not in
             ("cup", "bowl", "pill_box")}
    truth = {"fridge": pose(depth["fridge"] / 2 + off(), 0.42, 0, tilt()),
             "larder": pose(depth["larder"] / 2 + off(), 0.98, 0, tilt()),
             "base_unit": pose(depth["base_unit"] / 2 + off(), 1.54, 0, tilt()),
             "cooker": pose(depth["cooker"] / 2 + off(), 2.16, 0, tilt()),
             "glass_cabinet": pose(depth["glass_cabinet"] / 2 + 0.002, 1.545, 0, tilt() / 3),
             "sideboard": pose(1.75, depth["sideboard"] / 2 + off(), 0, 90 + tilt()),
             "chest": pose(3.35, depth["chest"] / 2 + off(), 0, 90 + tilt())}
    installer = {}
    for pid, t in truth.items():
        shift, turn, a = rng.uniform(0.02, 0.032), rng.uniform(2.0, 3.0) * rng.choice([-1, 1]), rng.uniform(0, 2 * math.pi)
        installer[pid] = t @ pose(shift * math.cos(a), shift * math.sin(a), 0, turn)
    tops = {pid: pieces[pid].surfaces["top"] for pid in truth}
    small = {"cup": ("base_unit", pose(0.06, 0.1, tops["base_unit"], 40)),
             "bowl": ("sideboard", pose(0.02, -0.35, tops["sideboard"], 0)),
             "pill_box": ("chest", pose(0.05, 0.25, tops["chest"], 15))}
    things = clutter()
    placed = [(things["kettle"], truth["base_unit"] @ pose(-0.1, -0.15, tops["base_unit"], 20)),
              (things["toaster"], truth["cooker"] @ pose(-0.12, 0.05, tops["cooker"], 0)),
              (things["bottles"], truth["sideboard"] @ pose(-0.05, 0.4, tops["sideboard"], 0)),
              (things["glasses"], truth["glass_cabinet"] @ pose(-0.02, 0.0, pieces["glass_cabinet"].surfaces["shelf"], 0))]
    return Home(pieces, truth, installer, small, placed)


def _xyz_rpy(m) -> dict:
    return {"xyz": [round(float(v), 4) for v in m[:3, 3]], "rpy_deg": [0, 0, round(math.degrees(math.atan2(m[1, 0], m[0, 0])), 3)]}


def _read_again(spec: dict) -> dict:
    """A front the tape put past its body's side or top is read again: kept 1 mm inside it (the
    modeller refuses a front off its body)."""
    spec = json.loads(json.dumps(spec))
    if "width_m" not in spec or "height_m" not in spec or spec["kind"] in ("cup", "bowl", "pill_box"):
        return spec
    top = spec["height_m"] + spec.get("mount_height_m", 0.0)
    fronts = spec.get("doors", []) + spec.get("drawers", [])
    for front in fronts:
        front["width_m"] = round(min(front["width_m"], spec["width_m"] - 0.001 - front["left_m"]), 4)
        front["height_m"] = round(min(front["height_m"], top - 0.001 - front["bottom_m"]), 4)
    for low in fronts:  # and a front read into the one above it is kept 1 mm under it
        for high in fronts:
            side_by_side = low["left_m"] + low["width_m"] <= high["left_m"] or high["left_m"] + high["width_m"] <= low["left_m"]
            if high is not low and not side_by_side and low["bottom_m"] < high["bottom_m"] < low["bottom_m"] + low["height_m"] + 0.001:
                low["height_m"] = round(high["bottom_m"] - 0.001 - low["bottom_m"], 4)
    return spec


def write_specs(home: Home, folder: Path) -> Path:
    """The installer's folder: a spec per piece (small ones too) and `home.yaml`, each large piece
    placed where the installer put it by eye, a parking place 1 m in front, the small ones on it."""
    folder.mkdir(parents=True, exist_ok=True)
    for pid in [*home.installer, *home.small]:
        (folder / f"{pid}.yaml").write_text(yaml.safe_dump(_read_again(home.pieces[pid].spec), sort_keys=False))

    def entry(oid: str, m: np.ndarray, **more) -> dict:
        return {"id": oid, "spec": f"{oid}.yaml", "pose": _xyz_rpy(m), **more}

    objects = []
    for pid, m in home.installer.items():
        parking = [{"name": "front", "xy": [round(float(v), 3) for v in m[:2, 3] + m[:2, 0]], "yaw_deg": 0}]
        on_it = [entry(sid, p, relation="on") for sid, (parent, p) in home.small.items() if parent == pid]
        objects.append(entry(pid, m, parking=parking, **({"objects": on_it} if on_it else {})))
    outline = [[0.0, 0.0], [ROOM[0], 0.0], [ROOM[0], ROOM[1]], [0.0, ROOM[1]]]
    (folder / "home.yaml").write_text(yaml.safe_dump(
        {"apartment": {"id": "home2", "name": "Kitchen"},
         "rooms": [{"id": "kitchen", "name": "Kitchen", "outline": outline, "objects": objects}]}, sort_keys=False))
    return folder


def build_map(home: Home, folder: Path) -> Path:
    specs = write_specs(home, folder / "specs")
    out = folder / "built"
    if not (out / "built.ok").exists():  # a build the gate refused leaves a map too
        done = subprocess.run([str(HOMEMODEL), "build", str(specs), "--out", str(out)], capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(done.stdout[-2000:] + done.stderr[-2000:])
        (out / "built.ok").touch()
    return out / "map.xml"


# ------------------------------------------------------------------------------ views


@dataclass
class Setup:
    name: str
    lens: Camera  # the intrinsics and depth units camera.yaml gives
    colour: bool  # a color.png beside the depth
    tof: bool  # flying pixels at depth edges


SETUPS = [Setup("kinect_v2", Camera(width=512, height=424, fx=365.5, fy=365.5, cx=257.3, cy=205.1, depth_scale_m=0.0002), True, True),
          Setup("realsense_848", Camera(width=848, height=480, fx=421.6, fy=421.3, cx=424.9, cy=240.6, depth_scale_m=0.0001), True, False),
          Setup("azure_nfov", Camera(width=640, height=576, fx=504.2, fy=504.4, cx=321.1, cy=334.7, depth_scale_m=0.001), False, True)]


@dataclass
class View:
    name: str
    setup: Setup
    map_from_camera: np.ndarray
    joints: dict[str, float]  # "piece/joint" -> real position
    small: dict[str, tuple[str, np.ndarray] | None]  # None: gone from the home
    occluder: str | None
    target: str
    seed: int
    past_limit: str | None = None


def look_from(eye, at, roll_deg) -> np.ndarray:
    z = np.asarray(at, float) - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, (0, 0, 1.0))
    x /= np.linalg.norm(x)
    m = np.eye(4)
    m[:3, :3] = np.stack([x, np.cross(z, x), z], 1) @ trimesh.transformations.rotation_matrix(math.radians(roll_deg), (0, 0, 1))[:3, :3]
    m[:3, 3] = eye
    return m


TARGETS = ["fridge", "larder", "base_unit", "cooker", "sideboard", "chest", "glass_cabinet"]
STATES = {"shut": (0.0, 0.0), "ajar": (0.04, 0.1), "half": (0.35, 0.6), "full": (0.8, 1.0)}


def _clear_of_furniture(home: Home, xy, margin=0.2) -> bool:
    for pid, t in home.truth.items():
        spec = home.pieces[pid].spec
        local = np.linalg.inv(t) @ np.array([xy[0], xy[1], 0, 1])
        if abs(local[0]) < spec["depth_m"] / 2 + margin + 0.1 and abs(local[1]) < spec["width_m"] / 2 + margin:
            return False
    return 0.25 < xy[0] < ROOM[0] - 0.25 and 0.25 < xy[1] < ROOM[1] - 0.25


def random_view(home: Home, index: int, rng) -> View:
    target = TARGETS[index % len(TARGETS)]
    t = home.truth[target]
    piece = home.pieces[target]
    lo, hi = trimesh.util.concatenate([p.mesh for p in piece.body]).bounds
    centre = t @ np.append((lo + hi) / 2, 1)
    height = {1: 0.8, 3: 1.7}.get(index % 5, None)
    for _ in range(400):
        dist = {0: 1.0, 2: rng.uniform(2.5, 3.0)}.get(index % 4, rng.uniform(1.2, 2.5))
        bear = rng.uniform(50, 60) * rng.choice([-1, 1]) if index % 6 == 5 else rng.uniform(-35, 35)
        b = math.radians(bear)
        eye = centre[:3] + (t[:3, 0] * math.cos(b) + t[:3, 1] * math.sin(b)) * dist
        eye[2] = height or rng.uniform(1.0, 1.5)
        look_z = rng.uniform(1.5, 1.8) if target == "glass_cabinet" else rng.uniform(0.3, min(1.3, hi[2] * 0.7))
        if _clear_of_furniture(home, eye[:2]):
            break
    else:
        raise RuntimeError(f"v{index:02d}: no camera place clear of the furniture")
    joints = {}
    for pid, p in home.pieces.items():
        for j in p.joints:
            if j.kind == "knob":
                k = int(j.name.split("_")[1])
                joints[f"{pid}/{j.name}"] = math.radians(KNOB_STEP[k] * int(rng.integers(len(KNOB_STATES[k]))))
            else:
                state = ["shut", "ajar", "half", "full"][int(rng.integers(4))]
                joints[f"{pid}/{j.name}"] = float(rng.uniform(*STATES[state]) * j.limit)
    past = None
    if index % 7 == 6:  # a door opened past its limit (a hinge let out, a door pushed hard)
        past = ["larder/door_0_hinge", "base_unit/door_0_hinge", "fridge/door_0_hinge"][index // 7 % 3]
        pid, jn = past.split("/")
        limit = next(j.limit for j in home.pieces[pid].joints if j.name == jn)
        joints[past] = limit + math.radians(rng.uniform(6, 10))
    small: dict = dict(home.small)
    if index % 3 == 1:  # the cup onto a shelf in the open larder, or onto the sideboard
        if joints["larder/door_0_hinge"] > math.radians(70):
            k = int(rng.integers(1, 4))
            small["cup"] = ("larder", pose(rng.uniform(-0.05, 0.1), rng.uniform(-0.1, 0.1),
                                           home.pieces["larder"].surfaces[f"shelf_{k}"], rng.uniform(-180, 180)))
        else:
            small["cup"] = ("sideboard", pose(rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.2),
                                              home.pieces["sideboard"].surfaces["top"], rng.uniform(-180, 180)))
        small["pill_box"] = ("chest", pose(rng.uniform(-0.1, 0.1), rng.uniform(-0.3, 0.0), home.pieces["chest"].surfaces["top"],
                                           rng.uniform(-30, 30)))
    elif index % 3 == 2:  # the bowl taken away, the pill box onto the base unit
        small["bowl"] = None
        small["pill_box"] = ("base_unit", pose(rng.uniform(0.0, 0.1), rng.uniform(0.05, 0.2), home.pieces["base_unit"].surfaces["top"],
                                               rng.uniform(-90, 90)))
    occluder = [None, "person", None, "chair"][index % 4]
    m = look_from(eye, (centre[0], centre[1], look_z), rng.uniform(-2, 2))
    return View(f"v{index:02d}", SETUPS[index % 3], m, joints, small, occluder, target, int(rng.integers(1 << 30)), past)


def views_of(home: Home, count: int, seed: int) -> list[View]:
    rng = np.random.default_rng([seed, 2026])
    return [random_view(home, i, rng) for i in range(count)]


# ------------------------------------------------------------------------------ rendering


def _room_meshes() -> list[trimesh.Trimesh]:
    X, Y = ROOM
    return [cuboid((-1, -1, -0.05), (X + 1, Y + 1, 0)), cuboid((-0.1, -0.1, 0), (0, Y + 0.1, 2.6)),
            cuboid((X, -0.1, 0), (X + 0.1, Y + 0.1, 2.6)), cuboid((-0.1, -0.1, 0), (X + 0.1, 0, 2.6)),
            cuboid((-0.1, Y, 0), (X + 0.1, Y + 0.1, 2.6))]


def _occluder(view: View, home: Home, rng) -> list[trimesh.Trimesh]:
    eye = view.map_from_camera[:3, 3]
    at = home.truth[view.target][:3, 3]
    p = eye + (at - eye) * rng.uniform(0.35, 0.55)
    side = np.cross(at - eye, (0, 0, 1))
    p = p + side / np.linalg.norm(side) * rng.uniform(0.05, 0.35) * rng.choice([-1, 1])
    x, y = p[0], p[1]
    if view.occluder == "person":  # a tall box and a head
        return [cuboid((x - 0.12, y - 0.2, 0), (x + 0.12, y + 0.2, 1.62)),
                trimesh.creation.icosphere(2, 0.1).apply_translation((x, y, 1.72))]
    legs = [cuboid((x + a - 0.02, y + b - 0.02, 0), (x + a + 0.02, y + b + 0.02, 0.44)) for a in (-0.19, 0.19) for b in (-0.19, 0.19)]
    return [*legs, cuboid((x - 0.21, y - 0.21, 0.44), (x + 0.21, y + 0.21, 0.48)), cuboid((x - 0.21, y + 0.17, 0.48), (x + 0.21, y + 0.21, 0.9))]


def _posed(home: Home, view: View) -> list[tuple[str, str | None, Part, np.ndarray]]:
    """(object, joint or None, part, map_from_part) for everything that is really there."""
    out = [("clutter", None, p, m) for parts, m in home.clutter for p in parts]
    for pid, piece in home.pieces.items():
        placed = view.small.get(pid, (None, None)) if pid in home.small else (None, home.truth[pid])
        if placed is None:  # a small object gone from the home
            continue
        m = placed[1] if placed[0] is None else home.truth[placed[0]] @ placed[1]
        moves = [(None, np.eye(4), piece.body)] + [(j.name, j.motion(view.joints[f"{pid}/{j.name}"]), j.parts) for j in piece.joints]
        out += [(pid, name, p, m @ move) for name, move, parts in moves for p in parts]
    return out


def _rays(s: Camera, m: np.ndarray, step: int = 1, margin: float = 0.0) -> np.ndarray:
    du = step * math.ceil(margin * s.width / step)
    dv = step * math.ceil(margin * s.height / step)
    u, v = np.meshgrid(np.arange(-du, s.width + du, step), np.arange(-dv, s.height + dv, step))
    d = np.stack([(u - s.cx) / s.fx, (v - s.cy) / s.fy, np.ones(u.shape)], -1).reshape(-1, 3) @ m[:3, :3].T
    return np.concatenate([np.broadcast_to(m[:3, 3], d.shape), d], 1).astype(np.float32)


def _cast(meshes, rays):
    scene = o3d.t.geometry.RaycastingScene()
    for mesh in meshes:
        scene.add_triangles(o3d.core.Tensor(np.asarray(mesh.vertices, np.float32)), o3d.core.Tensor(np.asarray(mesh.faces, np.uint32)))
    hit = scene.cast_rays(o3d.core.Tensor(rays))
    return hit["t_hit"].numpy(), hit["geometry_ids"].numpy().astype(np.int64), hit["primitive_normals"].numpy()


@dataclass
class Rendered:
    depth_m: np.ndarray
    rgb: np.ndarray
    visible: dict[str, float]
    small_visible: dict[str, float]


def render(home: Home, view: View, visibility: bool = True) -> Rendered:
    rng = np.random.default_rng(view.seed)
    posed = _posed(home, view)
    meshes = [p.mesh.copy().apply_transform(m) for _, _, p, m in posed]
    extra = _occluder(view, home, rng) if view.occluder else []
    everything = meshes + _room_meshes() + extra
    finish = np.array([p.finish for _, _, p, _ in posed] + ["matt"] * (len(everything) - len(posed)))
    rgb_of = np.array([p.rgb for _, _, p, _ in posed] + [(0.6, 0.55, 0.5)] + [(0.92, 0.9, 0.85)] * 4 + [(0.3, 0.3, 0.55)] * len(extra))
    s = view.setup.lens
    rays = _rays(s, view.map_from_camera)
    t, ids, normals = _cast(everything, rays)
    hit = np.isfinite(t)
    fin = np.where(hit, finish[np.minimum(ids, len(finish) - 1)], "none")
    glass = fin == "glass"
    if glass.any():  # the pane: seen through to what is behind (55 %) or no reading
        clear = [m for m, f in zip(everything, finish) if f != "glass"]
        tb, ib, nb = _cast(clear, rays[glass])
        through = rng.random(glass.sum()) < 0.55
        t[glass] = np.where(through, tb, np.inf)
        normals[glass] = nb
    d = rays[:, 3:]
    cos = np.abs(np.sum(normals * d, 1)) / np.linalg.norm(d, axis=1)
    ok = np.isfinite(t) & (cos > math.cos(math.radians(75)))
    z = np.where(ok, t, 0.0)
    z = np.where(ok, z + rng.normal(0, 1, z.shape) * (0.0012 + 0.0019 * (z - 0.4) ** 2), 0.0)
    z = np.round(z / 0.001) * 0.001
    drop = rng.random(z.shape) < np.select([fin == "dark", fin == "steel"], [0.08, 0.03], 0.01)
    z[drop | ~ok] = 0.0
    z = z.reshape(s.height, s.width)
    if view.setup.tof:  # flying pixels: where depth jumps by over 5 cm, a third of the edge pixels read in between
        zz = z.copy()
        jump = np.zeros_like(z, bool)
        jump[:, 1:] |= (np.abs(np.diff(zz, axis=1)) > 0.05) & (zz[:, 1:] > 0) & (zz[:, :-1] > 0)
        pick = jump & (rng.random(z.shape) < 0.33)
        left = np.roll(zz, 1, axis=1)
        mix = rng.uniform(0.2, 0.8, z.shape)
        z[pick] = np.round((zz * mix + left * (1 - mix))[pick] / 0.001) * 0.001
    shade = 0.35 + 0.65 * np.clip(cos, 0, 1)
    rgb = np.where(hit[:, None], rgb_of[np.minimum(ids, len(rgb_of) - 1)] * shade[:, None], 0.0)
    vis, svis = _visibility(posed, meshes, ids, view) if visibility else ({}, {})
    return Rendered(z, (np.clip(rgb, 0, 1) * 255).astype(np.uint8).reshape(s.height, s.width, 3), vis, svis)


def _visibility(posed, meshes, ids, view: View) -> tuple[dict, dict]:
    """Each moving part's (and small object's) share seen: its pixels in the view over its pixels
    alone on the image plane widened by the image's size each side (the image's edge is cover);
    every 4th pixel."""
    s = view.setup.lens
    grid = np.zeros((s.height, s.width), bool)
    grid[::4, ::4] = True
    ids_grid = ids[grid.ravel()]
    wide = _rays(s, view.map_from_camera, step=4, margin=1.0)
    groups: dict = {}
    for k, (pid, joint, _, _) in enumerate(posed):
        if pid == "clutter":
            continue
        if joint is not None or pid in view.small:
            groups.setdefault((pid, joint), []).append(k)
    vis, svis = {}, {}
    for (pid, joint), members in groups.items():
        own = np.isfinite(_cast([meshes[k] for k in members], wide)[0]).sum()
        share = float(np.isin(ids_grid, members).sum() / own) if own else 0.0
        if joint is None:
            svis[pid] = share
        else:
            vis[f"{pid}/{joint}"] = share
    return vis, svis


def write_observation(folder: Path, view: View, r: Rendered, home: Home) -> None:
    obs = folder / "obs"
    obs.mkdir(parents=True, exist_ok=True)
    s = view.setup.lens
    counts = np.round(r.depth_m / s.depth_scale_m)
    counts[counts > 65535] = 0  # past the format's range: no reading, as a driver gives
    Image.fromarray(counts.astype(np.uint16)).save(obs / "depth.png")
    if view.setup.colour:
        Image.fromarray(r.rgb).save(obs / "color.png")
    cam = {"width": s.width, "height": s.height, "fx": s.fx, "fy": s.fy, "cx": s.cx, "cy": s.cy, "depth_scale_m": s.depth_scale_m,
           "map_from_camera": [[float(v) for v in row] for row in view.map_from_camera]}
    (obs / "camera.yaml").write_text(yaml.safe_dump(cam))
    truth = {"setup": view.setup.name, "occluder": view.occluder, "target": view.target, "past_limit": view.past_limit,
             "joints": view.joints, "visible": r.visible, "small_visible": r.small_visible,
             "poses": {pid: m.tolist() for pid, m in home.truth.items()},
             "small": {sid: None if v is None else {"parent": v[0], "map_from_object": (home.truth[v[0]] @ v[1]).tolist()}
                       for sid, v in view.small.items()}}
    (folder / "truth.json").write_text(json.dumps(truth, indent=1))


# ------------------------------------------------------------------------------ observe and score


def observe(map_path: Path, obs: Path, out: Path) -> subprocess.CompletedProcess:
    """Exactly the issue's command line, one process per view."""
    return subprocess.run([str(HOMEMODEL), "map", "observe", str(map_path), str(obs), "--out", str(out / "new_map.xml"),
                           "--report", str(out / "report.json")], capture_output=True, text=True)


def read_map(path: Path) -> dict:
    """{"large": {id: (map_from_object, {joint: position}, limits)}, "small": {id: (parent, parent_from_object)}}."""
    def matrix(el) -> np.ndarray:
        m = trimesh.transformations.euler_matrix(*(float(v) for v in el.get("rpy").split()), "sxyz")
        m[:3, 3] = [float(v) for v in el.get("xyz").split()]
        return m

    large, small = {}, {}
    for el in ET.parse(path).getroot().iter():
        tag = el.tag.rsplit("}", 1)[-1]
        if tag in ("largeObject", "largeArticulatedObject"):
            joints, limits = {}, {}
            for j in el:
                if j.tag.endswith("}joint"):
                    joints[j.get("name")] = float(j.get("position"))
                    lim = [c for c in j if c.tag.endswith("}limits")]
                    limits[j.get("name")] = float(lim[0].get("upper")) if lim and lim[0].get("upper") else math.inf
            large[el.get("id")] = (matrix(el), joints, limits)
        elif tag == "smallObject":
            small[el.get("id")] = (el.get("parent"), matrix(el))
    return {"large": large, "small": small}


def _yaw(m) -> float:
    return math.degrees(math.atan2(m[1, 0], m[0, 0]))


def _pose_error(m: np.ndarray, truth: np.ndarray) -> tuple[float, float, float, float]:
    """A map pose's origin off the true one: on the floor (m), along the piece's own front (+x)
    and left (+y), and its turn (degrees)."""
    fwd, side = (np.linalg.inv(truth) @ np.append(m[:3, 3], 1.0))[:2]
    return float(math.hypot(fwd, side)), float(fwd), float(side), abs((_yaw(m) - _yaw(truth) + 180) % 360 - 180)


def score_view(prior: dict, new: dict, truth: dict) -> dict:
    joints = []
    for pid, (_, positions, limits) in prior["large"].items():
        for jn, old in positions.items():
            key = f"{pid}/{jn}"
            written = new["large"][pid][1][jn]
            q = truth["joints"][key]
            tol = DRAWER_TOL if jn.endswith("_slide") else DOOR_TOL
            # past its limit the best the map can hold is the limit
            target = min(q, limits[jn])
            changed = not math.isclose(old, written, abs_tol=1e-9)
            right = abs(written - target) <= tol
            vis = truth["visible"].get(key, 0.0)
            cls = ("written right" if right else "WRITTEN WRONG") if changed else (
                "kept, right" if abs(old - target) <= tol else ("missed" if vis >= HALF else "rightly not written"))
            joints.append({"joint": key, "truth": round(q, 4), "written": round(written, 4), "visible": round(vis, 3),
                           "class": cls, "error": round(written - target, 4), "past_limit": key == truth.get("past_limit")})
    poses = []
    for pid, t in truth["poses"].items():
        before, after = prior["large"][pid][0], new["large"][pid][0]
        row = {"object": pid, "class": "kept"}
        if not np.allclose(before, after, atol=1e-7):
            was, now = _pose_error(before, np.asarray(t)), _pose_error(after, np.asarray(t))
            row["class"] = "better" if now[0] < was[0] - SAME_M else ("WORSE" if now[0] > was[0] + SAME_M else "same")
            row |= {"map_mm": round(was[0] * 1000, 1), "written_mm": round(now[0] * 1000, 1),
                    "map_fwd_side_mm": [round(v * 1000, 1) for v in was[1:3]],
                    "written_fwd_side_mm": [round(v * 1000, 1) for v in now[1:3]],
                    "map_deg": round(was[3], 2), "written_deg": round(now[3], 2)}
        poses.append(row)
    small = []
    for sid, s in truth["small"].items():
        parent, m = new["small"][sid]
        before_parent, before = prior["small"][sid]
        moved = parent != before_parent or not np.allclose(m, before, atol=1e-7)
        vis = truth["small_visible"].get(sid, 0.0)
        if s is None:  # gone: nothing may be written for it
            small.append({"object": sid, "class": "WRITTEN WRONG" if moved else "gone, kept", "visible": 0.0, "parent": parent})
            continue
        at = new["large"][parent][0] @ m
        e = float(np.linalg.norm(at[:3, 3] - np.asarray(s["map_from_object"])[:3, 3]))
        fine = e <= SMALL_TOL and parent == s["parent"]
        cls = ("found right" if fine else "WRITTEN WRONG") if moved else (
            "kept, right" if fine else ("missed" if vis >= HALF else "rightly not written"))
        small.append({"object": sid, "class": cls, "error_mm": round(e * 1000, 1), "visible": round(vis, 2),
                      "parent": parent, "true_parent": s["parent"]})
    return {"joints": joints, "poses": poses, "small": small}


def unchanged_elsewhere(prior_path: Path, new_path: Path) -> list[str]:
    """What the new map changed besides joint positions, large poses, small objects and history
    (the model paths compared as the files they name)."""
    def flat(path: Path) -> dict:
        out = {}

        def walk(el, where: str) -> None:
            tag = el.tag.rsplit("}", 1)[-1]
            if tag in ("history", "smallObject"):
                return
            here = f"{where}/{tag}:{el.get('id') or el.get('name') or ''}"
            attrs = dict(el.attrib)
            if tag == "joint":
                attrs.pop("position", None)
            if tag in ("largeObject", "largeArticulatedObject"):
                attrs.pop("xyz", None)
                attrs.pop("rpy", None)
            if "model" in attrs:
                attrs["model"] = str((path.parent / attrs["model"]).resolve())
            key = here
            while key in out:
                key += "+"
            out[key] = (attrs, (el.text or "").strip())
            for child in el:
                walk(child, here)

        walk(ET.parse(path).getroot(), "")
        return out

    a, b = flat(prior_path), flat(new_path)
    return [f"{k}: {a.get(k)} -> {b.get(k)}" for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)]


def check_view(map_path: Path, home: Home, view: View, folder: Path, run=observe, visibility: bool = True) -> dict:
    write_observation(folder, view, render(home, view, visibility), home)
    result = folder / "result"
    result.mkdir(exist_ok=True)
    done = run(map_path, folder / "obs", result)
    if done.returncode != 0:
        raise RuntimeError(f"{folder.name}: exit {done.returncode}: {(done.stderr or '').strip()[-300:]}")
    return rescore(map_path, folder)


def rescore(map_path: Path, folder: Path) -> dict:
    """Score a view already observed (`folder/result`) against its truth: what was written, each
    joint's and small object's status in the report, and anything else the new map changed."""
    result = folder / "result"
    truth = json.loads((folder / "truth.json").read_text())
    scored = score_view(read_map(map_path), read_map(result / "new_map.xml"), truth)
    report = json.loads((result / "report.json").read_text())
    status = {f"{o['id']}/{j['name']}": j["status"] for o in report.get("objects", []) for j in o.get("joints", [])}
    small_status = {s["id"]: s["status"] for o in report.get("objects", []) for s in o.get("small_objects", [])}
    for row in scored["joints"]:
        row["status"] = status.get(row["joint"], "(not listed)")
    for row in scored["small"]:
        row["status"] = small_status.get(row["object"], "(not listed)")
    scored["other_changes"] = unchanged_elsewhere(map_path, result / "new_map.xml")
    (result / "score.json").write_text(json.dumps(scored, indent=1))
    return scored


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--views", type=int, default=28)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--only", type=int, nargs="*", help="these view indices alone")
    parser.add_argument("--rescore", action="store_true", help="score the views already observed again, run nothing")
    args = parser.parse_args()
    home = make_home(args.seed)
    map_path = build_map(home, args.out)
    tally: dict = {"joints": {}, "poses": {}, "small": {}}
    cpu = []
    for view in views_of(home, args.views, args.seed):
        if args.only and int(view.name[1:]) not in args.only:
            continue
        if args.rescore:
            scored = rescore(map_path, args.out / "views" / view.name)
        else:
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            scored = check_view(map_path, home, view, args.out / "views" / view.name)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
        for what in ("joints", "poses", "small"):
            for row in scored[what]:
                tally[what][row["class"]] = tally[what].get(row["class"], 0) + 1
                if row["class"] in ("WRITTEN WRONG", "WORSE", "missed"):
                    print(f"{view.name} {view.setup.name} {view.occluder or '-'} {what}: {json.dumps(row)}", flush=True)
        for line in scored["other_changes"]:
            print(f"{view.name} OTHER CHANGE: {line}", flush=True)
    print(json.dumps(tally, indent=1))
    if cpu:
        print(f"map observe, CPU s a view (its process): median {np.median(cpu):.2f}, max {max(cpu):.2f}")


if __name__ == "__main__":
    main()
