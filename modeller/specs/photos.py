"""Photo textures in a spec: which face of which part a photo shows, and where in the photo.

Any kind of spec may list `photos:`; each entry puts (part of) one photo on one face of one
part of the built model. A part is a Blender object of the build, named as a link (`body`,
`door_0`, `drawer_1`) or a piece of one (`body.shelf_0`, `drawer_0.box`); which parts a kind
has is only known once it is built, so an unknown part is refused then, with the valid ones.

Faces of a part are named in the part's own frame, which for every kind is the model's
convention (+x out of the front, +y to the object's left, +z up):

| face   | normal | the photo's "up" (image top) | the photo's "right" |
| ------ | ------ | ---------------------------- | ------------------- |
| front  | +x     | +z                           | +y                  |
| back   | -x     | +z                           | -y                  |
| left   | -y     | +z                           | +x                  |
| right  | +y     | +z                           | -x                  |
| top    | +z     | -x (front at the bottom)     | +y                  |
| bottom | -z     | +x (front at the top)        | +y                  |

"left" and "right" are as the installer standing in front of the object sees them (their
left hand is at -y). The face is the part's outermost surface facing that way; its
rectangle is the extent of the part's faces there.

`wrap` is the round side of a part that is round about one of its axes (`wrap_axis`, z by
default: a cup's or a bottle's side). Angles about the axis run from +x towards +y for z
(from +y towards +z for x, from +z towards +x for y). The photo shows a band of the side:
`wrap_span_deg` wide, centred on the direction `wrap_centre_deg`, over the part's full
height (or `wrap_range_m`). Its four corners are the band's corners as seen in the photo:
for `wrap_projection: side_view` (a photo of the round object itself, taken from far
enough to be nearly orthographic, looking at the axis from `wrap_centre_deg`) they are
where the band's left and right edges meet its top and bottom, usually the silhouette
(span 180); for `flat` (a photo of the label laid flat, or a scan) they are the label's
corners. The rest of the side keeps the part's colour.

Corners are pixel coordinates (x right, y down, pixel centres at integers) in the order
top-left, top-right, bottom-right, bottom-left as seen looking at the face, i.e. clockwise
in the image. `region_px` instead gives a box (x_min, y_min, x_max, y_max) in which the
face's outline is detected (the largest convex four-cornered contour).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from homemodel.core.yaml_specs import FieldError

FaceName = Literal["front", "back", "left", "right", "top", "bottom", "+x", "-x", "+y", "-y", "+z", "-z", "wrap"]

# (normal, image up) of each planar face in the part's frame; image right = up x normal.
FACE_DIRECTIONS: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {
    "+x": ((1, 0, 0), (0, 0, 1)),
    "-x": ((-1, 0, 0), (0, 0, 1)),
    "-y": ((0, -1, 0), (0, 0, 1)),
    "+y": ((0, 1, 0), (0, 0, 1)),
    "+z": ((0, 0, 1), (-1, 0, 0)),
    "-z": ((0, 0, -1), (1, 0, 0)),
}
FACE_AXES = {"front": "+x", "back": "-x", "left": "-y", "right": "+y", "top": "+z", "bottom": "-z"}

# Below these a quadrilateral is too small to rectify anything from.
MIN_EDGE_PX = 4.0
MIN_AREA_PX2 = 64.0

PointPx = tuple[float, float]
_WRAP_FIELDS = ("wrap_axis", "wrap_centre_deg", "wrap_span_deg", "wrap_projection", "wrap_range_m")


def quad_problem(corners: np.ndarray) -> str | None:
    """Why four corners (top-left, top-right, bottom-right, bottom-left; y down) cannot be a face."""
    edges = np.roll(corners, -1, axis=0) - corners
    lengths = np.linalg.norm(edges, axis=1)
    if lengths.min() < MIN_EDGE_PX:
        return f"two corners are {lengths.min():.1f} px apart; the face needs edges of at least {MIN_EDGE_PX:g} px"
    # With y down, a clockwise turn at every corner has a positive cross product.
    turns = edges[:, 0] * np.roll(edges, -1, axis=0)[:, 1] - edges[:, 1] * np.roll(edges, -1, axis=0)[:, 0]
    if np.all(turns < 0):
        return "the corners run anticlockwise: give them as top-left, top-right, bottom-right, bottom-left"
    if not np.all(turns > 0):
        return "the corners do not form a convex quadrilateral (crossed or dented outline)"
    area = 0.5 * abs(
        np.dot(corners[:, 0], np.roll(corners[:, 1], -1)) - np.dot(corners[:, 1], np.roll(corners[:, 0], -1))
    )
    if area < MIN_AREA_PX2:
        return f"the quadrilateral covers {area:.1f} px^2, under the {MIN_AREA_PX2:g} px^2 needed"
    return None


class FacePhoto(BaseModel):
    """One photo put on one face of one part of the model."""

    # As `modeller.specs.common._Spec` (which imports this module, so cannot be its base).
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    part: str = Field(
        min_length=1,
        description="name of a part of the built model: a link (`body`, `door_0`, `drawer_1`) or a piece of one "
        "(`body.shelf_0`); an unknown name is refused with the list of the kind's parts",
    )
    face: FaceName = Field(
        description="face of the part in its own frame: front|back|left|right|top|bottom (= +x|-x|-y|+y|+z|-z), "
        "or wrap for the round side of a part round about `wrap_axis`"
    )
    photo: Path = Field(description="PNG or JPEG image, relative to the spec file's folder")
    corners_px: tuple[PointPx, PointPx, PointPx, PointPx] | None = Field(
        None,
        description="the face's corners in the photo, [x, y] pixels (x right, y down), in the order top-left, "
        "top-right, bottom-right, bottom-left as seen looking at the face; give this or region_px",
    )
    region_px: tuple[float, float, float, float] | None = Field(
        None,
        description="[x_min, y_min, x_max, y_max] pixels of a box holding the face, whose outline (the largest "
        "convex four-cornered contour) is detected there; give this or corners_px",
    )
    wrap_axis: Literal["x", "y", "z"] = Field("z", description="wrap only: the axis the part is round about")
    wrap_centre_deg: float = Field(
        0.0, description="wrap only: direction of the middle of the photographed band, about wrap_axis"
    )
    wrap_span_deg: Annotated[float, Field(gt=0, le=360)] = Field(
        180.0, description="wrap only: angular width of the photographed band (at most 180 for side_view)"
    )
    wrap_projection: Literal["side_view", "flat"] = Field(
        "side_view",
        description="wrap only: side_view, a photo of the round side itself (columns unrolled as sin of the "
        "angle); flat, a photo of the label laid flat (columns linear in the angle)",
    )
    wrap_range_m: tuple[float, float] | None = Field(
        None,
        description="wrap only: [low, high] along wrap_axis in the part's frame that the band covers; "
        "default: the whole round side",
    )

    @property
    def face_axis(self) -> str:
        """`+x`.. for planar faces, `wrap` for the round side."""
        return FACE_AXES.get(self.face, self.face)

    @model_validator(mode="after")
    def _consistent(self) -> FacePhoto:
        if (self.corners_px is None) == (self.region_px is None):
            raise FieldError(("corners_px",), "give the face's corners_px or a region_px to find them in, not both")
        if self.corners_px is not None:
            problem = quad_problem(np.asarray(self.corners_px, dtype=np.float64))
            if problem is not None:
                raise FieldError(("corners_px",), problem)
        if self.region_px is not None:
            x_min, y_min, x_max, y_max = self.region_px
            if x_max - x_min < MIN_EDGE_PX or y_max - y_min < MIN_EDGE_PX:
                raise FieldError(
                    ("region_px",), f"region {list(self.region_px)} is empty: give x_min, y_min, x_max, y_max"
                )
        if self.face != "wrap":
            given = [name for name in _WRAP_FIELDS if name in self.model_fields_set]
            if given:
                raise FieldError((given[0],), f"only for face: wrap, not for face: {self.face}")
            return self
        if self.wrap_projection == "side_view" and self.wrap_span_deg > 180:
            raise FieldError(
                ("wrap_span_deg",),
                f"a photo of a round side shows at most 180 deg, not {self.wrap_span_deg:g}; "
                "use wrap_projection: flat for a label photographed flat",
            )
        if self.wrap_range_m is not None and not self.wrap_range_m[0] < self.wrap_range_m[1]:
            raise FieldError(("wrap_range_m",), f"low {self.wrap_range_m[0]} is not below high {self.wrap_range_m[1]}")
        return self
