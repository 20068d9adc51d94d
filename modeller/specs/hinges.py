"""Where a door really turns: its mounting (overlay, half overlay, inset), its hinge
(`edge`, `concealed`, `pivot`) and, when nobody can see the axis, the tape measurements an
installer takes of the open door, solved for the hinge line.

Every hinge line is two offsets in the closed door's own terms: `behind_face_m`, from the
door's outer face back into (and past) the door, and `in_from_edge_m`, from its hinge-side
edge toward its free edge. A butt hinge on the edge is (0, 0), today's default.

The measurements are taken in the plane square to the hinge line, relative to the body:
"forward" from the carcass's front plane (the front edges of its sides), "out" from the
outer face of what the door hangs on (the side panel's outer face for a left or right hinge,
the top for a top hinge, the underside for a bottom hinge; for a door hung on a middle
panel, that panel's face on the far side from the door), positive away from the door.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

import numpy as np
from pydantic import Field, model_validator

from homemodel.core.yaml_specs import FieldError
from modeller.specs.common import Length, Offset, _Spec

Mounting = Literal["overlay", "half_overlay", "inset"]
HingeType = Literal["edge", "concealed", "pivot"]

# A solved hinge line further than this from the door's edge is a misread tape, not a hinge.
_MAX_OFFSET_M = 0.1
# open_at_90 and free_corner of one door, read to the millimetre, agree this closely (their
# errors are 0.4 and 1.6 mm at most on simulated readings); further apart, the door's
# thickness in the spec is not the door's.
TAPE_AGREEMENT_M = 0.003
# Two faces read to the millimetre give a thickness within 1 mm; further from the spec's, the
# spec's door is not the one measured.
THICKNESS_AGREEMENT_M = 0.002


class HingeLine(_Spec):
    """The hinge line given directly, as offsets from the closed door."""

    behind_face_m: float = Field(description="from the door's outer face back to the axis (may exceed its thickness)")
    in_from_edge_m: float = Field(description="from the door's hinge-side edge toward its free edge to the axis")


class ConcealedHinge(_Spec):
    """A cup hinge (a 35 mm "European" hinge) by its published geometry, as one fixed axis.

    The hinge's linkage is replaced by one fixed axis, in from the door's hinge-side edge by
    the boring distance (the cup's rim nearest that edge, where the arm's knuckle sits). An
    overlay door swings clear of the carcass with the axis as little behind it as that allows:
    its inner face passes the side panel's front corner (which circles the axis) without
    touching it, and, opened to the hinge's full angle, the hinge-side corner of its inner
    face comes no further round than the plane of the side panel's outer face. An inset door
    swings inside its opening: the axis is as far behind its outer face as in from its edge,
    so the edge's outer corner swings out by only (sqrt(2) - 1) times the boring distance.
    On a middle panel a cranked hinge brings the door forward past its neighbour, which no
    fixed axis does: such a door's line is measured. The cup must lie on the door.
    """

    cup_diameter_m: Length = Field(0.035, description="diameter of the cup bored in the door")
    boring_distance_m: Annotated[float, Field(ge=0.002, le=0.009)] = Field(
        0.004, description="from the door's hinge-side edge to the rim of the cup hole (3 to 6 mm usually)"
    )
    opening_deg: Annotated[float, Field(gt=0, le=180)] = Field(110.0, description="the hinge's own opening angle")


class OpenAt90(_Spec):
    """The door opened square (90 degrees, check with a set square), measured with a tape."""

    inner_face_out_m: float = Field(
        description="sideways from the body's hinge-side outer face out to the door's inner face "
        "(negative: the door stands over the opening)"
    )
    edge_forward_m: float = Field(
        description="from the carcass's front plane forward to the door's hinge-side edge "
        "(negative: the edge is behind the front plane)"
    )
    outer_face_out_m: float | None = Field(
        None,
        description="the same way to the door's outer face: with inner_face_out_m it gives the door's thickness, "
        "which the hinge line is then solved with (and the build warns if the spec's differs)",
    )

    @property
    def thickness_m(self) -> float | None:
        """The door's thickness, outer face to inner face, as the square reading says."""
        return None if self.outer_face_out_m is None else self.outer_face_out_m - self.inner_face_out_m


class CornerAt(_Spec):
    """Where the door's free outer corner is, with the door opened part way."""

    forward_m: float = Field(description="from the carcass's front plane forward to the corner")
    out_m: float = Field(description="from the body's hinge-side outer face out to the corner (negative: in front of it)")


class HingeTape(_Spec):
    """Tape measurements of the open door: `open_at_90` or `free_corner` at two openings, or
    both: then `free_corner` (which needs no thickness) places the line and checks the
    thickness `open_at_90` relies on."""

    open_at_90: OpenAt90 | None = None
    free_corner: Annotated[list[CornerAt], Field(min_length=2, max_length=2)] | None = Field(
        None, description="the door's free outer corner at two different openings (say about 45 and 90 degrees)"
    )

    @model_validator(mode="after")
    def _one_way(self) -> HingeTape:
        if self.open_at_90 is not None and self.open_at_90.thickness_m is not None and self.open_at_90.thickness_m <= 0:
            raise FieldError(
                ("open_at_90", "outer_face_out_m"),
                "the door's outer face is out further than its inner face when open square (it is the larger reading)",
            )
        if self.open_at_90 is None and self.free_corner is None:
            raise FieldError((), "give open_at_90 or free_corner (two openings), or both")
        return self


class DoorMount(_Spec):
    """How a door is hung: these fields are mixed into `DoorSpec`."""

    mounting: Mounting = Field(
        "overlay",
        description="overlay / half_overlay: in front of the carcass (or face frame); inset: set into it, "
        "its outer face flush with the front",
    )
    hinge_type: HingeType = Field(
        "edge", description="edge: a butt hinge on the door's edge; concealed: a cup hinge; pivot: pins top and bottom"
    )
    concealed: ConcealedHinge = Field(default_factory=ConcealedHinge)
    pivot_in_from_edge_m: Offset | None = Field(
        None, description="pivot hinge: pin axis in from the hinge-side edge; default: half the door's thickness"
    )
    hinge_line: HingeLine | None = Field(None, description="the hinge line given directly (overrides hinge_type)")
    hinge_measured: HingeTape | None = Field(
        None, description="tape measurements of the open door, solved for the hinge line (overrides hinge_type)"
    )

    @model_validator(mode="after")
    def _one_hinge_line(self) -> DoorMount:
        if self.hinge_line is not None and self.hinge_measured is not None:
            raise FieldError(("hinge_measured",), "give hinge_line or hinge_measured, not both")
        return self


def solve_open_at_90(
    tape: OpenAt90, *, face_forward_m: float, edge_in_m: float, thickness_m: float
) -> tuple[float, float]:
    """(behind_face_m, in_from_edge_m) of the axis that turns the closed door to `tape`.

    In the plane square to the axis, with f forward from the carcass's front plane and s in
    from the hinge-side outer face: the closed door's outer face is at f = `face_forward_m`,
    its hinge-side edge at s = `edge_in_m`, the axis at (face - a, edge + b). Turned 90 degrees outward a point (f, s) goes to
    (f_axis + (s - s_axis), s_axis - (f - f_axis)), so the edge lands at f = face - a - b and
    the inner face at s = edge + b + thickness - a; the two readings give a + b and a - b.
    """
    a_plus_b = face_forward_m - tape.edge_forward_m
    # The inner face stands out (s negative) by inner_face_out_m: -(edge + b + t - a) = out.
    a_minus_b = tape.inner_face_out_m + edge_in_m + thickness_m
    return (a_plus_b + a_minus_b) / 2, (a_plus_b - a_minus_b) / 2


def open_at_90_inner_face_m(
    tape: OpenAt90, *, axis_forward_m: float, axis_in_m: float, edge_in_m: float
) -> float:
    """Where (forward of the front plane) the closed door's inner face must be for `tape` to
    put the axis at (`axis_forward_m`, `axis_in_m` in from the hinge-side outer face): the
    least-squares answer of the two readings (see `solve_open_at_90`: the axis lies at
    ((edge_forward - out - edge_in + inner) / 2, (edge_in - edge_forward - out + inner) / 2))."""
    from_forward = 2 * axis_forward_m - tape.edge_forward_m + tape.inner_face_out_m + edge_in_m
    from_in = 2 * axis_in_m + tape.edge_forward_m + tape.inner_face_out_m - edge_in_m
    return (from_forward + from_in) / 2


def solve_free_corner(
    corners: list[CornerAt], *, face_forward_m: float, edge_in_m: float, width_m: float
) -> tuple[float, float]:
    """(behind_face_m, in_from_edge_m) of the circle's centre through the free outer corner
    closed and at the two measured openings (the axis; no angle needs measuring)."""
    closed = np.array([face_forward_m, edge_in_m + width_m])  # (f, s), s in from the side
    points = [closed] + [np.array([c.forward_m, -c.out_m]) for c in corners]
    (x1, y1), (x2, y2), (x3, y3) = points
    d = 2 * (x1 * (y2 - y3) + x2 * (y3 - y1) + x3 * (y1 - y2))
    if abs(d) < 1e-9:
        raise FieldError(("free_corner",), "the corner's three positions lie on a line; measure two different openings")
    n1, n2, n3 = x1**2 + y1**2, x2**2 + y2**2, x3**2 + y3**2
    centre_f = (n1 * (y2 - y3) + n2 * (y3 - y1) + n3 * (y1 - y2)) / d
    centre_s = (n1 * (x3 - x2) + n2 * (x1 - x3) + n3 * (x2 - x1)) / d
    return face_forward_m - centre_f, centre_s - edge_in_m


def check_hinge_offsets(offsets: tuple[float, float], field: str) -> None:
    """A solved line this far from the door's edge comes from a misread tape."""
    behind, inward = offsets
    if not (math.isfinite(behind) and math.isfinite(inward)) or max(abs(behind), abs(inward)) > _MAX_OFFSET_M:
        raise FieldError(
            ("hinge_measured", field),
            f"the measurements put the hinge line {behind * 1000:.0f} mm behind the door's face and "
            f"{inward * 1000:.0f} mm in from its edge; re-measure",
        )
