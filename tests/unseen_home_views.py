"""An independent check of `homemodel map observe` (issue 26's "Done when"), written apart from
the project's own stand-in (`real_piece_views`, `unseen_pieces`) and from `tracking`: none of
their furniture, makers, renderer, noise or observation writer is used.

A bedroom and a utility corner stand in one room. Real pieces, made here of trimesh solids:
- a wardrobe whose two doors meet in the middle, on concealed hinges, bar handles, a recessed
  plinth, clothes hanging inside;
- a chest of four graduated drawers, dark fronts (more dropouts), two knobs a drawer, a top
  slab overhanging the carcass (read into the spec's `top_overhang`);
- a bedside table on four legs (read into the spec's `legs`, the plinth's height theirs), a drawer
  over a right-hinged door;
- a front-loading washing machine, its round door with a glass porthole (the sensor sees
  through it or not at all) on a hinge off the door's rim;
- a dishwasher beside it, its door hinged at the bottom (a flap);
- a worktop over both with a rounded front edge, a microwave on it (a dark window: more
  dropouts), and above it a wall cupboard whose lift-up flap is hinged at the top; a mug and
  a plate.

The installer's side: each piece measured with a tape (`mm`: a few millimetres off), the
hinge lines read at the free corner as the README's guide says, written as specs and a
`home.yaml` whose poses are 2-3 cm and 1.5-3 degrees off; `homemodel build` makes the map.

Views: a robot's head camera 1.0-1.5 m up, looking 10-30 degrees down, rolled up to 2
degrees, 1.2-2.5 m from a piece, in two camera set-ups (an Xtion-like 640x480 with its own
intrinsics and depth units of 0.25 mm; a 512x424 time-of-flight-sized image); every joint of
the room drawn shut, ajar, half or fully open; the issue's noise model; a person or a chair
standing in front in some views. Each view's depth and colour are ray-cast here with Open3D.

    python tests/unseen_home_views.py OUT [--views 24] [--seed 0]

builds the home in OUT, writes OUT/views/vNN/obs (and the truth beside it), runs exactly
`homemodel map observe MAP.xml OBS_DIR --out NEW_MAP.xml --report REPORT.json` on each and
prints, per view and in all, how the written joints, poses and small objects compare with the
truth (`score_view`).
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

HOMEMODEL = Path(sys.executable).with_name("homemodel")
ROOM_XY = (5.0, 4.0)  # the room's outline: x 0..5, y 0..4 m
WALL_H = 2.6
DOOR_TOL_RAD, DRAWER_TOL_M = math.radians(2.0), 0.005
SMALL_TOL_M = 0.01
POSE_SAME_M = 0.002  # a written pose within this of the map's error is neither better nor worse

# ------------------------------------------------------------------------------ solids


def box(x0: float, x1: float, y0: float, y1: float, z0: float, z1: float) -> trimesh.Trimesh:
    return trimesh.creation.box(bounds=[[x0, y0, z0], [x1, y1, z1]])


def rounded_box(x0: float, x1: float, y0: float, y1: float, z0: float, z1: float, r: float) -> trimesh.Trimesh:
    """A box with every edge rounded by `r`: the hull of spheres at the shrunk box's corners."""
    ball = trimesh.creation.icosphere(subdivisions=2, radius=r)
    corners = [(x, y, z) for x in (x0 + r, x1 - r) for y in (y0 + r, y1 - r) for z in (z0 + r, z1 - r)]
    return trimesh.Trimesh(np.concatenate([ball.vertices + c for c in corners])).convex_hull


def cylinder(radius: float, a: np.ndarray, b: np.ndarray, sections: int = 32) -> trimesh.Trimesh:
    return trimesh.creation.cylinder(radius=radius, segment=np.array([a, b], dtype=float), sections=sections)


def ring(r_out: float, r_in: float, a: np.ndarray, b: np.ndarray) -> trimesh.Trimesh:
    """A tube between points a and b (a washing machine's door rim, its drum)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    mesh = trimesh.creation.annulus(r_min=r_in, r_max=r_out, height=float(np.linalg.norm(b - a)), sections=48)
    align = trimesh.geometry.align_vectors([0, 0, 1], (b - a) / np.linalg.norm(b - a))
    align[:3, 3] = (a + b) / 2
    return mesh.apply_transform(align)


def holed_panel(x0: float, x1: float, y0: float, y1: float, z0: float, z1: float, centre_yz, radius: float):
    """A panel in the y-z plane with a round hole, extruded along x."""
    from shapely.geometry import Point, box as sbox

    shape = sbox(y0, z0, y1, z1).difference(Point(centre_yz).buffer(radius, 48))
    mesh = trimesh.creation.extrude_polygon(shape, height=x1 - x0)  # in (y, z, x)
    swap = np.array([[0, 0, 1, x0], [1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 1]], dtype=float)
    return mesh.apply_transform(swap)


# ------------------------------------------------------------------------------ pieces


@dataclass
class Solid:
    mesh: trimesh.Trimesh
    rgb: tuple[float, float, float]
    material: str = "matt"  # "dark": more dropouts; "glass": seen through or no reading


@dataclass
class Mover:
    """A moving part: its solids shut, in the object's frame, and its real motion."""

    link: str
    joint: str
    solids: list[Solid]
    axis_point: np.ndarray
    axis_dir: np.ndarray  # a door turns about it by +q (opening); a drawer slides along it
    revolute: bool
    limit: float

    def motion(self, q: float) -> np.ndarray:
        if self.revolute:
            return trimesh.transformations.rotation_matrix(q, self.axis_dir, self.axis_point)
        move = np.eye(4)
        move[:3, 3] = self.axis_dir * q
        return move


@dataclass
class Piece:
    """A real piece: its fixed solids and movers in its own frame (origin on the floor at the
    footprint's centre, +x out of the front), and the spec an installer writes for it."""

    id: str
    spec: dict
    body: list[Solid]
    movers: list[Mover] = field(default_factory=list)
    top_z: float = 0.0  # the surface small objects stand on


def _tape(rng: np.random.Generator, value: float, sd: float = 0.0012) -> float:
    """A tape's reading of a real length: a millimetre or so off, to the millimetre."""
    return round(round((value + rng.normal(0.0, sd)) * 1000) / 1000, 3)


def _axis_tilt(rng: np.random.Generator, direction, deg: float = 0.3) -> np.ndarray:
    d = np.asarray(direction, float)
    tilt = rng.normal(0.0, np.radians(deg), 3)
    d = d + np.cross(tilt, d)
    return d / np.linalg.norm(d)


def _free_corner(mover: Mover, corner: np.ndarray, front_x: float, side: str, side_at: float, rng) -> list[dict]:
    """The README's `free_corner` readings of a real door: its free corner opened about half
    way and nearly fully, `forward_m` from the carcass front plane, `out_m` from the hinge
    side's outer face, each read to the half millimetre."""
    readings = []
    for deg in (48.0, 87.0):
        p = trimesh.transform_points([corner], mover.motion(np.radians(deg)))[0]
        out = {"left": side_at - p[1], "right": p[1] - side_at, "top": p[2] - side_at}[side]
        half_mm = lambda v: round(round((v + rng.normal(0.0, 0.0004)) * 2000) / 2000, 4)  # noqa: E731
        readings.append({"forward_m": half_mm(p[0] - front_x), "out_m": half_mm(out)})
    return readings


def _side_door(rng, link: str, hinge: str, y0: float, y1: float, z0: float, z1: float, front_x: float,
               thick: float, rgb, extra: list[Solid], limit_deg: float) -> Mover:
    """A door on concealed hinges: its axis 31-33 mm behind its outer face, 4-5 mm in from its
    hinge-side edge, tilted by a few tenths of a degree."""
    face = front_x + 0.002 + thick
    slab = Solid(rounded_box(front_x + 0.002, face, y0, y1, z0, z1, 0.003), rgb)
    behind, inside = rng.uniform(0.031, 0.033), rng.uniform(0.004, 0.005)
    y = y0 + inside if hinge == "left" else y1 - inside
    direction = _axis_tilt(rng, (0, 0, -1) if hinge == "left" else (0, 0, 1))
    return Mover(link, f"{link}_hinge", [slab, *extra], np.array([face - behind, y, z0]), direction, True,
                 np.radians(limit_deg))


def _bar(x_face: float, y: float, z0: float, z1: float, standoff: float, rgb=(0.7, 0.7, 0.72)) -> list[Solid]:
    """A vertical bar handle on two posts."""
    bar = cylinder(0.007, [x_face + standoff, y, z0], [x_face + standoff, y, z1], 16)
    posts = [box(x_face, x_face + standoff, y - 0.005, y + 0.005, z - 0.005, z + 0.005) for z in (z0 + 0.02, z1 - 0.02)]
    return [Solid(bar, rgb), *(Solid(p, rgb) for p in posts)]


def _knob(x_face: float, y: float, z: float, rgb=(0.75, 0.65, 0.4)) -> Solid:
    stem = cylinder(0.006, [x_face, y, z], [x_face + 0.018, y, z], 16)
    cap = trimesh.creation.icosphere(subdivisions=2, radius=0.015).apply_translation([x_face + 0.022, y, z])
    return Solid(trimesh.util.concatenate([stem, cap]), rgb)


def _carcass(w: float, d: float, h: float, t: float, bottom: float, rgb, back: float = 0.008) -> list[Solid]:
    """Sides, top, bottom and a back panel of a carcass standing on `bottom` (a plinth's top)."""
    x0, x1, y0, y1 = -d / 2, d / 2, -w / 2, w / 2
    parts = [box(x0, x1, y0, y0 + t, bottom, h), box(x0, x1, y1 - t, y1, bottom, h),
             box(x0, x1, y0 + t, y1 - t, h - t, h), box(x0, x1, y0 + t, y1 - t, bottom, bottom + t),
             box(x0, x0 + back, y0 + t, y1 - t, bottom + t, h - t)]
    return [Solid(p, rgb) for p in parts]


def wardrobe(rng: np.random.Generator) -> Piece:
    w, d, h = rng.uniform(0.98, 1.06), rng.uniform(0.57, 0.6), rng.uniform(1.98, 2.05)
    t, plinth, recess, thick = 0.018, rng.uniform(0.07, 0.09), 0.05, 0.019
    oak, cloth = (0.72, 0.56, 0.36), (0.25, 0.27, 0.35)
    body = _carcass(w, d, h, t, plinth, oak)
    body += [Solid(box(-d / 2 + 0.02, d / 2 - recess, -w / 2 + 0.01, w / 2 - 0.01, 0.0, plinth), (0.2, 0.2, 0.2)),
             Solid(box(-d / 2 + 0.01, d / 2 - 0.03, -w / 2 + t, w / 2 - t, h - 0.28, h - 0.28 + t), oak),
             Solid(cylinder(0.012, [0.0, -w / 2 + t, h - 0.36], [0.0, w / 2 - t, h - 0.36]), (0.8, 0.8, 0.8))]
    for k, y in enumerate(np.linspace(-w / 2 + 0.08, w / 2 - 0.12, 7)):  # clothes on hangers
        low = h - rng.uniform(1.0, 1.3)
        body.append(Solid(box(-0.22, 0.22 - 0.02 * (k % 2), y, y + 0.05, low, h - 0.38), cloth))
    gap, z0, z1 = 0.003, plinth + 0.002, h - 0.002
    handle_z = (z0 + 1.0 - 0.16, z0 + 1.0 + 0.16)
    left = _side_door(rng, "door_0", "left", -w / 2 + 0.002, -gap / 2, z0, z1, d / 2, thick, oak,
                      _bar(d / 2 + 0.002 + thick, -gap / 2 - 0.05, *handle_z, 0.038), 105)
    right = _side_door(rng, "door_1", "right", gap / 2, w / 2 - 0.002, z0, z1, d / 2, thick, oak,
                       _bar(d / 2 + 0.002 + thick, gap / 2 + 0.05, *handle_z, 0.038), 105)
    doors = []
    for mover, hinge in ((left, "left"), (right, "right")):
        y0, y1 = (-w / 2 + 0.002, -gap / 2) if hinge == "left" else (gap / 2, w / 2 - 0.002)
        corner = np.array([d / 2 + 0.002 + thick, y1 if hinge == "left" else y0, z0])
        doors.append({"hinge": hinge, "left_m": _tape(rng, y0 + w / 2), "width_m": _tape(rng, y1 - y0),
                      "bottom_m": _tape(rng, z0), "height_m": _tape(rng, z1 - z0), "opening_limit_deg": 105,
                      "handle": {"length_m": 0.32, "diameter_m": 0.014, "standoff_m": 0.038,
                                 "from_free_edge_m": 0.05, "height_m": 1.0},
                      "hinge_measured": {"free_corner": _free_corner(mover, corner, d / 2, hinge,
                                                                     -w / 2 if hinge == "left" else w / 2, rng)}})
    spec = {"kind": "wardrobe", "width_m": _tape(rng, w), "depth_m": _tape(rng, d), "height_m": _tape(rng, h),
            "plinth_height_m": _tape(rng, plinth), "door_thickness_m": thick, "doors": doors, "drawers": [],
            "shelves": [{"height_m": _tape(rng, h - 0.28 + t)}], "rails": [{"height_m": _tape(rng, h - 0.36)}],
            "colour": "oak", "handle_colour": "silver"}
    return Piece("wardrobe", spec, body, [left, right], top_z=h)


def _drawer(rng, link: str, y0: float, y1: float, z0: float, z1: float, d: float, rgb, material: str,
            knobs_y: list[float], travel: float, box_depth: float = 0.4) -> Mover:
    """A drawer front (rounded edges) on a box 2 cm inside it, 12 mm walls, knobs on the front."""
    face = d / 2 + 0.002 + 0.019
    front = Solid(rounded_box(d / 2 + 0.002, face, y0, y1, z0, z1, 0.003), rgb, material)
    box_h = (z1 - z0) - 0.05
    bx0, by0, by1, bz0 = d / 2 - box_depth, y0 + 0.02, y1 - 0.02, z0 + 0.02
    walls = [box(bx0, d / 2 + 0.002, by0, by0 + 0.012, bz0, bz0 + box_h), box(bx0, d / 2 + 0.002, by1 - 0.012, by1, bz0, bz0 + box_h),
             box(bx0, bx0 + 0.012, by0, by1, bz0, bz0 + box_h), box(bx0, d / 2 + 0.002, by0, by1, bz0, bz0 + 0.01)]
    solids = [front, *(Solid(m, (0.8, 0.75, 0.65)) for m in walls), *(_knob(face, y, (z0 + z1) / 2) for y in knobs_y)]
    return Mover(link, f"{link}_slide", solids, np.zeros(3), _axis_tilt(rng, (1, 0, 0), 0.4), False, travel)


def chest(rng: np.random.Generator, slab_tape: np.random.Generator) -> Piece:
    """`slab_tape` reads the top slab (a generator of its own: the other readings and views stay
    as they were before the spec had a field for it)."""
    w, d, carcass_h = rng.uniform(0.78, 0.84), rng.uniform(0.44, 0.47), rng.uniform(0.82, 0.86)
    t, plinth, top = 0.018, rng.uniform(0.05, 0.07), 0.022
    front_out, sides_out = 0.025, 0.015  # the slab past the carcass' front and sides; flush at the back
    walnut, front_rgb = (0.38, 0.25, 0.16), (0.16, 0.11, 0.08)
    body = _carcass(w, d, carcass_h, t, plinth, walnut)
    body += [Solid(box(-d / 2 + 0.02, d / 2 - 0.03, -w / 2 + 0.01, w / 2 - 0.01, 0.0, plinth), walnut),
             Solid(rounded_box(-d / 2, d / 2 + front_out, -w / 2 - sides_out, w / 2 + sides_out, carcass_h,
                               carcass_h + top, 0.006), walnut)]
    heights = np.array([0.215, 0.2, 0.185, 0.17])
    heights *= (carcass_h - plinth - 5 * 0.003) / heights.sum()
    movers, drawers, z = [], [], plinth + 0.003
    for i, hgt in enumerate(heights):
        y0, y1 = -w / 2 + 0.002, w / 2 - 0.002
        movers.append(_drawer(rng, f"drawer_{i}", y0, y1, z, z + hgt, d, front_rgb, "dark", [-w / 4, w / 4], 0.35))
        drawers.append({"left_m": _tape(rng, y0 + w / 2), "width_m": _tape(rng, y1 - y0), "bottom_m": _tape(rng, z),
                        "height_m": _tape(rng, hgt), "depth_m": 0.4, "travel_m": 0.35, "box_wall_m": 0.012,
                        "box_height_m": _tape(rng, hgt - 0.05), "handle": {"type": "none"}})
        z += hgt + 0.003
    h = carcass_h + top
    spec = {"kind": "cupboard", "width_m": _tape(rng, w), "depth_m": _tape(rng, d), "height_m": _tape(rng, h),
            "plinth_height_m": _tape(rng, plinth), "plinth_recess_m": 0.03, "doors": [], "drawers": drawers,
            "colour": [0.38, 0.25, 0.16]}
    # The README's guide: a straight edge along the carcass' front and each side, the tape from it
    # to the slab's edge; the slab's thickness at its edge.
    spec["top_thickness_m"] = _tape(slab_tape, top)
    spec["top_overhang"] = {"front_m": _tape(slab_tape, front_out), "sides_m": _tape(slab_tape, sides_out)}
    return Piece("chest", spec, body, movers, top_z=h)


def bedside(rng: np.random.Generator, leg_tape: np.random.Generator) -> Piece:
    w, d, h = rng.uniform(0.44, 0.48), rng.uniform(0.37, 0.40), rng.uniform(0.58, 0.62)
    t, legs = 0.018, rng.uniform(0.1, 0.13)
    white = (0.9, 0.9, 0.88)
    body = _carcass(w, d, h, t, legs, white)
    body += [Solid(box(x - 0.0175, x + 0.0175, y - 0.0175, y + 0.0175, 0.0, legs), (0.55, 0.4, 0.25))
             for x in (-d / 2 + 0.03, d / 2 - 0.03) for y in (-w / 2 + 0.03, w / 2 - 0.03)]
    drawer_h = rng.uniform(0.12, 0.14)
    zd = h - 0.002 - drawer_h
    drawer = _drawer(rng, "drawer_0", -w / 2 + 0.002, w / 2 - 0.002, zd, h - 0.002, d, white, "matt", [0.0], 0.28, 0.3)
    z0, z1 = legs + 0.002, zd - 0.003
    door = _side_door(rng, "door_0", "right", -w / 2 + 0.002, w / 2 - 0.002, z0, z1, d / 2, 0.019, white,
                      [_knob(d / 2 + 0.021, -w / 2 + 0.04, z1 - 0.05)], 110)
    corner = np.array([d / 2 + 0.021, -w / 2 + 0.002, z0])
    spec = {"kind": "cupboard", "width_m": _tape(rng, w), "depth_m": _tape(rng, d), "height_m": _tape(rng, h),
            "plinth_height_m": _tape(rng, legs), "door_thickness_m": 0.019,
            "legs": {"size_m": _tape(leg_tape, 0.035), "inset_m": _tape(leg_tape, 0.0125)},
            "doors": [{"hinge": "right", "left_m": 0.002, "width_m": _tape(rng, w - 0.004), "bottom_m": _tape(rng, z0),
                       "height_m": _tape(rng, z1 - z0), "opening_limit_deg": 110,
                       "handle": {"type": "knob", "from_free_edge_m": 0.04, "height_m": _tape(rng, z1 - z0 - 0.05)},
                       "hinge_measured": {"free_corner": _free_corner(door, corner, d / 2, "right", w / 2, rng)}}],
            "drawers": [{"left_m": 0.002, "width_m": _tape(rng, w - 0.004), "bottom_m": _tape(rng, zd),
                         "height_m": _tape(rng, drawer_h), "depth_m": 0.3, "travel_m": 0.28,
                         "handle": {"type": "knob"}}],
            "colour": "white"}
    return Piece("bedside", spec, body, [drawer, door], top_z=h)


def washer(rng: np.random.Generator) -> Piece:
    """The standard layout (`WashingMachineSpec.default_layout`'s proportions, as the real ones
    are): a control strip on top, the porthole panel, a round door with a glass bowl whose
    hinge stands 5-8 mm off its rim, half its thickness behind its face."""
    w, d, h, dia = rng.uniform(0.595, 0.6), rng.uniform(0.55, 0.57), rng.uniform(0.845, 0.85), rng.uniform(0.46, 0.48)
    white, grey = (0.93, 0.93, 0.93), (0.5, 0.5, 0.52)
    control = 0.12
    strip = h - control
    zc = strip / 2 + 0.03
    fx = d / 2
    body = [Solid(holed_panel(fx - 0.02, fx, -w / 2, w / 2, 0.0, strip, (0.0, zc), 0.75 * dia / 2), white),
            Solid(box(fx - 0.02, fx, -w / 2 + 0.35 * w, w / 2, strip, h), white),
            Solid(cylinder(0.027, [fx, w / 2 - 0.1, h - control / 2], [fx + 0.03, w / 2 - 0.1, h - control / 2]), grey)]
    body += [Solid(box(-d / 2, fx - 0.02, y0, y1, z0, z1), white) for y0, y1, z0, z1 in  # sides, top, bottom
             ((-w / 2, -w / 2 + 0.02, 0, h), (w / 2 - 0.02, w / 2, 0, h), (-w / 2, w / 2, h - 0.02, h), (-w / 2, w / 2, 0, 0.02))]
    body.append(Solid(box(-d / 2, -d / 2 + 0.02, -w / 2, w / 2, 0, h), white))
    body += [Solid(ring(0.24, 0.235, [fx - 0.36, 0, zc], [fx - 0.02, 0, zc]), (0.6, 0.6, 0.62)),
             Solid(cylinder(0.24, [fx - 0.37, 0, zc], [fx - 0.36, 0, zc]), (0.6, 0.6, 0.62))]
    g, front = 0.002, rng.uniform(0.014, 0.018)  # the detergent drawer's front
    drawer = Mover("drawer_0", "drawer_0_slide",
                   [Solid(box(fx + g - 0.25, fx + g + front, -w / 2 + g, -w / 2 + 0.35 * w - g, strip + g, h - g), white)],
                   np.zeros(3), _axis_tilt(rng, (1, 0, 0)), False, 0.2)
    r = dia / 2
    face = fx + g + 0.06
    rim = ring(r, r - 0.07, [fx + g, 0, zc], [face, 0, zc])
    glass = trimesh.creation.icosphere(subdivisions=3, radius=r - 0.07)
    glass.vertices[:, 0] *= 0.45
    glass = glass.apply_translation([fx + g + 0.03, 0, zc])
    grip = box(face - 0.01, face + 0.025, r - 0.05, r - 0.02, zc - 0.05, zc + 0.05)
    off = rng.uniform(0.005, 0.008)
    door = Mover("door_0", "door_0_hinge", [Solid(rim, (0.8, 0.8, 0.82)), Solid(glass, (0.2, 0.22, 0.25), "glass"),
                                           Solid(grip, grey)],
                 np.array([face - 0.03, -r - off, zc - r]), _axis_tilt(rng, (0, 0, -1)), True, np.radians(150))
    spec = {"kind": "washing_machine", "width_m": _tape(rng, w), "depth_m": _tape(rng, d), "height_m": _tape(rng, h),
            "door_diameter_m": _tape(rng, dia), "door_thickness_m": _tape(rng, front), "colour": "white",
            "handle_colour": "grey",
            "drawers": [{"left_m": g, "width_m": _tape(rng, 0.35 * w - 2 * g), "bottom_m": _tape(rng, strip + g),
                         "height_m": _tape(rng, control - 2 * g), "depth_m": 0.25, "travel_m": 0.2,
                         "handle": {"type": "recessed", "length_m": 0.1, "recess_depth_m": 0.008}}],
            "doors": [{"hinge": "left", "shape": "round", "left_m": _tape(rng, w / 2 - r), "width_m": _tape(rng, dia),
                       "height_m": None, "bottom_m": _tape(rng, zc - r), "opening_limit_deg": 150,
                       "window": {"margin_m": 0.07}, "thickness_m": 0.06,
                       "hinge_line": {"behind_face_m": _tape(rng, 0.03, 0.002), "in_from_edge_m": _tape(rng, -off, 0.002)},
                       "handle": {"length_m": 0.1, "diameter_m": 0.016, "from_free_edge_m": 0.045}}]}
    spec["doors"][0]["height_m"] = spec["doors"][0]["width_m"]
    return Piece("washer", spec, body, [door, drawer], top_z=h)


def dishwasher(rng: np.random.Generator) -> Piece:
    """The standard layout: a kick plate, the door hinged at the bottom above it (its axis
    inside the door, 1 cm above its bottom edge), a bar handle along its top, two racks."""
    w, d, h, kick = rng.uniform(0.595, 0.6), rng.uniform(0.56, 0.58), rng.uniform(0.84, 0.85), rng.uniform(0.09, 0.11)
    steel, grey = (0.75, 0.76, 0.78), (0.35, 0.35, 0.37)
    g, thick = 0.003, rng.uniform(0.02, 0.024)
    body = _carcass(w, d, h, 0.02, 0.0, steel) + [Solid(box(d / 2 - 0.06, d / 2, -w / 2, w / 2, 0.0, kick), grey)]
    body += [Solid(box(-d / 2 + 0.05, d / 2 - 0.06, -w / 2 + 0.04, w / 2 - 0.04, z, z + 0.01), grey)
             for z in (kick + 0.08, kick + 0.42)]  # the racks' floors
    z0, z1 = kick + g, h - g
    face = d / 2 + g + thick
    bar = cylinder(0.008, [face + 0.03, -0.15, z1 - 0.04], [face + 0.03, 0.15, z1 - 0.04], 16)
    door = Mover("door_0", "door_0_hinge", [Solid(rounded_box(d / 2 + g, face, -w / 2 + g, w / 2 - g, z0, z1, 0.004), steel),
                                           Solid(bar, grey)],
                 np.array([face - thick / 2, 0.0, z0 + 0.01]), _axis_tilt(rng, (0, 1, 0)), True, np.radians(90))
    spec = {"kind": "dishwasher", "width_m": _tape(rng, w), "depth_m": _tape(rng, d), "height_m": _tape(rng, h),
            "kick_plate_height_m": _tape(rng, kick), "door_thickness_m": _tape(rng, thick), "colour": "silver",
            "handle_colour": "grey",
            "doors": [{"hinge": "bottom", "left_m": g, "width_m": _tape(rng, w - 2 * g), "bottom_m": _tape(rng, z0),
                       "height_m": _tape(rng, z1 - z0), "opening_limit_deg": 90,
                       "hinge_line": {"behind_face_m": _tape(rng, thick / 2), "in_from_edge_m": _tape(rng, 0.01)},
                       "handle": {"length_m": 0.3, "from_free_edge_m": 0.04}}]}
    return Piece("dishwasher", spec, body, [door], top_z=h)


def microwave(rng: np.random.Generator) -> Piece:
    """The standard layout: a control panel on the right with a knob, the left-hinged door over
    the cavity with a dark window (more dropouts) and a bar handle, a plate inside."""
    w, d, h, panel = rng.uniform(0.47, 0.5), rng.uniform(0.36, 0.39), rng.uniform(0.27, 0.3), rng.uniform(0.11, 0.13)
    black, dark = (0.12, 0.12, 0.13), (0.05, 0.05, 0.06)
    g, thick = 0.003, 0.03
    body = _carcass(w, d, h, 0.012, 0.0, black)
    body += [Solid(box(d / 2 - 0.02, d / 2, w / 2 - panel, w / 2 - 0.012, 0.012, h - 0.012), black),
             Solid(cylinder(0.02, [d / 2, w / 2 - panel / 2, 0.6 * h], [d / 2 + 0.02, w / 2 - panel / 2, 0.6 * h]), (0.6, 0.6, 0.6)),
             Solid(cylinder(0.13, [0.0, -panel / 2, 0.012], [0.0, -panel / 2, 0.017]), (0.8, 0.85, 0.85))]
    y0, y1, z0, z1 = -w / 2 + g, w / 2 - panel - g, g, h - g
    face = d / 2 + g + thick
    slab = Solid(rounded_box(d / 2 + g, face, y0, y1, z0, z1, 0.004), black)
    window = Solid(box(face - 0.002, face + 0.0005, y0 + 0.05, y1 - 0.05, z0 + 0.05, z1 - 0.05), dark, "dark")
    handle = _bar(face, y1 - 0.03, z0 + 0.05, z1 - 0.05, 0.03)
    door = Mover("door_0", "door_0_hinge", [slab, window, *handle], np.array([face - 0.012, y0 + 0.003, z0]),
                 _axis_tilt(rng, (0, 0, -1)), True, np.radians(110))
    corner = np.array([face, y1, z0])
    spec = {"kind": "microwave", "width_m": _tape(rng, w), "depth_m": _tape(rng, d), "height_m": _tape(rng, h),
            "panel_width_m": _tape(rng, panel), "colour": "black",
            "doors": [{"hinge": "left", "left_m": g, "width_m": _tape(rng, y1 - y0), "bottom_m": g,
                       "height_m": _tape(rng, z1 - z0), "opening_limit_deg": 110, "window": {"margin_m": 0.05},
                       "handle": {"length_m": _tape(rng, z1 - z0 - 0.1), "standoff_m": 0.03, "from_free_edge_m": 0.03},
                       "hinge_measured": {"free_corner": _free_corner(door, corner, d / 2, "left", -w / 2, rng)}}]}
    return Piece("microwave", spec, body, [door], top_z=h)


def worktop(rng: np.random.Generator) -> Piece:
    """A slab with a rounded front edge over the washing machine and the dishwasher."""
    w, d, thick, top = rng.uniform(1.23, 1.27), rng.uniform(0.6, 0.62), 0.038, rng.uniform(0.895, 0.905)
    slab = rounded_box(-d / 2, d / 2, -w / 2, w / 2, top - thick, top, 0.012)
    spec = {"kind": "worktop", "width_m": _tape(rng, w), "depth_m": _tape(rng, d), "thickness_m": thick,
            "height_m": _tape(rng, top), "cutouts": [], "colour": "grey"}
    return Piece("worktop", spec, [Solid(slab, (0.55, 0.55, 0.5))], [], top_z=top)


def wall_cupboard(rng: np.random.Generator, mount: float) -> Piece:
    """A wall cupboard: a flap on lift-up fittings (its axis 1 cm above its top edge, half its
    thickness behind its face) over a shelf; push to open, no handle."""
    w, d, h = rng.uniform(0.78, 0.82), rng.uniform(0.32, 0.35), rng.uniform(0.6, 0.72)
    t, beige = 0.018, (0.85, 0.8, 0.68)
    body = _carcass(w, d, h, t, 0.0, beige)
    for solid in body:
        solid.mesh = solid.mesh.copy().apply_translation([0, 0, mount])
    body.append(Solid(box(-d / 2 + 0.01, d / 2 - 0.02, -w / 2 + t, w / 2 - t, mount + h / 2, mount + h / 2 + t), beige))
    z0, z1 = mount + 0.002, mount + h - 0.002
    face = d / 2 + 0.002 + 0.019
    slab = Solid(rounded_box(d / 2 + 0.002, face, -w / 2 + 0.002, w / 2 - 0.002, z0, z1, 0.003), beige)
    flap = Mover("door_0", "door_0_hinge", [slab], np.array([face - 0.01, 0.0, z1 + 0.01]),
                 _axis_tilt(rng, (0, -1, 0)), True, np.radians(100))
    corner = np.array([face, -w / 2 + 0.002, z0])
    spec = {"kind": "wall_cabinet", "width_m": _tape(rng, w), "depth_m": _tape(rng, d), "height_m": _tape(rng, h),
            "mount_height_m": _tape(rng, mount), "door_thickness_m": 0.019,
            "shelves": [{"height_m": _tape(rng, mount + h / 2 + t)}],
            "doors": [{"hinge": "top", "left_m": 0.002, "width_m": _tape(rng, w - 0.004), "bottom_m": _tape(rng, z0),
                       "height_m": _tape(rng, z1 - z0), "opening_limit_deg": 100, "handle": {"type": "none"},
                       "hinge_measured": {"free_corner": _free_corner(flap, corner, d / 2, "top", mount + h, rng)}}],
            "colour": "beige"}
    return Piece("wall_cupboard", spec, body, [flap], top_z=mount + h)


def cup(rng: np.random.Generator) -> Piece:
    r, h = rng.uniform(0.04, 0.045), rng.uniform(0.085, 0.095)
    green = (0.2, 0.6, 0.3)
    wall = ring(r, r - 0.004, [0, 0, 0.006], [0, 0, h])
    base = cylinder(r, [0, 0, 0], [0, 0, 0.006])
    handle = trimesh.creation.torus(major_radius=0.022, minor_radius=0.005).apply_transform(
        trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0])).apply_translation([r + 0.012, 0, h * 0.55])
    spec = {"kind": "mug", "height_m": _tape(rng, h), "outer_diameter_m": _tape(rng, 2 * r),
            "wall_thickness_m": 0.004, "colour": [0.2, 0.6, 0.3]}
    return Piece("mug", spec, [Solid(trimesh.util.concatenate([wall, base, handle]), green)])


def plate(rng: np.random.Generator) -> Piece:
    dia = rng.uniform(0.25, 0.27)
    profile = [(0.0, 0.0), (0.07, 0.0), (0.075, 0.008), (dia / 2, 0.022), (dia / 2, 0.025), (0.072, 0.011), (0.0, 0.005)]
    mesh = trimesh.creation.revolve(np.array(profile), sections=64)
    spec = {"kind": "plate", "style": "flat", "diameter_m": _tape(rng, dia), "height_m": 0.025, "colour": [0.95, 0.9, 0.75]}
    return Piece("plate", spec, [Solid(mesh, (0.95, 0.9, 0.75))])


# ------------------------------------------------------------------------------ the home


@dataclass
class Home:
    """The real room: pieces, their true poses (map from object) and a small object's parent
    and place on it; `installer` the poses the map is built with."""

    pieces: dict[str, Piece]
    truth: dict[str, np.ndarray]
    installer: dict[str, np.ndarray]
    small: dict[str, tuple[str, np.ndarray]]  # id -> (parent, parent_from_object)


def pose(x: float, y: float, z: float, yaw_deg: float) -> np.ndarray:
    m = trimesh.transformations.rotation_matrix(np.radians(yaw_deg), [0, 0, 1])
    m[:3, 3] = (x, y, z)
    return m


def make_home(seed: int = 0) -> Home:
    rng = np.random.default_rng(seed)
    pieces = {p.id: p for p in (wardrobe(rng), chest(rng, np.random.default_rng([seed, 2])),
                                bedside(rng, np.random.default_rng([seed, 3])), washer(rng),
                                worktop(rng))}
    pieces["wall_cupboard"] = wall_cupboard(rng, pieces["worktop"].top_z + rng.uniform(0.5, 0.56))
    pieces["mug"], pieces["plate"] = cup(rng), plate(rng)
    later = np.random.default_rng([seed, 1])  # pieces added later: the first ones' draws kept
    pieces["dishwasher"], pieces["microwave"] = dishwasher(later), microwave(later)
    truth = {  # the bedroom wall at x = 0 (fronts +x), the utility wall at y = 4 (fronts -y)
        "wardrobe": pose(0.31, 0.75, 0, rng.uniform(-0.3, 0.3)),  # each 1-3 cm off the wall
        "chest": pose(0.25, 1.95, 0, rng.uniform(-0.5, 0.5)),
        "bedside": pose(0.215, 2.75, 0, rng.uniform(-1, 1)),
        "washer": pose(2.25, ROOM_XY[1] - 0.3, 0, -90 + rng.uniform(-0.5, 0.5)),
        "worktop": pose(2.55, ROOM_XY[1] - 0.31, 0, -90),
        "wall_cupboard": pose(2.75, ROOM_XY[1] - 0.175, 0, -90),
        "dishwasher": pose(2.86, ROOM_XY[1] - 0.3, 0, -90 + later.uniform(-0.5, 0.5)),
        "microwave": pose(2.93, ROOM_XY[1] - 0.22, pieces["worktop"].top_z, -90 + later.uniform(-3, 3)),
    }
    installer = {}
    for pid, t in truth.items():
        draw = later if pid in ("dishwasher", "microwave") else rng
        shift, turn = draw.uniform(0.02, 0.03), draw.uniform(1.5, 3.0) * draw.choice([-1, 1])
        a = draw.uniform(0, 2 * np.pi)
        installer[pid] = t @ pose(shift * np.cos(a), shift * np.sin(a), 0.0, turn)
    small = {"mug": ("bedside", pose(0.02, 0.08, pieces["bedside"].top_z, 30)),
             "plate": ("worktop", pose(0.05, -0.25, pieces["worktop"].top_z, 0))}
    return Home(pieces, truth, installer, small)


def _xyz_rpy(m: np.ndarray) -> dict:
    yaw = math.degrees(math.atan2(m[1, 0], m[0, 0]))
    return {"xyz": [round(float(v), 4) for v in m[:3, 3]], "rpy_deg": [0, 0, round(yaw, 3)]}


def _checked_by_installer(spec: dict) -> dict:
    """Fronts read past the body's sides or top by the tape's error are read again: each front
    kept 1 mm inside the body's width and height, and under a top slab standing out over it
    (the modeller refuses a front off its body or into its top)."""
    slab = spec["top_thickness_m"] if "top_overhang" in spec else 0.0
    top = spec["height_m"] + spec.get("mount_height_m", 0.0) - slab
    for front in spec.get("doors", []) + spec.get("drawers", []):
        front["left_m"] = max(front["left_m"], 0.001)
        front["width_m"] = round(min(front["width_m"], spec["width_m"] - 0.001 - front["left_m"]), 4)
        front["height_m"] = round(min(front["height_m"], top - 0.001 - front["bottom_m"]), 4)
    return spec


def write_specs(home: Home, folder: Path) -> Path:
    """The installer's folder: a spec per piece and `home.yaml`, the poses as placed by eye."""
    folder.mkdir(parents=True, exist_ok=True)
    objects = []
    for pid, m in home.installer.items():
        (folder / f"{pid}.yaml").write_text(yaml.safe_dump(_checked_by_installer(home.pieces[pid].spec), sort_keys=False))
        front = m[:2, 3] + m[:2, 0] * 1.0
        entry = {"id": pid, "spec": f"{pid}.yaml", "pose": _xyz_rpy(m),
                 "parking": [{"name": "front", "xy": [round(float(v), 3) for v in front], "yaw_deg": 0}]}
        kids = [(sid, p) for sid, (parent, p) in home.small.items() if parent == pid]
        for sid, p in kids:
            (folder / f"{sid}.yaml").write_text(yaml.safe_dump(home.pieces[sid].spec, sort_keys=False))
            entry.setdefault("objects", []).append({"id": sid, "spec": f"{sid}.yaml", "relation": "on", "pose": _xyz_rpy(p)})
        objects.append(entry)
    outline = [[0.0, 0.0], [ROOM_XY[0], 0.0], [ROOM_XY[0], ROOM_XY[1]], [0.0, ROOM_XY[1]]]
    home_yaml = {"apartment": {"id": "flat", "name": "Flat"},
                 "rooms": [{"id": "bedroom", "name": "Bedroom and utility", "outline": outline, "objects": objects}]}
    (folder / "home.yaml").write_text(yaml.safe_dump(home_yaml, sort_keys=False))
    return folder


def build_map(home: Home, folder: Path) -> Path:
    """`homemodel build` of the installer's folder, as the README says; returns the map."""
    specs = write_specs(home, folder / "specs")
    out = folder / "built"
    if not (out / "map.xml").exists():
        done = subprocess.run([str(HOMEMODEL), "build", str(specs), "--out", str(out)], capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(done.stdout + done.stderr)
    return out / "map.xml"


# ------------------------------------------------------------------------------ views


@dataclass
class CameraSetup:
    name: str
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    depth_scale_m: float


SETUPS = [CameraSetup("xtion", 640, 480, 570.3, 570.3, 314.5, 235.5, 0.00025),
          CameraSetup("tof_sized", 512, 424, 365.0, 365.0, 258.0, 208.0, 0.001)]


@dataclass
class View:
    name: str
    setup: CameraSetup
    map_from_camera: np.ndarray
    joints: dict[tuple[str, str], float]
    small: dict[str, tuple[str, np.ndarray]]
    occluder: str | None  # "person", "chair" or None
    seed: int


def look_from(eye: np.ndarray, target: np.ndarray, roll_deg: float) -> np.ndarray:
    """map_from_camera, OpenCV axes, looking from `eye` at `target`, rolled about the view."""
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, [0, 0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    m = np.eye(4)
    m[:3, :3] = np.stack([x, y, z], 1) @ trimesh.transformations.rotation_matrix(np.radians(roll_deg), [0, 0, 1])[:3, :3]
    m[:3, 3] = eye
    return m


LATER_PIECES = ("dishwasher", "microwave")  # their joints drawn apart, so the first pieces' views stay as they were


def random_view(home: Home, index: int, rng: np.random.Generator) -> View:
    """A head camera 1.0-1.5 m up, 1.2-2.5 m from a piece, looking 10-30 degrees down."""
    target_id = ["wardrobe", "chest", "bedside", "washer", "wall_cupboard", "microwave"][index % 6]
    t = home.truth[target_id]
    piece = home.pieces[target_id]
    bounds = trimesh.util.concatenate([s.mesh for s in piece.body]).bounds
    centre = t @ np.append(bounds.mean(0), 1.0)
    for _ in range(200):
        dist, height = rng.uniform(1.2, 2.5), rng.uniform(1.0, 1.5)
        bearing = np.radians(rng.uniform(-35, 35))
        out = t[:3, 0] * np.cos(bearing) + t[:3, 1] * np.sin(bearing)
        eye = centre[:3] + out * dist
        eye[2] = height
        look_z = rng.uniform(0.25, 1.3) if target_id != "wall_cupboard" else rng.uniform(1.1, 1.6)
        target = np.array([centre[0], centre[1], look_z])
        down = np.degrees(np.arctan2(eye[2] - look_z, np.linalg.norm(target[:2] - eye[:2])))
        if 0.3 < eye[0] < ROOM_XY[0] - 0.2 and 0.2 < eye[1] < ROOM_XY[1] - 0.3 and 10 <= down <= 30:
            break
    setup = SETUPS[index % 2]
    states = {"shut": (0.0, 0.0), "ajar": (0.04, 0.08), "half": (0.4, 0.6), "full": (0.85, 1.0)}
    joints = {}

    def draw_states(pieces: list[str], draw: np.random.Generator) -> None:
        for pid in pieces:
            for mover in home.pieces[pid].movers:
                name = ["shut", "ajar", "half", "full"][int(draw.integers(4))]
                joints[(pid, mover.joint)] = float(draw.uniform(*states[name]) * mover.limit)

    draw_states([pid for pid in home.pieces if pid not in LATER_PIECES], rng)
    small = dict(home.small)
    if index % 3 == 1:  # the mug carried to the chest, the plate moved on the worktop
        small["mug"] = ("chest", pose(rng.uniform(-0.2, 0.2), rng.uniform(-0.25, 0.25), home.pieces["chest"].top_z,
                                      rng.uniform(-180, 180)))
        small["plate"] = ("worktop", pose(rng.uniform(-0.05, 0.1), rng.uniform(-0.3, 0.0), home.pieces["worktop"].top_z, 0))
    occluder = [None, "person", None, "chair"][index % 4]
    roll, seed = rng.uniform(-2, 2), int(rng.integers(1 << 30))
    draw_states(list(LATER_PIECES), np.random.default_rng([seed, 1]))
    return View(f"v{index:02d}", setup, look_from(eye, target, roll), joints, small, occluder, seed)


def _occluder_solids(view: View, home: Home, target_id: str, rng) -> list[trimesh.Trimesh]:
    """A person or a chair half-way between the camera and the piece, to one side of its middle."""
    eye = view.map_from_camera[:3, 3]
    centre = home.truth[target_id][:3, 3]
    at = eye + (centre - eye) * rng.uniform(0.4, 0.6)
    side = np.cross(centre - eye, [0, 0, 1])
    side /= np.linalg.norm(side)
    at = at + side * rng.uniform(0.1, 0.3) * rng.choice([-1, 1])
    x, y = at[0], at[1]
    if view.occluder == "person":
        legs = [box(x - 0.06, x + 0.06, y + s - 0.06, y + s + 0.06, 0.0, 0.85) for s in (-0.1, 0.1)]
        torso = box(x - 0.13, x + 0.13, y - 0.22, y + 0.22, 0.85, 1.45)
        head = trimesh.creation.icosphere(subdivisions=2, radius=0.11).apply_translation([x, y, 1.58])
        return [*legs, torso, head]
    legs = [box(x + a - 0.015, x + a + 0.015, y + b - 0.015, y + b + 0.015, 0.0, 0.45)
            for a in (-0.2, 0.2) for b in (-0.2, 0.2)]
    return [*legs, box(x - 0.22, x + 0.22, y - 0.22, y + 0.22, 0.45, 0.49), box(x + 0.18, x + 0.22, y - 0.22, y + 0.22, 0.49, 0.95)]


@dataclass
class Rendered:
    depth_m: np.ndarray
    rgb: np.ndarray
    visible: dict[tuple[str, str], float]  # (object, joint) -> share of the moving part visible
    small_visible: dict[str, float]


def _posed(home: Home, view: View) -> list[tuple[str, str | None, Solid, np.ndarray]]:
    """(object, joint or None, solid, map_from_solid) for everything in the room."""
    out = []
    for pid, piece in home.pieces.items():
        if pid in view.small:
            parent, parent_from = view.small[pid]
            m = home.truth[parent] @ parent_from
        else:
            m = home.truth[pid]
        out += [(pid, None, s, m) for s in piece.body]
        for mover in piece.movers:
            motion = mover.motion(view.joints[(pid, mover.joint)])
            out += [(pid, mover.joint, s, m @ motion) for s in mover.solids]
    return out


def _room() -> list[trimesh.Trimesh]:
    X, Y = ROOM_XY
    return [box(-0.5, X + 0.5, -0.5, Y + 0.5, -0.05, 0.0), box(-0.1, 0.0, -0.1, Y + 0.1, 0, WALL_H),
            box(X, X + 0.1, -0.1, Y + 0.1, 0, WALL_H), box(-0.1, X + 0.1, -0.1, 0.0, 0, WALL_H),
            box(-0.1, X + 0.1, Y, Y + 0.1, 0, WALL_H)]


def _rays(setup: CameraSetup, map_from_camera: np.ndarray, step: int = 1, margin: float = 0.0) -> np.ndarray:
    """A ray a pixel (every `step`-th), over the image widened by `margin` of its size each side."""
    du, dv = (step * math.ceil(margin * size / step) for size in (setup.width, setup.height))  # on the step's grid
    u, v = np.meshgrid(np.arange(-du, setup.width + du, step), np.arange(-dv, setup.height + dv, step))
    d_cam = np.stack([(u - setup.cx) / setup.fx, (v - setup.cy) / setup.fy, np.ones_like(u, dtype=float)], -1)
    d_map = d_cam.reshape(-1, 3) @ map_from_camera[:3, :3].T  # z-depth = t, as the camera's z is 1
    origin = np.broadcast_to(map_from_camera[:3, 3], d_map.shape)
    return np.concatenate([origin, d_map], 1).astype(np.float32)


def _cast(meshes: list[trimesh.Trimesh], rays: np.ndarray) -> dict:
    scene = o3d.t.geometry.RaycastingScene()
    for mesh in meshes:
        scene.add_triangles(o3d.core.Tensor(np.asarray(mesh.vertices, np.float32)),
                            o3d.core.Tensor(np.asarray(mesh.faces, np.uint32)))
    hit = scene.cast_rays(o3d.core.Tensor(rays))
    return {k: hit[k].numpy() for k in ("t_hit", "geometry_ids", "primitive_normals")}


def render(home: Home, view: View, visibility: bool = True) -> Rendered:
    """Depth (the issue's noise model) and colour of the real room from the view's camera."""
    rng = np.random.default_rng(view.seed)
    posed = _posed(home, view)
    meshes = [s.mesh.copy().apply_transform(m) for _, _, s, m in posed]
    target = min(home.truth, key=lambda pid: np.linalg.norm(home.truth[pid][:2, 3] - view.map_from_camera[:2, 3]
                                                             - 1.8 * view.map_from_camera[:2, 2]))
    extra = _occluder_solids(view, home, target, rng) if view.occluder else []
    room = _room()
    everything = meshes + room + extra
    rays = _rays(view.setup, view.map_from_camera)
    hit = _cast(everything, rays)
    t, ids = hit["t_hit"], hit["geometry_ids"].astype(np.int64)
    n_posed = len(meshes)
    material = np.array([s.material for _, _, s, _ in posed] + ["matt"] * (len(room) + len(extra)))
    # glass: the porthole is seen through (to the drum) or gives no reading
    glass = (ids < len(material)) & (material[np.minimum(ids, len(material) - 1)] == "glass") & np.isfinite(t)
    if glass.any():
        behind = _cast([m for m, s in zip(meshes, posed) if s[2].material != "glass"] + room + extra, rays[glass])
        through = rng.random(glass.sum()) < 0.5
        t_glass = np.where(through, behind["t_hit"], np.inf)
        t[glass] = t_glass
    d = rays[:, 3:]
    normals = hit["primitive_normals"]
    cos = np.abs(np.sum(normals * d, 1)) / np.linalg.norm(d, axis=1)
    z = t.copy()  # the ray's z component is 1: t is the depth
    ok = np.isfinite(z) & (cos > np.cos(np.radians(75.0)))
    sigma = 0.0012 + 0.0019 * (z - 0.4) ** 2
    z = np.where(ok, z + rng.normal(0.0, 1.0, z.shape) * np.where(ok, sigma, 0.0), 0.0)
    z = np.round(z / 0.001) * 0.001  # 1 mm steps
    dark = (ids < n_posed) & (material[np.minimum(ids, len(material) - 1)] == "dark")
    drop = rng.random(z.shape) < np.where(dark, 0.08, 0.01)
    z[drop | ~ok] = 0.0
    rgb_of = np.array([s.rgb for _, _, s, _ in posed] + [(0.8, 0.78, 0.74)] + [(0.9, 0.9, 0.86)] * 4
                      + [(0.3, 0.35, 0.6)] * len(extra))
    shade = 0.35 + 0.65 * np.clip(cos, 0, 1)
    rgb = np.where(np.isfinite(hit["t_hit"])[:, None], rgb_of[np.minimum(ids, len(rgb_of) - 1)] * shade[:, None], 0.0)
    shape = (view.setup.height, view.setup.width)
    visible, small_visible = _visibility(posed, meshes, ids, view) if visibility else ({}, {})
    return Rendered(z.reshape(shape), (np.clip(rgb, 0, 1) * 255).astype(np.uint8).reshape(*shape, 3), visible, small_visible)


def _visibility(posed, meshes, ids, view) -> tuple[dict, dict]:
    """Each moving part's (and small object's) share visible: its pixels in the view over its
    pixels with nothing in front, on the image plane widened by the image's size each side
    (what the image's edge cuts off counts as covered); every 3rd pixel."""
    step = np.zeros((view.setup.height, view.setup.width), bool)
    step[::3, ::3] = True
    step = step.ravel()
    wide = _rays(view.setup, view.map_from_camera, step=3, margin=1.0)
    groups: dict[tuple[str, str | None], list[int]] = {}
    for k, (pid, joint, _, _) in enumerate(posed):
        if joint is not None or pid in view.small:
            groups.setdefault((pid, joint), []).append(k)
    visible, small_visible = {}, {}
    for key, members in groups.items():
        alone = _cast([meshes[k] for k in members], wide)
        own = np.isfinite(alone["t_hit"]).sum()
        seen = np.isin(ids[step], members).sum()
        share = float(seen / own) if own else 0.0
        if key[1] is None:
            small_visible[key[0]] = share
        else:
            visible[key] = share
    return visible, small_visible


def write_observation(folder: Path, view: View, rendered: Rendered, home: Home) -> None:
    """OBS_DIR (`folder/obs`) as the issue says: depth.png (16-bit), color.png, camera.yaml
    with map_from_camera; the truth beside it, outside what `observe` reads, in truth.json."""
    (folder / "obs").mkdir(parents=True, exist_ok=True)
    s = view.setup
    counts = np.round(rendered.depth_m / s.depth_scale_m)
    Image.fromarray(np.clip(counts, 0, 65535).astype(np.uint16)).save(folder / "obs" / "depth.png")
    Image.fromarray(rendered.rgb).save(folder / "obs" / "color.png")
    camera = {"width": s.width, "height": s.height, "fx": s.fx, "fy": s.fy, "cx": s.cx, "cy": s.cy,
              "depth_scale_m": s.depth_scale_m,
              "map_from_camera": [[float(v) for v in row] for row in view.map_from_camera]}
    (folder / "obs" / "camera.yaml").write_text(yaml.safe_dump(camera))
    truth = {"setup": s.name, "occluder": view.occluder,
             "joints": {f"{p}/{j}": q for (p, j), q in view.joints.items()},
             "visible": {f"{p}/{j}": v for (p, j), v in rendered.visible.items()},
             "small_visible": rendered.small_visible,
             "poses": {pid: m.tolist() for pid, m in home.truth.items()},
             "small": {sid: {"parent": parent, "parent_from_object": m.tolist(),
                             "map_from_object": (home.truth[parent] @ m).tolist()} for sid, (parent, m) in view.small.items()}}
    (folder / "truth.json").write_text(json.dumps(truth, indent=1))


# ------------------------------------------------------------------------------ observe and score


def observe(map_path: Path, obs: Path, out: Path) -> subprocess.CompletedProcess:
    """Exactly the issue's command line."""
    return subprocess.run([str(HOMEMODEL), "map", "observe", str(map_path), str(obs), "--out", str(out / "new_map.xml"),
                           "--report", str(out / "report.json")], capture_output=True, text=True)


def read_map(path: Path) -> dict:
    """{large id: (map_from_object, {joint: position})} and {small id: (parent, parent_from_object)}
    read from the XML itself."""
    def matrix(el) -> np.ndarray:
        x, y, z = (float(v) for v in el.get("xyz").split())
        r, p, yw = (float(v) for v in el.get("rpy").split())
        m = trimesh.transformations.euler_matrix(r, p, yw, "sxyz")
        m[:3, 3] = (x, y, z)
        return m

    large, small = {}, {}
    for el in ET.parse(path).getroot().iter():
        el.tag = el.tag.rsplit("}", 1)[-1]  # the map's namespace
        if el.tag in ("largeObject", "largeArticulatedObject"):
            large[el.get("id")] = (matrix(el), {j.get("name"): float(j.get("position")) for j in el
                                                if j.tag.endswith("}joint")})
        elif el.tag == "smallObject":
            small[el.get("id")] = (el.get("parent"), matrix(el))
    return {"large": large, "small": small}


def _yaw_deg(m: np.ndarray) -> float:
    return math.degrees(math.atan2(m[1, 0], m[0, 0]))


def score_view(prior: dict, new: dict, truth: dict) -> dict:
    """Every joint, pose and small object of one view against the truth."""
    joints = []
    for pid, (_, positions) in prior["large"].items():
        for joint, old in positions.items():
            # a joint the real piece does not move (the washer's knob, a plain cylinder) is at 0
            key, written = f"{pid}/{joint}", new["large"][pid][1][joint]
            q = truth["joints"].get(key, 0.0)
            tol = DRAWER_TOL_M if joint.endswith("_slide") else DOOR_TOL_RAD
            changed = not math.isclose(old, written, abs_tol=1e-9)
            right = abs(written - q) <= tol
            vis = truth["visible"].get(key, 0.0)
            kind = ("written right" if right else "WRITTEN WRONG") if changed else (
                "kept, right" if right else ("missed" if vis >= 0.5 else "rightly not written"))
            joints.append({"joint": key, "truth": q, "written": written, "visible": round(vis, 3), "class": kind,
                           "error": written - q})
    poses = []
    for pid, t in truth["poses"].items():
        t = np.asarray(t)
        before, after = prior["large"][pid][0], new["large"][pid][0]
        if np.allclose(before, after, atol=1e-7):
            poses.append({"object": pid, "class": "kept"})
            continue
        err = lambda m: (float(np.linalg.norm(m[:2, 3] - t[:2, 3])), abs((_yaw_deg(m) - _yaw_deg(t) + 180) % 360 - 180))  # noqa: E731
        (e0, y0), (e1, y1) = err(before), err(after)
        kind = "better" if e1 < e0 - POSE_SAME_M else ("WORSE" if e1 > e0 + POSE_SAME_M else "same")
        poses.append({"object": pid, "class": kind, "map_mm": round(e0 * 1000, 1), "written_mm": round(e1 * 1000, 1),
                      "map_deg": round(y0, 2), "written_deg": round(y1, 2)})
    small = []
    for sid, s in truth["small"].items():
        parent, m = new["small"][sid]
        before_parent, before = prior["small"][sid]
        moved = parent != before_parent or not np.allclose(m, before, atol=1e-7)
        at = np.asarray(new["large"][parent][0]) @ m
        true_at = np.asarray(s["map_from_object"])
        err = float(np.linalg.norm(at[:3, 3] - true_at[:3, 3]))
        vis = truth["small_visible"].get(sid, 0.0)
        if moved:
            kind = "found right" if err <= SMALL_TOL_M and parent == s["parent"] else "WRITTEN WRONG"
        else:
            kind = "kept, right" if err <= SMALL_TOL_M and parent == s["parent"] else (
                "missed" if vis >= 0.5 else "rightly not written")
        small.append({"object": sid, "class": kind, "error_mm": round(err * 1000, 1), "visible": round(vis, 2),
                      "parent": parent, "true_parent": s["parent"]})
    return {"joints": joints, "poses": poses, "small": small}


def views_of(home: Home, count: int, seed: int) -> list[View]:
    """The view set of a seed: the same views, camera set-ups, joint states and moves each time."""
    rng = np.random.default_rng(1000 + seed)
    return [random_view(home, index, rng) for index in range(count)]


def check_view(map_path: Path, home: Home, view: View, folder: Path, run=observe, visibility: bool = True) -> dict:
    """Render the view into `folder/obs`, run `map observe` on it (`run`: the command line, or the
    same command in-process) into `folder/result`, and score what it wrote against the truth."""
    write_observation(folder, view, render(home, view, visibility=visibility), home)
    result = folder / "result"
    result.mkdir(exist_ok=True)
    done = run(map_path, folder / "obs", result)
    if done.returncode != 0:
        raise RuntimeError(f"{folder.name}: exit {done.returncode}: {done.stderr.strip()[-300:]}")
    truth = json.loads((folder / "truth.json").read_text())
    scored = score_view(read_map(map_path), read_map(result / "new_map.xml"), truth)
    (result / "score.json").write_text(json.dumps(scored, indent=1))
    return scored


def _is_fault(row: dict) -> bool:
    return row["class"] in ("WRITTEN WRONG", "WORSE", "missed")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--views", type=int, default=24)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    home = make_home(args.seed)
    map_path = build_map(home, args.out)
    tally: dict[str, dict[str, int]] = {"joints": {}, "poses": {}, "small": {}}
    cpu_s = []
    for view in views_of(home, args.views, args.seed):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        scored = check_view(map_path, home, view, args.out / "views" / view.name)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu_s.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
        for what, rows in scored.items():
            for row in rows:
                tally[what][row["class"]] = tally[what].get(row["class"], 0) + 1
                if _is_fault(row):
                    print(f"{view.name} {what}: {json.dumps(row)}", flush=True)
    print(json.dumps(tally, indent=1))
    print(f"map observe, CPU s a view (the command's process): median {np.median(cpu_s):.2f}, max {max(cpu_s):.2f}")


if __name__ == "__main__":
    main()
