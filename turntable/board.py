"""The AprilTag board on the turntable: `board.yaml`, its layout, and tag corners in the table frame.

The table frame is the board's frame: x and y in the table top, z up out of it. Every tag
lies flat (z = 0) with its edges parallel to x and y; the top row of a tag's image points
towards +y, so its corners in OpenCV's ArUco order (top-left, top-right, bottom-right,
bottom-left, clockwise in the image) are (-h, +h), (+h, +h), (+h, -h), (-h, -h) about its
centre, h being half the tag size. `tag_size_m` is the edge of the black square (8 cells of
tag36h11: 6 data bits and a one-cell black border); one more white cell around it is the
quiet zone the detectors need.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pydantic

from homemodel.core.yaml_specs import FieldError, load_yaml_spec, write_yaml

TAG_FAMILY = "tag36h11"
TAG_CELLS = 8  # black square of tag36h11, in cells
TAG36H11_COUNT = 587
# A tag's four corners about its centre, in units of half the tag size, ArUco order.
_CORNER_SIGNS = np.array([[-1.0, 1.0], [1.0, 1.0], [1.0, -1.0], [-1.0, -1.0]])


class BoardTag(pydantic.BaseModel):
    model_config = pydantic.ConfigDict(extra="forbid")

    id: int = pydantic.Field(ge=0, lt=TAG36H11_COUNT)
    center_m: tuple[pydantic.FiniteFloat, pydantic.FiniteFloat]


class Board(pydantic.BaseModel):
    """The contents of `board.yaml`."""

    model_config = pydantic.ConfigDict(extra="forbid")

    family: str = TAG_FAMILY
    tag_size_m: pydantic.PositiveFloat = pydantic.Field(allow_inf_nan=False)
    tags: list[BoardTag] = pydantic.Field(min_length=1)
    # Written by `homemodel turntable board`; optional for boards made by other tools.
    table_diameter_m: pydantic.PositiveFloat | None = pydantic.Field(default=None, allow_inf_nan=False)

    @pydantic.field_validator("family")
    @classmethod
    def _known_family(cls, family: str) -> str:
        if family != TAG_FAMILY:
            raise ValueError(f"only {TAG_FAMILY} is supported, got {family!r}")
        return family

    @pydantic.model_validator(mode="after")
    def _distinct_tags(self) -> Board:
        seen: dict[int, int] = {}
        for index, tag in enumerate(self.tags):
            if tag.id in seen:
                raise FieldError(("tags", index, "id"), f"tag id {tag.id} repeats (also tags.{seen[tag.id]})")
            seen[tag.id] = index
        centers = np.array([t.center_m for t in self.tags])
        if len(centers) > 1:
            gaps = np.linalg.norm(centers[:, None] - centers[None], axis=-1) + np.eye(len(centers)) * 1e9
            i, j = np.unravel_index(np.argmin(gaps), gaps.shape)
            # Two tags closer than a tag's edge overlap: the board cannot be printed that way.
            if np.max(np.abs(centers[i] - centers[j])) < self.tag_size_m:
                raise FieldError(("tags", int(max(i, j)), "center_m"), f"overlaps tag id {self.tags[min(i, j)].id}")
        return self

    def corners_table(self) -> dict[int, np.ndarray]:
        """Each tag's four corners, (4, 3) in the table frame, in ArUco corner order."""
        centers = np.array([tag.center_m for tag in self.tags], dtype=np.float64)  # all at once: called per frame
        corners = np.zeros((len(self.tags), 4, 3))
        corners[..., :2] = centers[:, None] + _CORNER_SIGNS * (self.tag_size_m / 2)
        return dict(zip((tag.id for tag in self.tags), corners))

    @property
    def radius_m(self) -> float:
        """The table's radius: given, or the farthest tag corner from the board's origin."""
        if self.table_diameter_m is not None:
            return self.table_diameter_m / 2
        corners = np.concatenate(list(self.corners_table().values()))
        return float(np.max(np.linalg.norm(corners[:, :2], axis=1)))


def load_board(path: Path) -> Board:
    return load_yaml_spec(Path(path), Board)


def save_board(board: Board, path: Path) -> None:
    data = board.model_dump(exclude_none=True)
    data["tags"] = [{"id": t["id"], "center_m": [round(v, 9) for v in t["center_m"]]} for t in data["tags"]]
    write_yaml(Path(path), data, flow_style=None)


def grid_board(*, table_diameter_m: float, tag_size_m: float, gap_cells: int = 2, first_id: int = 0) -> Board:
    """A square grid of tags covering a round table, each tag with its quiet zone inside the disc.

    The pitch is the tag plus `gap_cells` cells (two cells keep one white cell around each
    tag); ids run row by row from the +y edge. The board's origin is the table's centre.
    """
    if not (math.isfinite(table_diameter_m) and table_diameter_m > 0):
        raise ValueError(f"the table diameter {table_diameter_m:g} m must be positive")
    if not (math.isfinite(tag_size_m) and 0 < tag_size_m < table_diameter_m / 2):
        raise ValueError(
            f"the tag size {tag_size_m:g} m must be positive and below half the table diameter ({table_diameter_m:g} m)"
        )
    cell = tag_size_m / TAG_CELLS
    pitch = tag_size_m + gap_cells * cell
    outer_half = tag_size_m / 2 + cell  # the tag with its quiet zone
    radius = table_diameter_m / 2
    n = int(radius // pitch) + 1
    centers = []
    for row in range(n, -n - 1, -1):
        for col in range(-n, n + 1):
            center = np.array([col * pitch, row * pitch])
            farthest = np.abs(center) + outer_half
            if np.hypot(*farthest) <= radius:
                centers.append((float(center[0]), float(center[1])))
    if not centers:
        raise ValueError(f"no {tag_size_m:g} m tag fits on a {table_diameter_m:g} m table")
    # Checked before the tags are made: BoardTag's own check would say it in pydantic's words.
    if first_id < 0:
        raise ValueError(f"the first id {first_id} must be 0 or more ({TAG_FAMILY}'s ids are 0-{TAG36H11_COUNT - 1})")
    if first_id + len(centers) > TAG36H11_COUNT:
        raise ValueError(
            f"{len(centers)} tags from the first id {first_id} exceed {TAG_FAMILY}'s {TAG36H11_COUNT} ids "
            f"(0-{TAG36H11_COUNT - 1})"
        )
    tags = [BoardTag(id=first_id + i, center_m=center) for i, center in enumerate(centers)]
    return Board(tag_size_m=tag_size_m, tags=tags, table_diameter_m=table_diameter_m)


def tag_bits(tag_id: int) -> np.ndarray:
    """The tag's 8x8 black square as booleans (True = white), top row first, from OpenCV's dictionary."""
    import cv2

    dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
    image = cv2.aruco.generateImageMarker(dictionary, tag_id, TAG_CELLS, borderBits=1)
    return image > 127
