"""Random "real" cabinets and appliances made of trimesh boxes, and the specs an installer
writes for them with the README's tape guide alone.

Each piece is drawn from a seed: base, wall and tall units with or without a face frame
(overhanging the sides, with middle rails), raised bottoms, thick shelves, open tops with
rails, back panels set in, overlay and inset doors hinged left, right or at the top, drawer
banks whose boxes have second boards, thin walls and offsets; microwaves and ovens whose thick
doors sit partly in their recess, with rectangular buttons and knobs in pockets and an
off-centre plate; fridges with door bins; dishwashers. The real geometry is continuous; the spec holds what
a tape read to the millimetre gives, the hinge lines by the guide's `open_at_90` or
`free_corner` (`test_modeller_real_features._tape`). Every door's real axis is drawn until the
real door swings clear of the real body (checked in the plane square to the axis), so the
real piece is one that could be built.

`test_modeller_unseen_furniture.measure` scores a rebuilt piece against its real one.
"""

from __future__ import annotations

import math

import numpy as np
import trimesh
from test_modeller_real_features import _box, _tape
from test_modeller_unseen_furniture import Mover, RealPiece, _slide

# A door keeps this far from the real parts round it as it swings (negative: a clearance).
_CLEAR_M = -0.001


def mm(value_m: float) -> float:
    """A tape's reading: to the millimetre."""
    return round(round(value_m * 1000) / 1000, 3)


class _Draw:
    """Random real sizes, to a tenth of a millimetre (a real piece is not made to the mm)."""

    def __init__(self, seed: int) -> None:
        self.rng = np.random.default_rng(seed)

    def u(self, low: float, high: float) -> float:
        return round(float(self.rng.uniform(low, high)), 4)

    def p(self, chance: float) -> bool:
        return bool(self.rng.random() < chance)

    def pick(self, options):
        return options[int(self.rng.integers(len(options)))]


# ---------------------------------------------------------------------------- doors


def _to_fs(hinge: str, ref: float, depth_m: float, box: tuple) -> tuple[float, float, float, float]:
    """A box (x0, x1, y0, y1, z0, z1) as a rectangle (f0, f1, s0, s1) in the door's plane:
    f forward of the front plane, s in from the face `ref` the tape reads `out` from."""
    x0, x1, y0, y1, z0, z1 = box
    f0, f1 = x0 - depth_m / 2, x1 - depth_m / 2
    if hinge == "left":
        return f0, f1, y0 - ref, y1 - ref
    if hinge == "right":
        return f0, f1, ref - y1, ref - y0
    if hinge == "bottom":
        return f0, f1, z0 - ref, z1 - ref
    return f0, f1, ref - z1, ref - z0


def _outline(rect: tuple, step_m: float = 0.001) -> np.ndarray:
    f0, f1, s0, s1 = rect
    fs = np.linspace(f0, f1, max(2, int((f1 - f0) / step_m) + 1))
    ss = np.linspace(s0, s1, max(2, int((s1 - s0) / step_m) + 1))
    return np.concatenate([
        np.stack([fs, np.full_like(fs, s0)], 1), np.stack([fs, np.full_like(fs, s1)], 1),
        np.stack([np.full_like(ss, f0), ss], 1), np.stack([np.full_like(ss, f1), ss], 1),
    ])


def _inside(points: np.ndarray, rect: tuple) -> bool:
    f0, f1, s0, s1 = rect
    depth = np.minimum.reduce([points[..., 0] - f0, f1 - points[..., 0], points[..., 1] - s0, s1 - points[..., 1]])
    return bool(np.any(depth > _CLEAR_M))


def swings_clear(door_rects: list, obstacles: list, axis_fs, limit_deg: float) -> bool:
    """Whether the door's cross-section turned outward about `axis_fs` from 0 to `limit_deg`
    stays out of every obstacle rectangle (and they out of it)."""
    axis = np.asarray(axis_fs, dtype=float)
    angles = np.radians(np.arange(0.0, limit_deg + 0.5, 1.0))
    c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
    outline = np.concatenate([_outline(r) for r in door_rects]) - axis
    turned = np.stack([outline[:, 0] * c + outline[:, 1] * s, outline[:, 1] * c - outline[:, 0] * s], -1) + axis
    corners = np.array([(r[a], r[b]) for r in obstacles for a in (0, 1) for b in (2, 3)]) - axis
    back = np.stack([corners[:, 0] * c - corners[:, 1] * s, corners[:, 1] * c + corners[:, 0] * s], -1) + axis
    return not any(_inside(turned, o) for o in obstacles) and not any(_inside(back, r) for r in door_rects)


def hinged_door(
    draw: _Draw, *, link: str, hinge: str, ref: float, depth_m: float, across: tuple[float, float],
    along: tuple[float, float], face_x: float, thick: float, inside: float, plug: tuple | None,
    obstacles: list[tuple], limit_deg: float, behind: tuple[float, float], inward: tuple[float, float], way: str,
    carried: tuple = (),
) -> tuple[Mover, dict]:
    """A real door (its slab from `face_x` back to the front plane's gap, and its `plug` box
    inside the opening, if any) on an axis drawn until it swings clear of `obstacles`
    (boxes in the model frame), and its tape readings.

    `across` is the door's extent across the hinge line (y for side hinges, z for flaps),
    `along` along it. Returns the mover and the tape (`hinge_measured`)."""
    side = hinge in ("left", "right")
    slab_back = plug[1] if plug is not None else face_x - thick  # the plug reaches the slab
    lo, hi = across
    if side:
        slab = (slab_back, face_x, lo, hi, along[0], along[1])
    else:
        slab = (slab_back, face_x, along[0], along[1], lo, hi)
    parts = [slab] + ([plug] if plug is not None else []) + list(carried)
    # Each part against what shares its extent along the hinge line (the plug is shorter).
    checks = []
    for part in parts:
        p0, p1 = (part[4], part[5]) if side else (part[2], part[3])
        near = []
        for box in obstacles:
            a0, a1 = (box[4], box[5]) if side else (box[2], box[3])
            if min(a1, p1) - max(a0, p0) > 0.001:
                near.append(_to_fs(hinge, ref, depth_m, box))
        checks.append(([_to_fs(hinge, ref, depth_m, part)], near))
    face_f = face_x - depth_m / 2
    slab_rect = checks[0][0][0]
    edge_s = slab_rect[2]
    width = slab_rect[3] - slab_rect[2]

    def clear(axis) -> bool:
        return all(swings_clear(rects, near, axis, limit_deg) for rects, near in checks)

    for _ in range(400):
        b, a = draw.u(*behind), draw.u(*inward)
        axis = (face_f - b, edge_s + a)
        if clear(axis):
            break
    else:
        axis = (face_f, edge_s)  # a butt hinge on the outer edge: an overlay door swings clear
        if not clear(axis):
            raise ValueError(f"{link}: no hinge line found that swings clear")
    sign = {"left": 1.0, "right": -1.0, "bottom": 1.0, "top": -1.0}[hinge]
    point = np.zeros(3)
    point[0] = depth_m / 2 + axis[0]
    if side:
        point[1], point[2] = ref + sign * axis[1], along[0]
        direction = np.array([0.0, 0.0, -1.0 if hinge == "left" else 1.0])
    else:
        point[1], point[2] = along[0], ref + sign * axis[1]
        direction = np.array([0.0, 1.0 if hinge == "bottom" else -1.0, 0.0])
    turn = trimesh.transformations.rotation_matrix(math.radians(limit_deg), direction, point)
    boxes = [_box(p[0::2], p[1::2]) for p in parts]
    mover = Mover(link, f"{link}_hinge", boxes, math.radians(limit_deg), turn, (point, np.abs(direction)))
    inner_f = face_f - thick
    tape = _tape(axis, face_f=face_f, inner_f=inner_f, edge_s=edge_s, width_m=width, way=way)
    return mover, tape


# ---------------------------------------------------------------------------- cabinets


def cabinet(seed: int, way: str = "open_at_90") -> RealPiece:
    """A base, wall or tall unit of random build, with doors, a flap or drawers."""
    r = _Draw(seed)
    kind = r.pick(["base", "wall", "tall"])
    t = r.u(0.016, 0.019)
    gap, door_t = r.u(0.0015, 0.003), r.u(0.016, 0.022)
    if kind == "base":
        w, d, plinth = r.u(0.35, 1.0), r.u(0.5, 0.6), r.u(0.08, 0.15)
        base, top = 0.0, r.u(0.78, 0.9)
    elif kind == "wall":
        w, d, plinth = r.u(0.35, 0.9), r.u(0.28, 0.36), 0.0
        base = r.u(1.3, 1.5)
        top = base + r.u(0.5, 0.9)
    else:
        w, d, plinth = r.u(0.45, 0.65), r.u(0.55, 0.62), r.u(0.08, 0.12)
        base, top = 0.0, r.u(1.8, 2.2)
    y = lambda left: -w / 2 + left  # noqa: E731
    bottom = base + plinth
    frame = r.p(0.5)
    fw, ft = r.u(0.035, 0.045), r.u(0.018, 0.021)
    ov = r.pick([0.0, r.u(0.004, 0.01)]) if frame else 0.0
    open_top = kind == "base" and r.p(0.5)
    top_t = t if r.p(0.6) else r.u(0.016, 0.024)
    raise_m = r.u(0.03, 0.05) if kind != "wall" and r.p(0.4) else 0.0
    bottom_t = t if r.p(0.6) else r.u(0.016, 0.024)
    back = (r.u(0.003, 0.008), r.u(0.005, 0.02)) if r.p(0.4) else None  # thickness, inset
    inset = r.p(0.3)
    front_x = d / 2 - (ft if frame else 0.0)  # the sides' front edges (behind a frame)
    back_in = -d / 2 + (t if back is None else back[1] + back[0])
    floor_z = bottom + raise_m + bottom_t
    body = [
        _box((-d / 2, y(0), bottom), (front_x, y(t), top)),
        _box((-d / 2, y(w - t), bottom), (front_x, y(w), top)),
        _box((-d / 2 + (0 if back is None else back[1]), y(t), floor_z),
             (back_in, y(w - t), top - (0 if open_top else top_t))),
        _box((back_in if back is None else -d / 2, y(t), bottom + raise_m), (front_x, y(w - t), floor_z)),
    ]
    spec: dict = {
        "kind": {"base": "cupboard", "wall": "wall_cabinet", "tall": "wardrobe"}[kind],
        "width_m": mm(w), "depth_m": mm(d), "height_m": mm(top - base), "wall_thickness_m": mm(t),
        "door_thickness_m": mm(door_t), "door_gap_m": mm(gap), "mass_kg": 30,
    }
    if kind == "wall":
        spec["mount_height_m"] = mm(base)
    if kind == "tall":
        spec["rails"] = []
    if plinth > 0:
        recess = r.u(0.04, 0.07)
        body += [
            _box((d / 2 - recess - t, y(0), 0), (d / 2 - recess, y(w), plinth)),
            _box((-d / 2, y(0), 0), (-d / 2 + t, y(w), plinth)),
            _box((-d / 2, y(0), 0), (d / 2 - recess, y(t), plinth)),
            _box((-d / 2, y(w - t), 0), (d / 2 - recess, y(w), plinth)),
        ]
        spec |= {"plinth_height_m": mm(plinth), "plinth_recess_m": mm(recess)}
    if open_top:
        rails = [(0.0 if not frame else ft, r.u(0.08, 0.12)), (None, r.u(0.06, 0.1))]
        spec["top_panel"] = False
        spec["top_rails"] = []
        for from_front, depth in rails:
            from_front = d - t - depth if from_front is None else from_front
            body.append(_box((d / 2 - from_front - depth, y(t), top - t), (d / 2 - from_front, y(w - t), top)))
            spec["top_rails"].append({"from_front_m": mm(from_front), "depth_m": mm(depth)})
    else:
        body.append(_box((-d / 2 + (0 if back is None else back[1]), y(t), top - top_t), (front_x, y(w - t), top)))
        if top_t != t:
            spec["top_thickness_m"] = mm(top_t)
    if bottom_t != t:
        spec["bottom_thickness_m"] = mm(bottom_t)
    if raise_m:
        spec["bottom_raise_m"] = mm(raise_m)
    if back is not None:
        body.append(_box((-d / 2 + back[1], y(t), floor_z), (back_in, y(w - t), top - (0 if open_top else top_t))))
        spec["back_panel"] = {"thickness_m": mm(back[0]), "inset_m": mm(back[1])}
    # The opening the fronts cover (overlay) or sit in (inset), left/right from the left side.
    open_left, open_right = (fw - ov, w - fw + ov) if frame else (t, w - t)
    open_bottom = max(bottom + (fw if frame else 0.0), floor_z)
    open_top_z = top - max(fw if frame else 0.0, t if open_top else top_t)  # under the top or its rails
    # Rows of fronts, bottom to top: ("doors" | "flap" | "drawer", height share).
    if kind == "wall":
        rows = [("flap" if r.p(0.35) else "doors", 1.0)]
    elif kind == "base":
        rows = r.pick([[("doors", 1.0)], [("doors", 0.78), ("drawer", 0.22)], [("drawer", 0.3), ("drawer", 0.3), ("drawer", 0.4)]])
    else:
        rows = r.pick([[("doors", 1.0)], [("drawer", 0.14), ("drawer", 0.14), ("doors", 0.72)]])
    if inset:
        lo_y, hi_y, lo_z, hi_z = open_left + gap, open_right - gap, open_bottom + gap, open_top_z - gap
    else:
        lo_y = (-ov if frame else 0.0) + gap
        hi_y = w + (ov if frame else 0.0) - gap
        lo_z, hi_z = bottom + gap, top - gap
    rail_h = fw if frame else 0.0
    heights = np.array([share for _, share in rows]) * (hi_z - lo_z - (len(rows) - 1) * (2 * gap + (rail_h if inset else 0)))
    face_x = d / 2 if inset else d / 2 + gap + door_t
    fronts_z, z = [], lo_z
    for (what, _), height in zip(rows, heights):
        fronts_z.append((what, z, z + height))
        z += height + 2 * gap + (rail_h if inset else 0)
    frame_rails = []
    if frame:
        for (_, _, z_top), _next in zip(fronts_z, fronts_z[1:]):
            middle = z_top + gap + (rail_h / 2 if inset else 0.0)
            frame_rails.append(middle - fw / 2)
    shelves = []
    door_rows = [(z0, z1) for what, z0, z1 in fronts_z if what in ("doors", "flap")]
    if door_rows:
        z0, z1 = max(door_rows[0][0], floor_z + 0.05), door_rows[0][1]
        for k in range(r.pick([0, 1, 2])):
            shelf_t = t if r.p(0.5) else r.u(0.022, 0.03)
            shelf_top = z0 + (k + 1) * (z1 - z0) / (r.pick([2, 3]) + k)
            set_back = r.u(0.02, 0.05) + (door_t + gap if inset else 0.0)
            depth = front_x - set_back - back_in
            body.append(_box((back_in, y(t), shelf_top - shelf_t), (back_in + depth, y(w - t), shelf_top)))
            shelves.append({"height_m": mm(shelf_top), "depth_m": mm(depth), "thickness_m": mm(shelf_t)})
    spec["shelves"] = shelves
    if frame:
        x0 = d / 2 - ft
        stiles = []
        body += [
            _box((x0, y(-ov), bottom), (d / 2, y(fw - ov), top)),
            _box((x0, y(w - fw + ov), bottom), (d / 2, y(w + ov), top)),
            _box((x0, y(fw - ov), bottom), (d / 2, y(w - fw + ov), bottom + fw)),
            _box((x0, y(fw - ov), top - fw), (d / 2, y(w - fw + ov), top)),
        ]
        body += [_box((x0, y(fw - ov), z), (d / 2, y(w - fw + ov), z + fw)) for z in frame_rails]
        spec["face_frame"] = {"width_m": mm(fw), "thickness_m": mm(ft), "overhang_m": mm(ov),
                              "rails": [{"bottom_m": mm(z)} for z in frame_rails], "stiles": stiles}
    movers, doors, drawers = [], [], []
    closed_fronts: list[tuple] = []
    limit = r.u(92, 110)
    door_plans = []
    for what, z0, z1 in fronts_z:
        if what == "drawer":
            drawers.append((z0, z1))
        elif what == "flap":
            door_plans.append(("top", lo_y, hi_y, z0, z1))
        else:
            pair = hi_y - lo_y > 0.62
            if pair:
                middle = (lo_y + hi_y) / 2
                door_plans += [("left", lo_y, middle - gap, z0, z1), ("right", middle + gap, hi_y, z0, z1)]
            else:
                door_plans.append((r.pick(["left", "right"]), lo_y, hi_y, z0, z1))
    for hinge, y0, y1, z0, z1 in door_plans:
        closed_fronts.append((face_x - door_t, face_x, y(y0), y(y1), z0, z1))
    for k, (hinge, y0, y1, z0, z1) in enumerate(door_plans):
        others = [b for j, b in enumerate(closed_fronts) if j != k]
        obstacles = [tuple(np.ravel(np.stack(m.bounds).T)) for m in body] + others
        ref = {"left": y(0), "right": y(w), "top": top, "bottom": base}[hinge]
        side = hinge in ("left", "right")
        behind = (0.002, 0.008) if inset else (0.002, 0.016)
        inward = (0.002, 0.008) if inset else (0.0, 0.01)
        mover, tape = hinged_door(
            r, link=f"door_{k}", hinge=hinge, ref=ref, depth_m=d, across=(y(y0), y(y1)) if side else (z0, z1),
            along=(z0, z1) if side else (y(y0), y(y1)), face_x=face_x, thick=door_t, inside=0.0, plug=None,
            obstacles=obstacles, limit_deg=limit, behind=behind, inward=inward, way=way,
        )
        movers.append(mover)
        door = {"hinge": hinge, "left_m": mm(y0), "width_m": mm(y1 - y0), "bottom_m": mm(z0), "height_m": mm(z1 - z0),
                "opening_limit_deg": round(limit), "handle": {"type": "none"}, "hinge_measured": tape}
        if inset:
            door["mounting"] = "inset"
        doors.append(door)
    spec_drawers = []
    for k, (z0, z1) in enumerate(drawers):
        middle = (z0 + z1) / 2
        opening = (
            open_left, open_right,
            max([open_bottom] + [z + fw for z in frame_rails if z + fw <= middle]),
            min([open_top_z] + [z for z in frame_rails if z >= middle]),
        )
        mover, drawer = _drawer(r, k, d=d, w=w, y0=lo_y, y1=hi_y, z0=z0, z1=z1, gap=gap, door_t=door_t, inset=inset,
                                opening=opening, back_in=back_in)
        movers.append(mover)
        if inset:
            drawer["mounting"] = "inset"
        spec_drawers.append(drawer)
    spec["doors"] = doors
    spec["drawers"] = spec_drawers
    return RealPiece(spec, body, movers, voxel_m=0.008 if kind == "tall" else 0.006)


def _drawer(r: _Draw, k: int, *, d, w, y0, y1, z0, z1, gap, door_t, inset, opening, back_in) -> tuple[Mover, dict]:
    """A real drawer: its front, perhaps a second board inside the opening, a box of thin
    walls above the front's bottom edge and beside its middle; and what the guide measures."""
    y = lambda left: -w / 2 + left  # noqa: E731
    open_left, open_right, open_bottom, open_top = opening
    front_in = d / 2 - door_t if inset else d / 2 + gap
    face = front_in + door_t
    wall = r.u(0.012, 0.016)
    runners = r.u(0.008, 0.014)
    box_w = (min(y1, open_right) - max(y0, open_left)) - 2 * runners - r.u(0.0, 0.04)
    middle = (y0 + y1) / 2
    room = (min(y1, open_right) - max(y0, open_left) - box_w) / 2
    offset = r.u(-room, room) if r.p(0.5) else 0.0
    offset = max(-room, min(room, offset))
    low = max(z0, open_bottom) + 0.002
    box_z = low + r.u(0.0, 0.03)
    high = min(z1, open_top) - gap
    box_h = r.u(0.6, 0.95) * (high - box_z)
    board = r.u(0.012, 0.019) if r.p(0.6) else 0.0
    board_inside = r.u(0.005, 0.03) if board and not inset and r.p(0.5) else None
    board_front = front_in if board_inside is None else d / 2 - board_inside
    box_front = board_front - board
    depth = min(r.u(0.3, 0.5), box_front - back_in - 0.01)
    travel = r.u(0.6, 0.8) * depth
    by0, by1 = y(middle + offset - box_w / 2), y(middle + offset + box_w / 2)
    bz1, back_x = box_z + box_h, box_front - depth
    boxes = [_box((front_in, y(y0), z0), (face, y(y1), z1))]
    spec = {"left_m": mm(y0), "width_m": mm(y1 - y0), "bottom_m": mm(z0), "height_m": mm(z1 - z0), "depth_m": mm(depth),
            "travel_m": mm(travel), "handle": {"type": "none"}, "box_bottom_m": mm(box_z - z0), "box_width_m": mm(box_w),
            "box_offset_m": mm(offset), "box_height_m": mm(box_h), "box_wall_m": mm(wall)}
    if board:
        board_top = min(high, bz1 + r.u(0.0, 0.03))
        boxes.append(_box((box_front, by0, box_z), (board_front, by1, board_top)))
        spec |= {"inner_board_m": mm(board), "inner_board_height_m": mm(board_top - box_z)}
        if board_inside is not None:
            spec["inner_board_inside_m"] = mm(board_inside)
    else:
        boxes.append(_box((box_front - wall, by0, box_z), (box_front, by1, bz1)))
    boxes += [
        _box((back_x, by0, box_z), (box_front, by1, box_z + wall)),
        _box((back_x, by0, box_z), (box_front, by0 + wall, bz1)),
        _box((back_x, by1 - wall, box_z), (box_front, by1, bz1)),
        _box((back_x, by0, box_z), (back_x + wall, by1, bz1)),
    ]
    return _slide(f"drawer_{k}", travel, boxes), spec


# ---------------------------------------------------------------------------- appliances


def _appliance_body(w, d, h, t, y) -> list[trimesh.Trimesh]:
    return [
        _box((-d / 2, y(0), 0), (d / 2, y(t), h)),
        _box((-d / 2, y(w - t), 0), (d / 2, y(w), h)),
        _box((-d / 2, y(t), 0), (d / 2, y(w - t), t)),
        _box((-d / 2, y(t), h - t), (d / 2, y(w - t), h)),
        _box((-d / 2, y(t), t), (-d / 2 + t, y(w - t), h - t)),
    ]


def _pocketed_panel(r: _Draw, *, x_face, panel_t, y0, y1, z0, z1, parts, y) -> list[trimesh.Trimesh]:
    """A panel's boxes round rectangular pockets `parts` ((left, height, half w, half h, depth) each,
    margins included), with each pocket's floor."""
    boxes = []
    ys = sorted({y0, y1, *(min(max(v, y0), y1) for p in parts for v in (p[0] - p[2], p[0] + p[2]))})
    zs = sorted({z0, z1, *(min(max(v, z0), z1) for p in parts for v in (p[1] - p[3], p[1] + p[3]))})
    for a, b in zip(ys, ys[1:]):
        for c, e in zip(zs, zs[1:]):
            if b - a < 1e-6 or e - c < 1e-6:
                continue
            hit = [p for p in parts if p[0] - p[2] <= a + 1e-9 and b <= p[0] + p[2] + 1e-9
                   and p[1] - p[3] <= c + 1e-9 and e <= p[1] + p[3] + 1e-9]
            depth = max((p[4] for p in hit), default=0.0)
            boxes.append(_box((x_face - panel_t, y(a), c), (x_face - depth, y(b), e)))
    return boxes


def _button(r: _Draw, *, left, height, panel_t, d, y, room_m: float = 0.035) -> tuple[Mover, dict, tuple]:
    """A rectangular button in a pocket, level with, below or above the face."""
    bw, bh = r.u(0.02, 0.07), r.u(0.012, min(0.035, room_m))
    pocket, margin = r.u(0.009, panel_t - 0.003), r.u(0.001, 0.004)
    projection = r.u(-0.002, 0.004)
    travel = r.u(0.003, min(0.01, projection + pocket - 0.004))
    body = r.u(0.004, projection + pocket - travel)
    face = d / 2 + projection
    button = _box((face - body, y(left - bw / 2), height - bh / 2), (face, y(left + bw / 2), height + bh / 2))
    press = Mover("button_0", "button_0_press", [button], travel,
                  trimesh.transformations.translation_matrix((-travel, 0, 0)))
    spec = {"left_m": mm(left), "height_m": mm(height), "shape": "rectangle", "width_m": mm(bw),
            "button_height_m": mm(bh), "projection_m": mm(projection), "travel_m": mm(travel),
            "body_depth_m": mm(body), "pocket": {"depth_m": mm(pocket), "margin_m": mm(margin)}}
    return press, spec, (left, height, bw / 2 + margin, bh / 2 + margin, pocket)


def _knob(r: _Draw, k: int, *, left, height, diameter, panel_t, d, y, pocket: bool) -> tuple[list, dict, tuple | None]:
    """A knob (a cylinder), perhaps in a round pocket; it is not moved (turning leaves it in place)."""
    projection = r.u(0.015, 0.03)
    spec = {"left_m": mm(left), "height_m": mm(height), "diameter_m": mm(diameter), "projection_m": mm(projection),
            "states": ["off", "1", "2", "3"], "step_deg": 40, "stops": bool(r.p(0.5))}
    sunk = 0.0
    hole = None
    if pocket:
        sunk, margin = r.u(0.004, panel_t - 0.003), r.u(0.002, 0.005)
        spec["pocket"] = {"depth_m": mm(sunk), "margin_m": mm(margin)}
        hole = (left, height, diameter / 2 + margin, diameter / 2 + margin, sunk)
    length = projection + sunk
    knob = trimesh.creation.cylinder(radius=diameter / 2, height=length, sections=48)
    knob.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, (0, 1, 0)))
    knob.apply_translation((d / 2 + projection - length / 2, y(left), height))
    return [knob], spec, hole


def microwave(seed: int, way: str = "open_at_90") -> RealPiece:
    """A thick door partly in the recess, a rectangular button in a pocket, a knob perhaps in
    a pocket, an off-centre plate."""
    r = _Draw(seed)
    w, d, h, t = r.u(0.45, 0.55), r.u(0.34, 0.42), r.u(0.26, 0.32), r.u(0.01, 0.014)
    gap, panel_w, panel_t = 0.003, r.u(0.1, 0.13), r.u(0.014, 0.022)
    y = lambda left: -w / 2 + left  # noqa: E731
    divider = w - panel_w
    body = _appliance_body(w, d, h, t, y)
    body.append(_box((-d / 2 + t, y(divider), t), (d / 2, y(divider + t), h - t)))
    walls = [tuple(np.ravel(np.stack(m.bounds).T)) for m in body]
    press, button, pocket = _button(r, left=divider + panel_w / 2, height=r.u(0.05, 0.09), panel_t=panel_t, d=d, y=y)
    knob_boxes, knob, hole = _knob(r, 0, left=divider + panel_w / 2, height=r.u(0.17, h - 0.05),
                                   diameter=r.u(0.03, min(0.045, panel_w - 0.04)), panel_t=panel_t, d=d, y=y, pocket=r.p(0.5))
    pockets = [pocket] + ([hole] if hole else [])
    body += _pocketed_panel(r, x_face=d / 2, panel_t=panel_t, y0=divider + t, y1=w - t, z0=t, z1=h - t, parts=pockets, y=y)
    body += knob_boxes
    thick, inside = r.u(0.045, 0.07), r.u(0.008, 0.02)
    left, right = gap, divider - gap
    face_x = d / 2 + thick - inside
    plug = (d / 2 - inside, d / 2 + gap, y(t + gap), y(divider - gap), t + gap, h - t - gap)
    limit = r.u(95, 115)
    mover, tape = hinged_door(
        r, link="door_0", hinge="left", ref=y(0), depth_m=d, across=(y(left), y(right)), along=(gap, h - gap),
        face_x=face_x, thick=thick, inside=inside, plug=plug, obstacles=walls,
        limit_deg=limit, behind=(0.01, 0.045), inward=(0.004, 0.02), way=way,
    )
    plate_d = r.u(0.22, min(0.28, divider - t - 0.04, d - t - 0.04))
    cavity = (divider - t, d - t)
    right_off = r.u(-1, 1) * (cavity[0] - plate_d) / 2 * 0.8
    # Back from the door's inner part, which sweeps the cavity's front as it opens.
    back_off = r.u(0.0, 1.0) * (cavity[1] - plate_d) / 2 * 0.8 + max(0.0, plate_d / 2 + inside + 0.03 - cavity[1] / 2)
    raise_m = r.u(0.0, 0.015)
    plate = trimesh.creation.cylinder(radius=plate_d / 2, height=0.006, sections=64)
    plate.apply_translation(((-d / 2 + t + d / 2) / 2 - back_off, y((t + divider) / 2 + right_off), t + raise_m + 0.003))
    body.append(plate)
    spec = {
        "kind": "microwave", "width_m": mm(w), "depth_m": mm(d), "height_m": mm(h), "wall_thickness_m": mm(t),
        "door_gap_m": gap, "turntable_diameter_m": mm(plate_d), "turntable_right_m": mm(right_off),
        "turntable_back_m": mm(back_off), "turntable_raise_m": mm(raise_m),
        "panels": [{"left_m": mm(divider), "width_m": mm(panel_w), "bottom_m": 0, "height_m": mm(h),
                    "thickness_m": mm(panel_t)}],
        "dividers": [{"left_m": mm(divider)}], "knobs": [knob], "buttons": [button],
        "doors": [{"hinge": "left", "left_m": mm(left), "width_m": mm(right - left), "bottom_m": gap,
                   "height_m": mm(h - 2 * gap), "thickness_m": mm(thick), "in_opening_m": mm(inside),
                   "opening_limit_deg": round(limit), "handle": {"type": "none"}, "hinge_measured": tape}],
        "mass_kg": 15,
    }
    return RealPiece(spec, body, [mover, press], voxel_m=0.005)


def oven(seed: int, way: str = "open_at_90") -> RealPiece:
    """A built-in oven: a bottom-hinged thick door partly in the recess, knobs in pockets and a button."""
    r = _Draw(seed)
    w, d, h, t = r.u(0.56, 0.6), r.u(0.5, 0.57), r.u(0.58, 0.6), r.u(0.015, 0.022)
    gap, panel_h, panel_t = 0.003, r.u(0.08, 0.11), r.u(0.018, 0.026)
    y = lambda left: -w / 2 + left  # noqa: E731
    panel_z = h - panel_h
    body = _appliance_body(w, d, h, t, y)
    middle_z = (panel_z + h - t) / 2  # the panel shows between the carcass' top and the cavity
    room = (h - t - panel_z) - 0.012  # for a knob or button and its pocket's margins
    press, button, pocket = _button(r, left=w * 0.5, height=middle_z, panel_t=panel_t, d=d, y=y, room_m=room)
    parts, knobs, pockets = [], [], [pocket]
    pocketed = r.p(0.7)
    for k, left in enumerate((w * 0.15, w * 0.3, w * 0.7, w * 0.85)):
        boxes, knob, hole = _knob(r, k, left=left, height=middle_z, diameter=r.u(0.03, min(0.045, room)),
                                  panel_t=panel_t, d=d, y=y, pocket=pocketed)
        parts += boxes
        knobs.append(knob)
        pockets += [hole] if hole else []
    body += _pocketed_panel(r, x_face=d / 2, panel_t=panel_t, y0=0, y1=w, z0=panel_z, z1=h, parts=pockets, y=y)
    body += parts
    thick, inside = r.u(0.045, 0.065), r.u(0.01, 0.025)
    bottom, top = gap, panel_z - gap
    face_x = d / 2 + thick - inside
    plug = (d / 2 - inside, d / 2 + gap, y(t + gap), y(w - t - gap), t + gap, top)
    mover, tape = hinged_door(
        r, link="door_0", hinge="bottom", ref=0.0, depth_m=d, across=(bottom, top), along=(y(gap), y(w - gap)),
        face_x=face_x, thick=thick, inside=inside, plug=plug, obstacles=[tuple(np.ravel(np.stack(m.bounds).T)) for m in body],
        limit_deg=90, behind=(0.01, 0.035), inward=(0.004, 0.02), way=way,
    )
    spec = {
        "kind": "oven", "width_m": mm(w), "depth_m": mm(d), "height_m": mm(h), "wall_thickness_m": mm(t),
        "door_gap_m": gap, "hob": None, "drawers": [], "shelves": [],
        "panels": [{"left_m": 0, "width_m": mm(w), "bottom_m": mm(panel_z), "height_m": mm(panel_h), "thickness_m": mm(panel_t)}],
        "knobs": knobs, "buttons": [button],
        "doors": [{"hinge": "bottom", "left_m": gap, "width_m": mm(w - 2 * gap), "bottom_m": gap, "height_m": mm(top - bottom),
                   "thickness_m": mm(thick), "in_opening_m": mm(inside), "opening_limit_deg": 90,
                   "handle": {"type": "none"}, "hinge_measured": tape}],
        "mass_kg": 35,
    }
    return RealPiece(spec, body, [mover, press], voxel_m=0.005)


def fridge(seed: int, way: str = "open_at_90") -> RealPiece:
    """A fridge: a thick right- or left-hinged door with bins, a freezer drawer below a divider."""
    r = _Draw(seed)
    w, d, h, t = r.u(0.55, 0.7), r.u(0.6, 0.68), r.u(1.6, 1.9), r.u(0.035, 0.05)
    gap, thick = 0.003, r.u(0.045, 0.07)
    y = lambda left: -w / 2 + left  # noqa: E731
    split = r.u(0.45, 0.6)
    body = _appliance_body(w, d, h, t, y)
    body.append(_box((-d / 2 + t, y(t), split), (d / 2, y(w - t), split + t)))  # the divider shelf
    hinge = r.pick(["left", "right"])
    bottom, top = split + gap, h - gap
    face_x = d / 2 + gap + thick
    obstacles = [tuple(np.ravel(np.stack(m.bounds).T)) for m in body]
    limit = r.u(100, 125)
    for extra in (0.0, 0.01, 0.02, 0.04):  # bins further from the sides until the door swings clear
        bins, bin_specs = [], []
        margin = t + r.u(0.005, 0.015) + extra
        for k in range(r.pick([1, 2, 3])):
            z0 = bottom + 0.15 + k * 0.3
            depth, lip = r.u(0.07, 0.11), r.u(0.04, 0.07)
            bins.append((face_x - thick - depth, face_x - thick, y(gap + margin), y(w - gap - margin), z0, z0 + lip))
            bin_specs.append({"height_m": mm(z0 - bottom), "depth_m": mm(depth), "lip_height_m": mm(lip), "margin_m": mm(margin)})
        try:
            mover, tape = hinged_door(
                r, link="door_0", hinge=hinge, ref=y(0) if hinge == "left" else y(w), depth_m=d,
                across=(y(gap), y(w - gap)), along=(bottom, top), face_x=face_x, thick=thick, inside=0.0, plug=None,
                obstacles=obstacles, limit_deg=limit, behind=(0.005, thick), inward=(0.003, 0.02), way=way,
                carried=tuple(bins),
            )
            break
        except ValueError:
            continue
    del mover.boxes[1:]  # the bins' bounds were for the swing; their sheets follow
    # The bins move with the door (open boxes, as a sheet's bounds: the score is by volume).
    for b in bins:
        x0, x1, y0, y1, z0, z1 = b
        wall = 0.003
        mover.boxes += [_box((x0, y0, z0), (x1, y1, z0 + wall)), _box((x0, y0, z0), (x0 + wall, y1, z1)),
                        _box((x0, y0, z0), (x1, y0 + wall, z1)), _box((x0, y1 - wall, z0), (x1, y1, z1)),
                        _box((x1 - wall, y0, z0), (x1, y1, z1))]
    drawer_mover, drawer = _drawer(r, 0, d=d, w=w, y0=gap, y1=w - gap, z0=gap, z1=split - gap / 2, gap=gap, door_t=thick,
                                   inset=False, opening=(t, w - t, t, split), back_in=-d / 2 + t)
    spec = {
        "kind": "fridge", "width_m": mm(w), "depth_m": mm(d), "height_m": mm(h), "wall_thickness_m": mm(t),
        "door_gap_m": gap, "door_thickness_m": mm(thick), "shelves": [{"height_m": mm(split + t)}],
        "doors": [{"hinge": hinge, "left_m": gap, "width_m": mm(w - 2 * gap), "bottom_m": mm(bottom), "height_m": mm(top - bottom),
                   "opening_limit_deg": round(math.degrees(mover.limit)), "handle": {"type": "none"},
                   "hinge_measured": tape, "shelves": bin_specs}],
        "drawers": [drawer], "mass_kg": 60,
    }
    mover.limit = math.radians(spec["doors"][0]["opening_limit_deg"])
    mover.at_limit = trimesh.transformations.rotation_matrix(
        mover.limit, (0, 0, -1.0 if hinge == "left" else 1.0), mover.axis[0])
    return RealPiece(spec, body, [mover, drawer_mover], voxel_m=0.008)


def dishwasher(seed: int, way: str = "open_at_90") -> RealPiece:
    """A dishwasher: a bottom-hinged door over a kick plate, no racks."""
    r = _Draw(seed)
    w, d, h, t = r.u(0.44, 0.6), r.u(0.55, 0.6), r.u(0.8, 0.87), r.u(0.015, 0.025)
    gap, kick, thick = 0.003, r.u(0.08, 0.12), r.u(0.03, 0.05)
    y = lambda left: -w / 2 + left  # noqa: E731
    body = _appliance_body(w, d, h, t, y)
    body.append(_box((d / 2 - t, y(t), t), (d / 2, y(w - t), kick)))
    bottom, top = kick + gap, h - gap
    face_x = d / 2 + gap + thick
    obstacles = [tuple(np.ravel(np.stack(m.bounds).T)) for m in body]
    mover, tape = hinged_door(
        r, link="door_0", hinge="bottom", ref=0.0, depth_m=d, across=(bottom, top), along=(y(gap), y(w - gap)),
        face_x=face_x, thick=thick, inside=0.0, plug=None, obstacles=obstacles, limit_deg=90,
        behind=(0.005, thick), inward=(0.003, 0.02), way=way,
    )
    spec = {
        "kind": "dishwasher", "width_m": mm(w), "depth_m": mm(d), "height_m": mm(h), "wall_thickness_m": mm(t),
        "door_gap_m": gap, "door_thickness_m": mm(thick), "racks": [],
        "panels": [{"left_m": 0, "width_m": mm(w), "bottom_m": 0, "height_m": mm(kick)}],
        "doors": [{"hinge": "bottom", "left_m": gap, "width_m": mm(w - 2 * gap), "bottom_m": mm(bottom),
                   "height_m": mm(top - bottom), "opening_limit_deg": 90, "handle": {"type": "none"}, "hinge_measured": tape}],
        "mass_kg": 45,
    }
    return RealPiece(spec, body, [mover], voxel_m=0.006)


MAKERS = {"cabinet": cabinet, "microwave": microwave, "oven": oven, "fridge": fridge, "dishwasher": dishwasher}


def random_pieces(count: int, *, seed: int = 0, way: str = "open_at_90") -> list[tuple[str, RealPiece]]:
    """`count` pieces, cabinets about half of them, each from its own seed."""
    names = ["cabinet", "cabinet", "microwave", "oven", "fridge", "dishwasher"]
    pieces = []
    for k in range(count):
        kind = names[k % len(names)]
        pieces.append((f"{kind}_{seed + k}", MAKERS[kind](seed + k, way)))
    return pieces
