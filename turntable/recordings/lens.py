"""Lens models a recording may carry that the one Camera does not (RealSense's inverse
Brown-Conrady, ROS's rational polynomial with k4-k6), refitted as OpenCV's forward
Brown-Conrady (k1 k2 p1 p2 k3) over the whole image, or followed as each pixel's ray
(`opencv_pixel_rays`: a ROS depth lens with k4-k6), or undone in the images themselves
(`undistortion_maps`: a colour lens the refit does not hold)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from homemodel.geometry.camera import Camera


def fit_brown_conrady(undistorted: np.ndarray, distorted: np.ndarray) -> tuple[np.ndarray, float]:
    """OpenCV Brown-Conrady k1 k2 p1 p2 k3 mapping normalised `undistorted` points onto
    `distorted` ones, by linear least squares (the model is linear in its coefficients), and the
    largest residual (normalised units)."""
    x, y = undistorted[:, 0], undistorted[:, 1]
    r2 = x * x + y * y
    rows_x = np.column_stack([x * r2, x * r2 * r2, 2 * x * y, r2 + 2 * x * x, x * r2**3])
    rows_y = np.column_stack([y * r2, y * r2 * r2, r2 + 2 * y * y, 2 * x * y, y * r2**3])
    a = np.vstack([rows_x, rows_y])
    b = np.concatenate([distorted[:, 0] - x, distorted[:, 1] - y])
    coefficients = np.linalg.lstsq(a, b, rcond=None)[0]
    return coefficients, float(np.max(np.abs(a @ coefficients - b)))


def refit_as_brown_conrady(
    camera: Camera, undistort: Callable[[np.ndarray], np.ndarray]
) -> tuple[Camera, float]:
    """`camera` with the Brown-Conrady coefficients that best reproduce `undistort` (distorted
    normalised points to undistorted ones) over a grid across its image, and the worst
    residual in pixels."""
    u, v = np.meshgrid(np.linspace(0, camera.width - 1, 40), np.linspace(0, camera.height - 1, 30))
    distorted = np.column_stack([(u.ravel() - camera.cx) / camera.fx, (v.ravel() - camera.cy) / camera.fy])
    fitted, residual = fit_brown_conrady(undistort(distorted), distorted)
    refitted = Camera(**{**camera.model_dump(), "distortion": tuple(float(c) for c in fitted), "distortion_model": "brown_conrady"})
    return refitted, residual * camera.fx


def undistort_inverse_brown_conrady(coefficients: list[float]) -> Callable[[np.ndarray], np.ndarray]:
    """RealSense's inverse Brown-Conrady: its k1 k2 p1 p2 k3 map distorted points to undistorted."""
    k1, k2, p1, p2, k3 = coefficients

    def undistort(points: np.ndarray) -> np.ndarray:
        x, y = points[:, 0], points[:, 1]
        r2 = x * x + y * y
        radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
        return np.column_stack(
            [x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x), y * radial + 2 * p2 * x * y + p1 * (r2 + 2 * y * y)]
        )

    return undistort


def undistort_opencv(coefficients: list[float]) -> Callable[[np.ndarray], np.ndarray]:
    """OpenCV's model with any of its coefficient counts (ROS rational_polynomial: k1 k2 p1 p2
    k3 k4 k5 k6), inverted by OpenCV's iterative undistortion."""
    import cv2

    d = np.asarray(coefficients, dtype=np.float64)
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)

    def undistort(points: np.ndarray) -> np.ndarray:
        xy = cv2.undistortPointsIter(points.reshape(-1, 1, 2), np.eye(3), d, None, None, criteria)
        return xy.reshape(-1, 2)

    return undistort


def opencv_pixel_rays(camera: Camera, coefficients: list[float]) -> tuple[np.ndarray, float]:
    """(h*w, 3) rays (z = 1) through `camera`'s pixel centres under OpenCV's model with all of
    `coefficients`, and the fraction of pixels without one: NaN where the iterative inversion
    does not land back on its pixel (past the model's reach, such as a wide lens's corners)."""
    import cv2

    v, u = np.mgrid[0 : camera.height, 0 : camera.width]
    pixels = np.column_stack([u.ravel(), v.ravel()]).astype(np.float64)
    distorted = (pixels - [camera.cx, camera.cy]) / [camera.fx, camera.fy]
    rays = np.column_stack([undistort_opencv(coefficients)(distorted), np.ones(len(pixels))])
    back = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), camera.matrix, np.asarray(coefficients, np.float64))[0]
    lost = ~(np.linalg.norm(back.reshape(-1, 2) - pixels, axis=1) < 0.01)
    rays[lost] = np.nan
    return rays, float(lost.mean())


def undistortion_maps(camera: Camera, coefficients: list[float]) -> tuple[np.ndarray, np.ndarray]:
    """cv2.remap's maps from `camera`'s pinhole (its intrinsics, no distortion) to where each of
    its pixels lies in an image taken through OpenCV's model with all of `coefficients`."""
    import cv2

    size = (camera.width, camera.height)
    return cv2.initUndistortRectifyMap(camera.matrix, np.asarray(coefficients, np.float64), None, camera.matrix, size, cv2.CV_32FC1)
