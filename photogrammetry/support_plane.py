"""The surface the object stands on: the cameras' common up, then a level plane under the
object in the dense points (RANSAC with the normal held near up)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# A support plane must hold at least this share of the points near the object: Kermit's chair
# seat, half hidden behind the books and the board, holds 4 % of them.
MIN_PLANE_SHARE = 0.03
# RANSAC runs on a random sample this large (Kermit's seat and Buddha's table came out within
# a degree of the planes found in 20,000, in half the time).
MAX_RANSAC_POINTS = 10_000
RANSAC_TRIES = 1000
SURFACE_AGREEMENT_DEG = 25.0  # an inlier's own surface faces within this of the plane's normal
MAX_TILT_DEG = 25.0  # a support plane's normal is within this of the cameras' up
# When no plane that level qualifies (photos turned at odd angles make up a weak hint: Buddha's
# frames put it 56 degrees off the table), planes up to this tilt are looked at.
MAX_TILT_LOOSE_DEG = 70.0
MAX_PLANES = 8  # planes looked at, largest first, before giving up
# Of the points that stay in every frame (the object and what it stands on), at least this
# share lies on or above a support plane: a flat part of the object itself (a chair's seat
# when the chair is the object) has much of the object below it.
MIN_SHARE_ABOVE = 0.75
MIN_CAMERAS_ABOVE = 0.8


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


def camera_up(rotations: np.ndarray) -> np.ndarray:
    """The cameras' common up (unit) from their `camera_from_world` rotations (N, 3, 3).

    Photos are mostly taken upright or turned by a quarter: one image axis of each, x or y, is
    level. Starting from the mean of -y, each camera's most level axis is taken, and up is the
    direction most nearly perpendicular to all of them. The mean of -y alone leans back by the
    cameras' mean downward look (18 degrees on Kermit's photos, all taken from the front);
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
    # Objects are photographed from above: most cameras look down (the mean -y may not tell,
    # when many photos are turned).
    return up if np.sum(rotations[:, 2, :] @ up) <= 0 else -up


def _local_normals(points: np.ndarray) -> np.ndarray:
    """Unit normals (unsigned) of the surface through each point: its 16 nearest neighbours' PCA."""
    from scipy.spatial import cKDTree

    _, neighbours = cKDTree(points).query(points, k=min(16, len(points)))
    patches = points[neighbours] - points[neighbours].mean(axis=1, keepdims=True)
    return np.linalg.eigh(np.einsum("nki,nkj->nij", patches, patches))[1][:, :, 0]


def _level_ransac(
    points: np.ndarray, normals: np.ndarray, up: np.ndarray, max_tilt_deg: float, threshold: float,
    rng: np.random.Generator,
) -> np.ndarray:  # fmt: skip
    """The inlier mask of the plane, tilted at most `max_tilt_deg` from `up`, that holds the
    most of `points` within `threshold` whose own surface faces the same way (`normals`): a
    slab through upright surfaces (books, a toy's legs) cuts many points but faces none. Each
    hypothesis is a point's own tangent plane; tilted ones are skipped."""
    seeds = rng.integers(0, len(points), RANSAC_TRIES)
    seeds = seeds[np.abs(normals[seeds] @ up) >= np.cos(np.radians(max_tilt_deg))]
    hypotheses, offsets = normals[seeds], -np.sum(normals[seeds] * points[seeds], axis=1)
    best, best_count = np.zeros(len(points), bool), 0
    min_cos = np.cos(np.radians(SURFACE_AGREEMENT_DEG))
    for start in range(0, len(seeds), 128):  # blocks of hypotheses against every point
        block = slice(start, start + 128)
        near = np.abs(points @ hypotheses[block].T + offsets[block]) <= threshold
        near &= np.abs(normals @ hypotheses[block].T) >= min_cos
        counts = near.sum(axis=0)
        top = int(np.argmax(counts))
        if counts[top] > best_count:
            best, best_count = near[:, top], int(counts[top])
    return best


def find_support_plane(
    points: np.ndarray,
    object_points: np.ndarray,
    camera_from_world: np.ndarray,
    focus: np.ndarray,
    *,
    threshold: float,
    seed: int = 0,
) -> Plane | None:
    """The support plane under the object, or None when there is none.

    `points` are the dense points near where the cameras look (the table round the object
    among them), `object_points` those that stay in (nearly) every frame, `camera_from_world`
    the cameras' poses (N, 4, 4) and `focus` the point they look at. Planes near level with
    the cameras' up (`camera_up`: within MAX_TILT_DEG, else within MAX_TILT_LOOSE_DEG) are
    found largest first (RANSAC, then a least-squares refit of the inliers). A support plane
    holds MIN_PLANE_SHARE of the points, has the cameras, `focus` and MIN_SHARE_ABOVE of the
    object points above it, and the cameras look down on it; of those, the highest under
    `focus` is the one the object stands on (a board on a table, a seat above the floor)."""
    points = np.asarray(points, np.float64)
    if points.ndim != 2 or points.shape[1] != 3:
        raise ValueError(f"{points.shape=} but expected (N, 3)")
    rotations = camera_from_world[:, :3, :3]
    centres = -np.einsum("nji,nj->ni", rotations, camera_from_world[:, :3, 3])
    up = camera_up(rotations)
    rng = np.random.default_rng(seed)
    if len(points) > MAX_RANSAC_POINTS:  # a random subset finds the same plane, much faster
        points = points[rng.choice(len(points), MAX_RANSAC_POINTS, replace=False)]
    if len(object_points) > MAX_RANSAC_POINTS:
        object_points = object_points[rng.choice(len(object_points), MAX_RANSAC_POINTS, replace=False)]
    all_normals = _local_normals(points)
    for max_tilt in (MAX_TILT_DEG, MAX_TILT_LOOSE_DEG):
        remaining, normals = points, all_normals
        best: Plane | None = None
        for _ in range(MAX_PLANES):
            inliers = _level_ransac(remaining, normals, up, max_tilt, threshold, rng)
            share = inliers.sum() / len(points)
            if share < MIN_PLANE_SHARE:
                break
            on_plane = remaining[inliers]
            remaining, normals = remaining[~inliers], normals[~inliers]
            centroid = on_plane.mean(axis=0)
            normal = np.linalg.svd(on_plane - centroid, full_matrices=False)[2][-1]
            normal *= np.sign(normal @ up)
            spread = (on_plane - centroid) @ normal
            plane = Plane(
                normal=normal,
                offset=float(-normal @ centroid),
                inlier_share=float(share),
                tilt_deg=float(np.degrees(np.arccos(np.clip(normal @ up, -1, 1)))),
                noise=float(1.4826 * np.median(np.abs(spread - np.median(spread)))),
            )
            focus_height = plane.height(focus[None])[0]
            if (
                plane.tilt_deg <= max_tilt
                and focus_height > threshold
                and np.mean(plane.height(centres) > threshold) >= MIN_CAMERAS_ABOVE
                and np.mean(rotations[:, 2, :] @ normal) < 0
                and np.mean(plane.height(object_points) > -threshold) >= MIN_SHARE_ABOVE
                and (best is None or focus_height < best.height(focus[None])[0])
            ):
                best = plane
        if best is not None:
            return best
    return None
