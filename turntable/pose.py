"""Camera pose per frame from the tag corners: PnP over every corner seen, RANSAC, then
Levenberg-Marquardt refinement on the inliers."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from homemodel.core.checks import require_at_least, require_between, require_positive
from turntable.board import Board
from homemodel.geometry.camera import Camera

_AMBIGUOUS_RMS_RATIO = 3.0  # candidates' unrefined errors within this factor (and a tenth of RANSAC's threshold) are both refined


@dataclass(kw_only=True)
class PoseOptions:
    min_tags: int = 3  # fewer known tags in a frame: the frame is skipped
    ransac_threshold_px: float = 3.0
    max_reprojection_error_px: float = 2.0  # RMS over inliers; worse frames are skipped
    min_inlier_fraction: float = 0.8

    def check(self) -> None:
        require_at_least("min_tags", self.min_tags, 1)
        require_positive("ransac_threshold_px", self.ransac_threshold_px)
        require_positive("max_reprojection_error_px", self.max_reprojection_error_px)
        require_between("min_inlier_fraction", self.min_inlier_fraction, 0.0, 1.0)


@dataclass(kw_only=True)
class FramePose:
    camera_from_table: np.ndarray
    tags: int  # known tags seen
    inlier_corners: int
    reprojection_error_px: float  # RMS over the inlier corners
    table_points: np.ndarray  # (n, 3) the inlier corners on the board
    image_points: np.ndarray  # (n, 2) where they were seen


class PoseSkip(Exception):
    """A frame whose pose cannot be trusted; the message says why. Not an input error: the
    pipeline counts such frames and goes on."""


def estimate_camera_from_table(
    detections: dict[int, np.ndarray],
    board: Board,
    camera: Camera,
    options: PoseOptions | None = None,
    near: np.ndarray | None = None,
) -> FramePose:
    """`camera_from_table` from detected corners (tag id -> (4, 2) pixels); raises PoseSkip.
    Given a camera_from_table `near` the answer (a predicted frame's), it is refined from there:
    no RANSAC and no global solve, so neither the flip ambiguity nor their time."""
    options = options or PoseOptions()
    table_corners = board.corners_table()
    known = sorted(tag_id for tag_id in detections if tag_id in table_corners)
    object_points = np.array([table_corners[i] for i in known], dtype=np.float64).reshape(-1, 3)
    image_points = np.array([detections[i] for i in known], dtype=np.float64).reshape(-1, 2)
    return pose_from_corners(object_points, image_points, camera, options, near)


def pose_from_corners(
    object_points: np.ndarray,
    image_points: np.ndarray,
    camera: Camera,
    options: PoseOptions,
    near: np.ndarray | None = None,
) -> FramePose:
    """`estimate_camera_from_table` from its tags' corners already paired: (4 n, 3) on the
    board, in tag order, and (4 n, 2) in the image (a tracked frame's tags come as arrays)."""
    import cv2

    tags = len(object_points) // 4
    if tags < options.min_tags:
        raise PoseSkip(f"{tags} board tags seen, {options.min_tags} needed")
    K, dist = camera.matrix, camera.distortion_coefficients
    seen = image_points  # OpenCV's PnP knows Brown-Conrady only: a fisheye's corners go in undistorted
    if camera.has_distortion and camera.distortion_model == "kannala_brandt":
        image_points, dist = camera.undistorted_pixels(image_points), np.zeros(5)
    if near is not None:
        rvec, tvec, inliers = _refined_near(object_points, image_points, K, dist, near, options.ransac_threshold_px)
        if len(inliers) < options.min_inlier_fraction * len(object_points):
            raise PoseSkip(f"only {len(inliers)} of {len(object_points)} corners agree on a pose")
        return _frame_pose(rvec, tvec, object_points, image_points, seen, inliers, K, dist, tags, options)
    # Minimal (P3P) samples: OpenCV's RANSAC with a non-minimal solver (SQPnP, EPnP) drew
    # samples from one small tag and kept 30 of 104 corners on a steep view where AP3P kept all.
    ok, rvec, tvec, inliers = cv2.solvePnPRansac(
        object_points,
        image_points,
        K,
        dist,
        flags=cv2.SOLVEPNP_AP3P,
        reprojectionError=options.ransac_threshold_px,
        iterationsCount=500,
        confidence=0.999,
    )
    if not ok or inliers is None:
        raise PoseSkip("PnP found no consistent pose")
    inliers = inliers.ravel()
    if len(inliers) < options.min_inlier_fraction * len(object_points):
        raise PoseSkip(f"only {len(inliers)} of {len(object_points)} corners agree on a pose")
    # A planar board has two poses that fit a noisy view almost equally (the flip
    # ambiguity); RANSAC's can be the wrong one, where refinement stays. SQPnP on all inliers
    # finds the global optimum; the better of the two, refined, is kept. Refinement (LM, most
    # of PnP's time) is spent on the worse one only when their errors are close enough to be
    # that ambiguity: RANSAC's final pose was often 20 px off where SQPnP's was 0.3 px.
    inlier_object, inlier_image = object_points[inliers], image_points[inliers]
    candidates = [(rvec, tvec)]
    ok_global, rvec_global, tvec_global = cv2.solvePnP(inlier_object, inlier_image, K, dist, flags=cv2.SOLVEPNP_SQPNP)
    if ok_global:
        candidates.append((rvec_global, tvec_global))

    def rms_px(rvec: np.ndarray, tvec: np.ndarray) -> float:
        projected, _ = cv2.projectPoints(inlier_object, rvec, tvec, K, dist)
        return float(np.sqrt(np.mean(np.sum((projected.reshape(-1, 2) - inlier_image) ** 2, axis=1))))

    scored = sorted(((rms_px(r, t), i) for i, (r, t) in enumerate(candidates)))
    best = None
    for rms, i in scored:
        if best is not None and rms > _AMBIGUOUS_RMS_RATIO * scored[0][0] + options.ransac_threshold_px / 10:
            break
        rvec, tvec = cv2.solvePnPRefineLM(inlier_object, inlier_image, K, dist, *(c.copy() for c in candidates[i]))
        rms = rms_px(rvec, tvec)
        if best is None or rms < best[0]:
            best = (rms, rvec, tvec)
    _, rvec, tvec = best
    return _frame_pose(rvec, tvec, object_points, image_points, seen, inliers, K, dist, tags, options)


def _refined_near(
    object_points: np.ndarray, image_points: np.ndarray, K: np.ndarray, dist: np.ndarray, near: np.ndarray, threshold_px: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(rvec, tvec, inlier indices): Levenberg-Marquardt from `near` on every corner, then again
    on the corners within `threshold_px` of that pose if any lay beyond."""
    import cv2

    rvec, tvec = cv2.Rodrigues(near[:3, :3])[0], near[:3, 3].reshape(3, 1).copy()
    inliers = np.arange(len(object_points))
    for _ in range(2):
        rvec, tvec = cv2.solvePnPRefineLM(object_points[inliers], image_points[inliers], K, dist, rvec, tvec)
        projected, _ = cv2.projectPoints(object_points, rvec, tvec, K, dist)
        close = np.flatnonzero(np.linalg.norm(projected.reshape(-1, 2) - image_points, axis=1) <= threshold_px)
        if len(close) == len(inliers) or len(close) < 4:
            break
        inliers = close
    return rvec, tvec, close


def _frame_pose(
    rvec: np.ndarray,
    tvec: np.ndarray,
    object_points: np.ndarray,
    image_points: np.ndarray,
    seen: np.ndarray,
    inliers: np.ndarray,
    K: np.ndarray,
    dist: np.ndarray,
    tags: int,
    options: PoseOptions,
) -> FramePose:
    """The frame's pose from a refined (rvec, tvec), if its inliers' RMS error and side of the
    camera allow; `seen` are the image points as detected (before any undistortion)."""
    import cv2

    projected, _ = cv2.projectPoints(object_points[inliers], rvec, tvec, K, dist)
    rms = float(np.sqrt(np.mean(np.sum((projected.reshape(-1, 2) - image_points[inliers]) ** 2, axis=1))))
    if rms > options.max_reprojection_error_px:
        raise PoseSkip(f"reprojection error {rms:.2f} px above {options.max_reprojection_error_px} px")
    camera_from_table = np.eye(4)
    camera_from_table[:3, :3] = cv2.Rodrigues(rvec)[0]
    camera_from_table[:3, 3] = tvec.ravel()
    if camera_from_table[2, 3] <= 0:
        raise PoseSkip("the board would lie behind the camera")
    return FramePose(
        camera_from_table=camera_from_table,
        tags=tags,
        inlier_corners=len(inliers),
        reprojection_error_px=rms,
        table_points=object_points[inliers],
        image_points=seen[inliers],
    )
