"""Draw `tape_guide.png`: where an installer holds the tape to find a concealed hinge's axis
(README, "Measuring a door's hinge line"). Seen from above, a left-hinged overlay door on a
carcass' left side; the readings are simulated from a known axis and solved with the
modeller's own solver, so the picture shows the numbers the spec would get. The third
panel is a thick appliance door with part of it inside the opening: the thickness
`open_at_90` needs, and how far the door reaches in.

    .venv/bin/python docs/images/tape_guide.py
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from modeller.specs.hinges import CornerAt, OpenAt90, solve_free_corner, solve_open_at_90  # noqa: E402

# Millimetres: door 18 thick, 2 mm in front of the carcass, its edge 2 mm in from the side's
# outer face; the true axis 26 mm behind its face and 5 mm in from its edge.
THICK, GAP, EDGE_IN, SIDE, WIDTH = 18.0, 2.0, 2.0, 18.0, 400.0
BEHIND, INWARD = 26.0, 5.0
FACE = GAP + THICK


def turned(points: np.ndarray, angle_deg: float) -> np.ndarray:
    """(f forward, s in from the side) points of the door turned open about the true axis."""
    axis = np.array([FACE - BEHIND, EDGE_IN + INWARD])
    a = math.radians(angle_deg)
    rel = points - axis
    return axis + np.stack([rel[:, 0] * math.cos(a) + rel[:, 1] * math.sin(a), rel[:, 1] * math.cos(a) - rel[:, 0] * math.sin(a)], 1)


def door(angle_deg: float) -> np.ndarray:
    corners = np.array([[FACE, EDGE_IN], [FACE, EDGE_IN + WIDTH], [FACE - THICK, EDGE_IN + WIDTH], [FACE - THICK, EDGE_IN]])
    return turned(corners, angle_deg)


def plot_xy(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Figure axes: x = out from the side to the left (negative s), y = forward."""
    return -points[:, 1], points[:, 0]


def carcass(ax) -> None:
    ax.add_patch(plt.Rectangle((-SIDE, -120), SIDE, 120, color="0.75", zorder=1))
    ax.axhline(0, color="0.4", ls="--", lw=0.8)
    ax.axvline(0, color="0.4", ls="--", lw=0.8)
    ax.text(-SIDE / 2, -30, "side", ha="center", va="center", fontsize=8, rotation=90)
    ax.text(-66, -5, "carcass front plane", fontsize=7, color="0.3", va="top")

    closed = door(0)
    ax.fill(*plot_xy(closed), facecolor="none", edgecolor="0.5", ls=":", zorder=2)


def dimension(ax, start, end, label, colour, label_at) -> None:
    ax.annotate("", xy=end, xytext=start, arrowprops={"arrowstyle": "<->", "color": colour, "lw": 1.4})
    ax.plot(*zip(start, end), color=colour, lw=0.6)
    ax.text(*label_at, label, color=colour, fontsize=8)


def thick_door(ax) -> None:
    """A microwave's door, 65 mm from its outer face to its inner part's face, 16 mm of it
    inside the cavity's recess when closed; opened square about its axis."""
    thick, inside, gap, wall, width = 65.0, 16.0, 3.0, 12.0, 120.0
    face = thick - inside
    axis = np.array([face - 31.0, 3.0 + 12.0])
    slab = np.array([[face, 3.0], [face, 3.0 + width], [gap, 3.0 + width], [gap, 3.0]])
    plug = np.array([[gap, wall + gap], [gap, 3.0 + width], [-inside, 3.0 + width], [-inside, wall + gap]])

    def opened(points: np.ndarray) -> np.ndarray:
        rel = points - axis
        return axis + np.stack([rel[:, 1], -rel[:, 0]], 1)  # turned 90 degrees outward

    ax.add_patch(plt.Rectangle((-wall, -80), wall, 80, color="0.75", zorder=1))
    ax.axhline(0, color="0.4", ls="--", lw=0.8)
    ax.axvline(0, color="0.4", ls="--", lw=0.8)
    ax.text(-wall / 2, -40, "side", ha="center", va="center", fontsize=8, rotation=90)
    for part in (slab, plug):
        ax.fill(*plot_xy(part), facecolor="none", edgecolor="0.5", ls=":", zorder=2)
        ax.fill(*plot_xy(opened(part)), color="#8c8c8c" if part is slab else "#b0b0b0", zorder=3)
    ax.plot(*plot_xy(axis[None]), "o", color="red", zorder=5)
    open_slab, open_plug = opened(slab), opened(plug)
    across = -open_slab[0, 1], -open_plug[2, 1]
    dimension(ax, (across[0], 140), (across[1], 140), "", "tab:orange", (0, 0))
    ax.text(-95, 150, f"thickness_m = {thick / 1000:.3f}: across the hinge-side\nedge, outer face to the innermost face", color="tab:orange", fontsize=8)
    dimension(ax, (60, 0), (60, face), "", "tab:brown", (0, 0))
    ax.text(64, 8, f"closed, the face stands\n{face / 1000:.3f} out: in_opening_m =\n{thick / 1000:.3f} - {face / 1000:.3f} = {inside / 1000:.3f}", color="tab:brown", fontsize=8)
    inner_out = -open_plug[2:, 1].max()
    dimension(ax, (0, -6), (inner_out, -6), "", "tab:blue", (0, 0))
    ax.text(-95, -65, f"inner_face_out_m\n= {inner_out / 1000:.3f} (to the\ninnermost face)", color="tab:blue", fontsize=8)
    ax.set_title("a thick door, part of it in the opening", fontsize=10)
    ax.set_xlim(-100, 165)
    ax.set_ylim(-80, 175)


def main() -> None:
    fig, (left, right, third) = plt.subplots(1, 3, figsize=(16, 5.4))
    # Left: opened square. Readings from the true axis, then solved as the spec solves them.
    carcass(left)
    open_door = door(90)
    left.fill(*plot_xy(open_door), color="#d9b38c", zorder=3)
    inner_out = -open_door[2:, 1].max()
    edge_forward = open_door[[0, 3], 0].max()
    dimension(left, (0, 40), (inner_out, 40), f"inner_face_out_m = {inner_out / 1000:.3f}\n(side's outer face to\nthe door's inner face)", "tab:blue", (22, 35))
    outer_out = -open_door[:2, 1].min()  # the same way to the outer face: the two differ by the thickness
    dimension(left, (0, 52), (outer_out, 52), "", "tab:purple", (0, 0))
    left.text(-68, 28, f"outer_face_out_m\n= {outer_out / 1000:.3f} (outer -\ninner = thickness)", color="tab:purple", fontsize=8)
    hinge_edge_x = -open_door[0, 1]
    dimension(left, (hinge_edge_x, 0), (hinge_edge_x, edge_forward), "", "tab:green", (0, 0))
    left.text(22, -22, f"edge_forward_m = {edge_forward / 1000:.3f}\n(front plane to the door's\nhinge-side edge; behind: -)", color="tab:green", fontsize=8)
    a, b = solve_open_at_90(
        OpenAt90(inner_face_out_m=inner_out / 1000, edge_forward_m=edge_forward / 1000),
        face_forward_m=FACE / 1000,
        edge_in_m=EDGE_IN / 1000,
        thickness_m=THICK / 1000,
    )
    axis = np.array([[FACE - a * 1000, EDGE_IN + b * 1000]])
    left.plot(*plot_xy(axis), "o", color="red", zorder=5)
    left.text(-68, -45, f"hinge line (solved):\n{a * 1000:.0f} mm behind the door's face,\n{b * 1000:.0f} mm in from its edge", color="red", fontsize=8)
    left.set_title("door opened square (check with a set square)", fontsize=10)
    # Right: the free outer corner at two openings; no angle needs reading.
    carcass(right)
    readings = []
    for angle, shade in ((45, "#ecd5bd"), (95, "#d9b38c")):
        opened = door(angle)
        right.fill(*plot_xy(opened), color=shade, zorder=3)
        corner = opened[1]
        readings.append(CornerAt(forward_m=corner[0] / 1000, out_m=-corner[1] / 1000))
        x, y = plot_xy(corner[None])
        right.plot(x, y, "s", color="tab:purple", zorder=5)
        right.annotate("", xy=(x[0], y[0]), xytext=(x[0], 0), arrowprops={"arrowstyle": "<->", "color": "tab:green"})
        right.annotate("", xy=(x[0], y[0]), xytext=(0, y[0]), arrowprops={"arrowstyle": "<->", "color": "tab:blue"})
        right.text(x[0] + 4, y[0] + 6, f"{angle} deg: forward_m {corner[0] / 1000:.3f},\nout_m {-corner[1] / 1000:.3f}", fontsize=8, color="tab:purple")
    a2, b2 = solve_free_corner(readings, face_forward_m=FACE / 1000, edge_in_m=EDGE_IN / 1000, width_m=WIDTH / 1000)
    axis2 = np.array([[FACE - a2 * 1000, EDGE_IN + b2 * 1000]])
    right.plot(*plot_xy(axis2), "o", color="red", zorder=5)
    right.text(-200, -60, "hinge line (solved): the circle's centre\nthrough the closed and both open corners", color="red", fontsize=8)
    right.set_title("free outer corner at two openings (free_corner)", fontsize=10)
    left.set_xlim(-70, 70)
    left.set_ylim(-60, 60)
    right.set_xlim(-420, 60)
    right.set_ylim(-125, 440)
    thick_door(third)
    for ax in (left, right, third):
        ax.set_aspect("equal")
        ax.set_xlabel("mm, out from the side's outer face (into the cabinet: negative)", fontsize=8)
        ax.set_ylabel("mm, forward of the carcass front", fontsize=8)
        ax.tick_params(labelsize=7)
    fig.suptitle("Seen from above: a left-hinged door, where to hold the tape", fontsize=11)
    fig.tight_layout()
    fig.savefig(Path(__file__).with_name("tape_guide.png"), dpi=110)


if __name__ == "__main__":
    main()
