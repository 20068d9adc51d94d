"""The surface the object stands on: the cameras' common up, then a level plane under the
object in the dense points (RANSAC with the normal held near up)."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

# A support plane must hold at least this share of the points near the object: Kermit's chair
# seat, half hidden behind the books and the board, holds 4 % of them.
MIN_PLANE_SHARE = 0.03
# Once a plane holds MIN_PLANE_SHARE, any holding this share of it may be chosen: the seat
# under Kermit holds 2.7-3.2 % as the dense points vary by 0.5 %, and a bar at its edge let a
# plane tilted 5 degrees more, through his lap, win when the seat fell under it.
EDGE_SHARE = 0.8
# Each hypothesis (a point's tangent plane, tilted by the point's own noise) is refitted this
# many times on its inliers before it is scored: the same surface then scores the same.
REFINE_ROUNDS = 2
# Only hypotheses holding this share of the points as seeded are refitted: a refit corrects a
# seed's tilt (Kermit's seat: 2.7 -> 3.0 %), it does not double the share.
REFIT_MIN_SHARE = 0.012
# The highest plane under the focus is chosen among those this near parallel to the best: a
# board lying on the table, not a plane tilted through the object's base.
PARALLEL_DEG = 3.0
# RANSAC runs on a random sample this large (Kermit's seat and Buddha's table came out within
# a degree of the planes found in 20,000, in half the time).
MAX_RANSAC_POINTS = 10_000
RANSAC_TRIES = 1000
SURFACE_AGREEMENT_DEG = 25.0  # an inlier's own surface faces within this of the plane's normal
MAX_TILT_DEG = 25.0  # a support plane's normal is within this of the cameras' up
# When no plane that level qualifies (photos turned at odd angles make up a weak hint: Buddha's
# frames put it 56 degrees off the table), planes up to this tilt are looked at.
MAX_TILT_LOOSE_DEG = 70.0
# Of the points that stay in every frame (the object and what it stands on), at least this
# share lies on or above a support plane: a flat part of the object itself (a chair's seat
# when the chair is the object) has much of the object below it.
MIN_SHARE_ABOVE = 0.75
# A plane's score is its inlier share less this times the share of the object points below it.
# On Kermit's photos a slab through the board and his legs holds 4.8 % of the points and has
# 7.5 % of the object below it; the seat under them 3.9 % and 2.7 % (the chair's frame).
BELOW_WEIGHT = 1.0
BELOW_MARGIN = 0.005  # share of the object points
MIN_CAMERAS_ABOVE = 0.8
# A photo is held upright (or upside down), not turned a quarter, when its y axis is within 60
# degrees of up: a camera looking down 60 degrees at the object, held upright, is at 60.
UPRIGHT_MIN_COS = 0.5
# The side a support is on (`_support_side`) decides up's sign when its best level plane with
# the object, the focus and the cameras above it holds this share of the points near the object
# and this many times the other side's best. Buddha's lowest band: 1.7 % on the table's side,
# 0.07 % on the other; its colour frames (no support in the points) 0.14 % and 0.11 %: no
# word; Kermit, the rendered set and the other Buddha sets 2.3-85 % against none.
SIDE_MIN_SHARE = 0.005
SIDE_RATIO = 3.0


@dataclass(kw_only=True)
class Plane:
    """Points x with normal . x + offset = 0; the normal points to the side the cameras are on."""

    normal: np.ndarray
    offset: float
    inlier_share: float
    tilt_deg: float = 0.0  # the normal's angle to the cameras' up
    # The robust spread of the inliers' heights: how thick the surface came out (a cushion, a
    # warped board, depth noise). Points of the object standing on it do not count.
    noise: float = 0.0

    def height(self, points: np.ndarray) -> np.ndarray:
        return points @ self.normal + self.offset

    def figures(self) -> dict:
        """For summary.json: the plane in the SfM frame and how it was found."""
        return {
            "normal_sfm": [round(float(v), 5) for v in self.normal],
            "offset_sfm": round(self.offset, 5),
            "inlier_share": round(self.inlier_share, 4),
            "tilt_from_camera_up_deg": round(self.tilt_deg, 2),
            "noise_sfm": round(self.noise, 5),
        }


def focus_point(centres: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """The point closest (least squares) to every camera's optical axis: what the photos look at."""
    a, b = np.zeros((3, 3)), np.zeros(3)
    for c, d in zip(centres, axes):
        d = d / np.linalg.norm(d)
        projector = np.eye(3) - np.outer(d, d)
        a += projector
        b += projector @ c
    return np.linalg.lstsq(a, b, rcond=None)[0]


def _level_axis(rotations: np.ndarray) -> np.ndarray:
    """The cameras' common vertical (unit, signed as their mean -y) from their `camera_from_world`
    rotations (N, 3, 3).

    Photos are mostly taken upright or turned by a quarter: one image axis of each, x or y, is
    level. Starting from the mean of -y, each camera's most level axis is taken, and the axis is
    the direction most nearly perpendicular to all of them. The mean of -y alone leans back by
    the cameras' mean downward look (18 degrees on Kermit's photos, all taken from the front);
    where the level axes do not pin a direction (all cameras facing one way) it is what is
    left. Photos turned at any angle (Buddha's frames) make it a weak hint only (56 degrees off
    the table there)."""
    rotations = np.asarray(rotations, np.float64)
    if rotations.ndim != 3 or rotations.shape[1:] != (3, 3):
        raise ValueError(f"{rotations.shape=} but expected (N, 3, 3)")
    up = -rotations[:, 1, :].mean(axis=0)
    up /= max(np.linalg.norm(up), 1e-12)
    x, y = rotations[:, 0, :], rotations[:, 1, :]
    for _ in range(3):
        level = np.where((np.abs(x @ up) <= np.abs(y @ up))[:, None], x, y)
        _, singular, vt = np.linalg.svd(level)
        if len(singular) < 3 or singular[1] < 2 * singular[2]:
            break  # the level axes span no plane: up stays
        up = vt[-1] * np.sign(vt[-1] @ up)
    return up


def _upright_sign(rotations: np.ndarray, axis: np.ndarray) -> int:
    """+1 or -1 as the photos held upright (or upside down) say `axis` points up by their -y,
    when half of them or more are; 0 (no word) when most are turned a quarter. A tall object
    photographed at eye level is looked up at, and the look-down rule turned such a model
    upside down."""
    y = rotations[:, 1, :]
    held = np.abs(y @ axis) >= UPRIGHT_MIN_COS
    if 2 * held.sum() < len(rotations):
        return 0
    return 1 if np.sum(-y[held] @ axis) >= 0 else -1


def _look_down_sign(rotations: np.ndarray, axis: np.ndarray) -> int:
    """+1 or -1 so that most cameras look down: objects are mostly photographed from above."""
    return 1 if np.sum(rotations[:, 2, :] @ axis) <= 0 else -1


def camera_up(rotations: np.ndarray) -> np.ndarray:
    """The cameras' common up (unit) from their `camera_from_world` rotations (N, 3, 3):
    `_level_axis`, its sign from the photos held upright, else from the cameras looking down
    (`scene_up` lets the dense points speak before the latter)."""
    axis = _level_axis(rotations)
    return axis * (_upright_sign(rotations, axis) or _look_down_sign(rotations, axis))


def scene_up(
    points: np.ndarray, object_points: np.ndarray, camera_from_world: np.ndarray, focus: np.ndarray, *,
    threshold: float, seed: int = 0,
) -> np.ndarray:  # fmt: skip
    """The scene's up (unit): `camera_up`, except that when the photos held upright give no sign,
    the side a support is on (`_support_side`, from the dense points near the object and
    those that stay in every frame) gives it before the cameras' look does. Photos turned a
    quarter all round an object from its own mid-height (Buddha's lowest band: 27 cameras
    looking 3 degrees up on average) made the look-down rule a coin toss, and the model came
    out upside down."""
    rotations = np.asarray(camera_from_world, np.float64)[:, :3, :3]
    axis = _level_axis(rotations)
    sign = _upright_sign(rotations, axis)
    if not sign:
        centres = -np.einsum("nji,nj->ni", rotations, camera_from_world[:, :3, 3])
        rng = np.random.default_rng(seed)
        sign = _support_side(*_ransac_sample(points, object_points, rng), centres, focus, axis, threshold, rng)
    return axis * (sign or _look_down_sign(rotations, axis))


def _local_normals(points: np.ndarray) -> np.ndarray:
    """Unit normals (unsigned) of the surface through each point: its 16 nearest neighbours' PCA."""
    from scipy.spatial import cKDTree

    _, neighbours = cKDTree(points).query(points, k=min(16, len(points)))
    patches = points[neighbours] - points[neighbours].mean(axis=1, keepdims=True)
    return np.linalg.eigh(np.einsum("nki,nkj->nij", patches, patches))[1][:, :, 0]


def _plane_hypotheses(
    points: np.ndarray, normals: np.ndarray, up: np.ndarray, max_tilt_deg: float, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Up to RANSAC_TRIES planes (unit normals on the cameras' side, offsets): the tangent
    planes of points whose own surface is within `max_tilt_deg` of `up`."""
    level = np.nonzero(np.abs(normals @ up) >= np.cos(np.radians(max_tilt_deg)))[0]
    seeds = rng.choice(level, min(RANSAC_TRIES, len(level)), replace=False)
    hypotheses = normals[seeds] * np.sign(normals[seeds] @ up)[:, None]
    return hypotheses, -np.sum(hypotheses * points[seeds], axis=1)


def _blocks(planes: int) -> Iterator[slice]:
    """The planes in blocks of 128, each block against every point at once."""
    return (slice(start, start + 128) for start in range(0, planes, 128))


def _inliers(
    hypotheses: np.ndarray, offsets: np.ndarray, points: np.ndarray, normals: np.ndarray, threshold: float
) -> np.ndarray:
    """(points, planes): which `points` lie within `threshold` of each plane with their own
    surface facing the same way (a slab through upright surfaces, books or a toy's legs, cuts
    many points but faces none)."""
    near = np.abs(points @ hypotheses.T + offsets) <= threshold
    near &= np.abs(normals @ hypotheses.T) >= np.cos(np.radians(SURFACE_AGREEMENT_DEG))
    return near


def _inlier_shares(
    hypotheses: np.ndarray, offsets: np.ndarray, points: np.ndarray, normals: np.ndarray, threshold: float
) -> np.ndarray:
    """Per plane, the share of `points` that are its `_inliers`."""
    shares = np.zeros(len(hypotheses))
    for block in _blocks(len(hypotheses)):
        shares[block] = _inliers(hypotheses[block], offsets[block], points, normals, threshold).mean(axis=0)
    return shares


def _refined(
    hypotheses: np.ndarray, offsets: np.ndarray, points: np.ndarray, normals: np.ndarray, up: np.ndarray,
    threshold: float,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The planes (REFINE_ROUNDS times) fitted by least squares to their `_inliers`; one with
    fewer than 3 stays."""
    moments = (points[:, :, None] * points[:, None, :]).reshape(-1, 9)
    hypotheses, offsets = hypotheses.copy(), offsets.copy()
    for _ in range(REFINE_ROUNDS):
        for block in _blocks(len(hypotheses)):
            near = _inliers(hypotheses[block], offsets[block], points, normals, threshold)
            count = near.sum(axis=0)
            weights = near / np.maximum(count, 1)
            centroids = weights.T @ points
            scatter = (weights.T @ moments).reshape(-1, 3, 3) - centroids[:, :, None] * centroids[:, None, :]
            fitted = np.linalg.eigh(scatter)[1][:, :, 0]
            fitted *= np.sign(fitted @ up)[:, None]
            enough = count >= 3
            hypotheses[block] = np.where(enough[:, None], fitted, hypotheses[block])
            offsets[block] = np.where(enough, -np.sum(hypotheses[block] * centroids, axis=1), offsets[block])
    return hypotheses, offsets


def _score_planes(
    hypotheses: np.ndarray, offsets: np.ndarray, points: np.ndarray, normals: np.ndarray,
    object_points: np.ndarray, threshold: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """Per plane, its `_inlier_shares` of `points`, and the shares of `object_points` more than
    `threshold` below it and above it."""
    inliers = _inlier_shares(hypotheses, offsets, points, normals, threshold)
    below, above = np.zeros(len(hypotheses)), np.zeros(len(hypotheses))
    for block in _blocks(len(hypotheses)):
        heights = object_points @ hypotheses[block].T + offsets[block]
        below[block] = np.mean(heights < -threshold, axis=0)
        above[block] = np.mean(heights > threshold, axis=0)
    return inliers, below, above


def _ransac_sample(
    points: np.ndarray, object_points: np.ndarray, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """At most MAX_RANSAC_POINTS of `points` and of `object_points` (a random subset finds the
    same plane, much faster), and the sampled points' normals."""
    points = np.asarray(points, np.float64)
    if points.ndim != 2 or points.shape[1] != 3:
        raise ValueError(f"{points.shape=} but expected (N, 3)")
    if len(points) > MAX_RANSAC_POINTS:
        points = points[rng.choice(len(points), MAX_RANSAC_POINTS, replace=False)]
    if len(object_points) > MAX_RANSAC_POINTS:
        object_points = object_points[rng.choice(len(object_points), MAX_RANSAC_POINTS, replace=False)]
    return points, object_points, _local_normals(points)


def _on_its_upper_side(
    normals: np.ndarray, offsets: np.ndarray, below: np.ndarray, centres: np.ndarray, focus: np.ndarray, threshold: float
) -> np.ndarray:
    """Which planes (normals (K, 3), offsets (K,); `below`: the share of the object under each)
    have MIN_SHARE_ABOVE of the object, the focus and MIN_CAMERAS_ABOVE of the cameras on the
    side their normal points to: what a support under the object has."""
    return (
        (below <= 1 - MIN_SHARE_ABOVE)
        & (normals @ focus + offsets > threshold)
        & (np.mean(centres @ normals.T + offsets > threshold, axis=0) >= MIN_CAMERAS_ABOVE)
    )


def _support_side(
    points: np.ndarray, object_points: np.ndarray, normals: np.ndarray, centres: np.ndarray, focus: np.ndarray,
    axis: np.ndarray, threshold: float, rng: np.random.Generator,
) -> int:  # fmt: skip
    """+1 or -1: the side of the object along `axis` a support is on, as the level planes that
    have the object and the cameras on their other side say; 0 when neither side's best holds
    SIDE_MIN_SHARE of the points and SIDE_RATIO times the other's. Seen from above, only the
    plane under the object can be one (a flat top has the cameras above it too); from the
    object's own mid-height a flat top could, but a table and the object's flat foot hold more
    than a rounded top (Buddha's lowest band: 1.7 % against 0.07 %)."""
    hypotheses, offsets = _plane_hypotheses(points, normals, axis, MAX_TILT_DEG, rng)
    if not len(hypotheses):
        return 0
    inliers, below, above = _score_planes(hypotheses, offsets, points, normals, object_points, threshold)
    best = [
        float(inliers[qualified].max()) if qualified.any() else 0.0
        for qualified in (
            _on_its_upper_side(hypotheses, offsets, below, centres, focus, threshold),
            _on_its_upper_side(-hypotheses, -offsets, above, centres, focus, threshold),
        )
    ]
    if max(best) < SIDE_MIN_SHARE or max(best) < SIDE_RATIO * min(best):
        return 0
    return 1 if best[0] > best[1] else -1


def find_support_plane(
    points: np.ndarray,
    object_points: np.ndarray,
    camera_from_world: np.ndarray,
    focus: np.ndarray,
    *,
    threshold: float,
    seed: int = 0,
    up: np.ndarray | None = None,
) -> Plane | None:
    """The support plane under the object, or None when there is none.

    `points` are the dense points near where the cameras look (the table round the object
    among them), `object_points` those that stay in (nearly) every frame, `camera_from_world`
    the cameras' poses (N, 4, 4) and `focus` the point they look at. Planes near level with
    `up` (None: `scene_up` of the same; within MAX_TILT_DEG, else within MAX_TILT_LOOSE_DEG)
    are each a point's tangent plane refitted to its inliers. A support plane has the cameras,
    `focus` and MIN_SHARE_ABOVE of the object points above it, and the cameras look down on
    it; there is one when such a plane holds MIN_PLANE_SHARE of the points, and then any such
    plane holding EDGE_SHARE of that may be it. Of those, the one the object stands on holds
    the most points and has the least of the object below it (BELOW_WEIGHT): a slab through a
    board lying on the seat and a toy's legs holds as many points as the seat under them, but
    cuts them off."""
    if up is None:
        up = scene_up(points, object_points, camera_from_world, focus, threshold=threshold, seed=seed)
    rotations = camera_from_world[:, :3, :3]
    centres = -np.einsum("nji,nj->ni", rotations, camera_from_world[:, :3, 3])
    rng = np.random.default_rng(seed)
    points, object_points, normals = _ransac_sample(points, object_points, rng)

    def placed(normal: np.ndarray, offset: np.ndarray, below: np.ndarray) -> np.ndarray:
        """Which planes (normals (K, 3), offsets (K,)) lie where a support does."""
        return _on_its_upper_side(normal, offset, below, centres, focus, threshold) & (
            np.mean(rotations[:, 2, :] @ normal.T, axis=0) < 0
        )

    for max_tilt in (MAX_TILT_DEG, MAX_TILT_LOOSE_DEG):
        hypotheses, offsets = _plane_hypotheses(points, normals, up, max_tilt, rng)
        if not len(hypotheses):
            continue
        hopeful = _inlier_shares(hypotheses, offsets, points, normals, threshold) >= REFIT_MIN_SHARE
        if not hopeful.any():
            continue
        hypotheses, offsets = _refined(hypotheses[hopeful], offsets[hopeful], points, normals, up, threshold)
        inliers, below, _ = _score_planes(hypotheses, offsets, points, normals, object_points, threshold)
        where = placed(hypotheses, offsets, below) & (hypotheses @ up >= np.cos(np.radians(max_tilt)))
        if not (where & (inliers >= MIN_PLANE_SHARE)).any():
            continue
        qualified = where & (inliers >= EDGE_SHARE * MIN_PLANE_SHARE)
        score = np.where(qualified, inliers - BELOW_WEIGHT * below, -np.inf)
        best = int(np.argmax(score))
        # Of the planes parallel to it that cut off hardly more of the object, the highest under
        # the focus (a board on a table, the object standing on the board): the best of those
        # within `threshold` of the highest (refitted planes of one surface are one plane).
        near = qualified & (below <= below[best] + BELOW_MARGIN)
        near &= hypotheses @ hypotheses[best] >= np.cos(np.radians(PARALLEL_DEG))
        under_focus = np.where(near, hypotheses @ focus + offsets, np.inf)
        best = int(np.argmax(np.where(under_focus <= under_focus.min() + threshold, score, -np.inf)))
        # Refitted once more, on its own inliers: the plane its surface gives, not the seed's tilt.
        refit = _refined(hypotheses[best : best + 1], offsets[best : best + 1], points, normals, up, threshold)
        normal, offset = refit[0][0], refit[1][0]
        on_plane = _inliers(normal[None], offset[None], points, normals, threshold)[:, 0]
        spread = points[on_plane] @ normal + offset
        return Plane(
            normal=normal,
            offset=float(offset),
            inlier_share=float(on_plane.mean()),
            tilt_deg=float(np.degrees(np.arccos(np.clip(normal @ up, -1, 1)))),
            noise=float(1.4826 * np.median(np.abs(spread - np.median(spread)))),
        )
    return None
