"""Which transfer curve a capture's 8-bit colour was encoded with, linear or sRGB, measured from
its tags.

The tag edges are refined where the intensity crosses half-way between black and white, which
is the edge itself for a blur symmetric in linear light (`turntable.tags.refine_edges`). Read
with the wrong curve the crossing moves into the black (an sRGB image read as linear) or into
the white (a linear image read as sRGB), on every black/white edge alike: a tag's black square
comes out smaller or larger, and so do its black cells inside. The tag's cells are a regular
grid, so the square its refined sides make says where each inner edge between a black and a
white cell lies: with the right curve the edges are found there, with the wrong one each lies
a fraction of a pixel towards the white or the black. On readme_check's bottle recordings
(640 x 360), linear and sRGB-encoded: 0.000-0.005 px off with the right curve, 0.14-0.26 px
with the wrong one. Real cameras' tone curves need not be either (below).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Literal

import numpy as np

from turntable.board import TAG_CELLS, tag_bits
from turntable.capture import Capture, FrameError, read_color
from turntable.tags import LINEAR_LEVELS, DetectionOptions, bilinear_levels, detect_tags, profile_crossings, refine_edges

ColorEncoding = Literal["linear", "srgb"]
ENCODINGS: tuple[ColorEncoding, ...] = ("linear", "srgb")

_ACROSS = np.linspace(-0.45, 0.45, 37)  # each inner edge's profile, in cells (clear of the next edge a cell away)
_ALONG = np.array([-0.2, 0.0, 0.2])  # profiles along each edge, in cells from its middle
_LEVEL_SAMPLES = 4  # at either end of a profile, averaged for its black and white levels
_MIN_CONTRAST = 0.02  # of full scale, between a profile's two levels
_CLIPPED = 250  # 8-bit level: a profile reaching it is left out
_MEASURED_FRAMES = 8  # spread over the capture: single real photos scatter widely (below)
# Linear is taken only when the measure says so clearly: cameras deliver sRGB, and single real
# photos (the swatbotics iPhone JPEGs, sRGB) read -0.45 to +0.02 px as linear and +0.03 to +0.39
# as sRGB, some looking linear; 8 of them together read -0.06 to -0.22 as linear. The simulator's
# linear recordings read within 0.032 px as linear and 0.12-0.26 px as sRGB (8 frames).
_LINEAR_WITHIN_PX = 0.04  # the linear reading's offset at most this ...
_SRGB_BEYOND_PX = 0.1  # ... and the sRGB reading's this far into the white (and sRGB's own
# reading within this, the linear one this far into the black, for sRGB to count as measured)
_MIN_EDGES = 200  # clear edge profiles a reading needs (a paper white clipped all over leaves few)


@dataclass(frozen=True, kw_only=True)
class EncodingDecision:
    encoding: ColorEncoding
    decided_by: str
    # Per curve, the median distance (px) of the tags' inner cell edges towards their white
    # cell from where the tags' refined sides put them: the curve nearer 0 is taken.
    cell_edge_offset_px: dict[str, float] | None = None
    cell_edges: int = 0  # edge profiles measured

    def figures(self) -> dict:
        return {
            "color_encoding": self.encoding,
            "decided_by": self.decided_by,
            "cell_edge_offset_px": self.cell_edge_offset_px,
            "cell_edges": self.cell_edges,
        }


@lru_cache(maxsize=None)
def _inner_edges(tag_id: int) -> tuple[np.ndarray, np.ndarray]:
    """The tag's edges between a black and a white cell inside its black square: (E, 2) middles
    and (E, 2) unit normals towards the white cell, in cells (u right, v down from the square's
    top-left corner, as its bits are laid out)."""
    bits = tag_bits(tag_id)
    middles, normals = [], []
    for step in ((1, 0), (0, 1)):  # (du, dv): the cell right of, then below, each cell
        v, u = np.nonzero(bits[: TAG_CELLS - step[1], : TAG_CELLS - step[0]] != bits[step[1] :, step[0] :])
        white_after = bits[v + step[1], u + step[0]]
        middles.append(np.column_stack([u + 0.5 + step[0] / 2, v + 0.5 + step[1] / 2]))
        normals.append(np.where(white_after[:, None], 1.0, -1.0) * np.array(step, dtype=np.float64))
    return np.concatenate(middles), np.concatenate(normals)


def cell_edge_offsets_px(gray: np.ndarray, detections: dict[int, np.ndarray], encoding: ColorEncoding) -> np.ndarray:
    """Each clear inner-edge profile's offset (px) towards its white cell from where the tag's
    square puts it, the tags' sides refined and the profiles read with `encoding`; `detections`:
    tag id -> (4, 2) corners as detected (ArUco order: the square's top-left first)."""
    import cv2

    levels = LINEAR_LEVELS[encoding]
    ids = sorted(detections)
    squares = refine_edges(gray, np.stack([detections[i] for i in ids]), levels)
    unit_square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float32) * TAG_CELLS
    points = []
    for tag_id, corners in zip(ids, squares):
        middles, normals = _inner_edges(tag_id)
        along = normals[:, ::-1]  # the edge's own direction (either way)
        cells = (
            middles[:, None, None, :]
            + _ALONG[None, :, None, None] * along[:, None, None, :]
            + _ACROSS[None, None, :, None] * normals[:, None, None, :]
        )  # (E, A, M, 2)
        homography = cv2.getPerspectiveTransform(unit_square, corners.astype(np.float32))
        points.append(cv2.perspectiveTransform(cells.reshape(1, -1, 2), homography)[0].reshape(-1, len(_ACROSS), 2))
    pixels = np.concatenate(points)  # (P, M, 2)
    profiles = bilinear_levels(gray, levels, pixels[..., 0], pixels[..., 1])
    at, fraction, usable = profile_crossings(profiles, _LEVEL_SAMPLES, _MIN_CONTRAST)
    clipped = profiles.max(axis=1) >= levels[_CLIPPED]  # a white clipped by the exposure is no level
    clear = usable & ~clipped
    crossing = _ACROSS[at % len(_ACROSS)] + fraction * (_ACROSS[1] - _ACROSS[0])
    px_per_cell = np.linalg.norm(pixels[:, -1] - pixels[:, 0], axis=-1) / (_ACROSS[-1] - _ACROSS[0])
    return (crossing * px_per_cell)[clear]


def measured_encoding(grays: list[np.ndarray], detection: DetectionOptions) -> EncodingDecision | None:
    """The encoding with which the inner cell edges of the tags in `grays` lie where the tags'
    squares put them, when the two curves' readings say so clearly; else sRGB, assumed. None when
    no image shows a tag."""
    offsets: dict[str, list[np.ndarray]] = {e: [] for e in ENCODINGS}
    options = DetectionOptions(detector=detection.detector, max_hamming=detection.max_hamming, edge_refinement=False)
    for gray in grays:
        if found := detect_tags(gray, options):
            for encoding in ENCODINGS:
                offsets[encoding].append(cell_edge_offsets_px(gray, found, encoding))
    measured = {e: np.concatenate(o) if o else np.zeros(0) for e, o in offsets.items()}
    count = min(len(o) for o in measured.values())
    if count == 0:
        return None
    medians = {e: float(np.median(o)) for e, o in measured.items()}
    linear, srgb = medians["linear"], medians["srgb"]
    if count < _MIN_EDGES:
        encoding, decided_by = "srgb", f"assumed, as cameras deliver it: {count} clear cell edges, {_MIN_EDGES} needed"
    elif abs(linear) <= _LINEAR_WITHIN_PX and srgb >= _SRGB_BEYOND_PX:
        encoding, decided_by = "linear", "measured: the tags' cell edges"
    elif abs(srgb) <= _SRGB_BEYOND_PX and linear <= -_SRGB_BEYOND_PX:
        encoding, decided_by = "srgb", "measured: the tags' cell edges"
    else:
        encoding, decided_by = "srgb", "assumed, as cameras deliver it: the tags' cell edges unclear"
    return EncodingDecision(
        encoding=encoding,
        decided_by=decided_by,
        cell_edge_offset_px={e: round(v, 3) for e, v in medians.items()},
        cell_edges=count,
    )


def capture_encoding(capture: Capture, chosen: str, detection: DetectionOptions) -> EncodingDecision:
    """The encoding `chosen` ("linear" or "srgb"), or for "auto" the capture's: a simulated
    capture's renders are linear (not measured: the benchmarks' captures pay nothing); any
    other's is measured on `_MEASURED_FRAMES` frames spread over it (`measured_encoding`), and
    taken as sRGB, as cameras deliver it, when they show no tag."""
    if chosen != "auto":
        return EncodingDecision(encoding=chosen, decided_by="given (--srgb/--linear)")  # type: ignore[arg-type]
    if capture.simulated:
        return EncodingDecision(encoding="linear", decided_by="a simulated capture (its renders are linear)")
    import cv2

    step = max(1, len(capture.frames) // _MEASURED_FRAMES)
    grays = []
    for frame in capture.frames[step // 2 :: step][:_MEASURED_FRAMES]:
        try:
            grays.append(cv2.cvtColor(read_color(frame.color, capture.camera), cv2.COLOR_RGB2GRAY))
        except FrameError:
            continue  # the poses stage skips and reports it
    return measured_encoding(grays, detection) or EncodingDecision(
        encoding="srgb", decided_by=f"assumed, as cameras deliver it: no tag in {len(grays)} frames"
    )
