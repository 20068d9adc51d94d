"""The one pinhole camera: intrinsics in OpenCV's convention (pixel centres at integer
coordinates, x right, y down, z forward), optional lens distortion (Brown-Conrady: OpenCV's k1 k2
p1 p2 k3; or Kannala-Brandt: OpenCV fisheye's k1 k2 k3 k4), and the scale of its depth PNGs;
read from and written to a turntable capture's `camera.yaml`.

Every projection, pixel ray and depth back-projection of the toolkit goes through it, so all
of them honour the distortion the same way.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import numpy as np
import pydantic

from homemodel.core.transforms import rigid_transform
from homemodel.core.yaml_specs import load_yaml_spec, write_yaml

_Positive = pydantic.PositiveFloat
_Finite = pydantic.FiniteFloat


class Camera(pydantic.BaseModel):
    model_config = pydantic.ConfigDict(extra="forbid", frozen=True)

    width: int = pydantic.Field(gt=0, le=16384)
    height: int = pydantic.Field(gt=0, le=16384)
    fx: _Positive = pydantic.Field(allow_inf_nan=False)
    fy: _Positive = pydantic.Field(allow_inf_nan=False)
    cx: _Finite
    cy: _Finite
    # brown_conrady: OpenCV k1 k2 p1 p2 k3; kannala_brandt (fisheye, equidistant): k1 k2 k3 k4.
    distortion: tuple[_Finite, _Finite, _Finite, _Finite, _Finite] | tuple[_Finite, _Finite, _Finite, _Finite] | None = (
        None
    )
    distortion_model: Literal["brown_conrady", "kannala_brandt"] = "brown_conrady"
    depth_scale_m: _Positive = pydantic.Field(default=0.001, allow_inf_nan=False)

    @pydantic.model_validator(mode="after")
    def _coefficients_fit_the_model(self) -> Camera:
        wanted = 4 if self.distortion_model == "kannala_brandt" else 5
        if self.distortion is not None and len(self.distortion) != wanted:
            raise ValueError(f"distortion has {len(self.distortion)} coefficients but {self.distortion_model} takes {wanted}")
        return self

    @classmethod
    def from_matrix(cls, matrix: np.ndarray, *, width: int, height: int) -> Camera:
        """The distortion-free camera of a 3x3 K (without skew)."""
        k = np.asarray(matrix, dtype=np.float64)
        if k.shape != (3, 3):
            raise ValueError(f"{k.shape=} but expected (3, 3)")
        fx, fy, cx, cy = (float(v) for v in (k[0, 0], k[1, 1], k[0, 2], k[1, 2]))
        return cls(width=width, height=height, fx=fx, fy=fy, cx=cx, cy=cy)

    @property
    def matrix(self) -> np.ndarray:
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def distortion_coefficients(self) -> np.ndarray:
        """The coefficients in OpenCV's order for the model (cv2 for Brown-Conrady, cv2.fisheye
        for Kannala-Brandt); zeros when there is no distortion."""
        if self.distortion is None:
            return np.zeros(4 if self.distortion_model == "kannala_brandt" else 5)
        return np.asarray(self.distortion, dtype=np.float64)

    @property
    def has_distortion(self) -> bool:
        return self.distortion is not None and any(self.distortion)

    def without_distortion(self) -> Camera:
        """The pinhole camera with the same intrinsics (what an undistorted image is seen with)."""
        return self._changed(distortion=None, distortion_model="brown_conrady")

    def scaled(self, factor: float) -> Camera:
        """The camera of the image resized by `factor` (pixel centres stay pixel centres)."""
        factor = float(factor)
        return self._changed(
            width=round(self.width * factor),
            height=round(self.height * factor),
            fx=self.fx * factor,
            fy=self.fy * factor,
            cx=(self.cx + 0.5) * factor - 0.5,
            cy=(self.cy + 0.5) * factor - 0.5,
        )

    def _changed(self, **fields: object) -> Camera:
        # Validated, unlike model_copy(update=...).
        return Camera(**{**self.model_dump(), **fields})

    def rays(self, pixels: np.ndarray) -> np.ndarray:
        """(N, 3) rays with z = 1 through the (N, 2) pixel coordinates (x, y), lens distortion removed."""
        pixels = np.asarray(pixels, dtype=np.float64)
        if pixels.ndim != 2 or pixels.shape[1] != 2:
            raise ValueError(f"{pixels.shape=} but expected (N, 2)")
        if self.has_distortion:
            import cv2

            distorted = pixels.reshape(-1, 1, 2)
            # Iterated to convergence: OpenCV's default five iterations leave tenths of a pixel
            # at the corners of a strongly distorted lens.
            criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-12)
            if self.distortion_model == "kannala_brandt":
                xy = cv2.fisheye.undistortPoints(distorted, self.matrix, self.distortion_coefficients, criteria=criteria)
            else:
                xy = cv2.undistortPointsIter(
                    distorted, self.matrix, self.distortion_coefficients, None, None, criteria
                )
            xy = xy.reshape(-1, 2)
        else:
            xy = (pixels - [self.cx, self.cy]) / [self.fx, self.fy]
        return np.column_stack([xy, np.ones(len(xy))])

    def pixel_rays(self) -> np.ndarray:
        """(height * width, 3) rays with z = 1 through every pixel centre, row by row."""
        u, v = np.meshgrid(np.arange(self.width, dtype=np.float64), np.arange(self.height, dtype=np.float64))
        return self.rays(np.column_stack([u.ravel(), v.ravel()]))

    def project(self, points_camera: np.ndarray) -> np.ndarray:
        """(N, 2) pixel coordinates of (N, 3) points in the camera frame (z > 0), with distortion."""
        points = np.asarray(points_camera, dtype=np.float64)
        if points.ndim != 2 or points.shape[1] != 3:
            raise ValueError(f"{points.shape=} but expected (N, 3)")
        x = points[:, 0] / points[:, 2]
        y = points[:, 1] / points[:, 2]
        if self.has_distortion and self.distortion_model == "kannala_brandt":
            k1, k2, k3, k4 = self.distortion_coefficients
            r = np.hypot(x, y)
            theta = np.arctan(r)
            t2 = theta * theta
            theta_d = theta * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))
            scale = np.divide(theta_d, r, out=np.ones_like(r), where=r > 1e-12)
            x, y = x * scale, y * scale
        elif self.has_distortion:
            k1, k2, p1, p2, k3 = self.distortion_coefficients
            r2 = x * x + y * y
            radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
            x, y = (
                x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
                y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y,
            )
        return np.column_stack([self.fx * x + self.cx, self.fy * y + self.cy])

    def undistorted_pixels(self, pixels: np.ndarray) -> np.ndarray:
        """(N, 2) where the (N, 2) pixels of this camera fall in its distortion-free twin."""
        rays = self.rays(pixels)
        return rays[:, :2] * [self.fx, self.fy] + [self.cx, self.cy]

    def remap_from(self, source: Camera) -> tuple[np.ndarray, np.ndarray]:
        """cv2.remap's float32 (map_x, map_y): for each pixel of this camera, where its ray falls
        in `source`'s image (same centre and axes). Turns an image seen by `source` into one
        seen by this camera, whatever either's distortion."""
        projected = source.project(self.pixel_rays()).astype(np.float32)
        shape = (self.height, self.width)
        return projected[:, 0].reshape(shape), projected[:, 1].reshape(shape)

    def depth_to_points(self, depth_m: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
        """(N, 3) points in the camera frame of the valid (finite, positive, in `mask`) pixels of a
        depth image (z along the optical axis), row by row."""
        valid = np.isfinite(depth_m) & (depth_m > 0)
        if mask is not None:
            valid &= mask
        v, u = np.nonzero(valid)
        z = depth_m[v, u].astype(np.float64)
        return self.rays(np.column_stack([u, v])) * z[:, None]


def load_camera(path: Path) -> Camera:
    return load_yaml_spec(Path(path), Camera)


class PosedCamera(Camera):
    """A camera.yaml that may also give the camera's pose: `map_from_camera`, a 4x4 nested list,
    row-major, metres, OpenCV camera axes (an observation's camera.yaml)."""

    map_from_camera: list[list[float]] | None = None

    @pydantic.field_validator("map_from_camera")
    @classmethod
    def _rigid(cls, value: list[list[float]] | None) -> list[list[float]] | None:
        return None if value is None else rigid_transform(value, "the matrix").tolist()

    @property
    def camera(self) -> Camera:
        return Camera(**self.model_dump(exclude={"map_from_camera"}))


def load_camera_and_pose(path: Path) -> tuple[Camera, np.ndarray | None]:
    """The camera of a camera.yaml and its `map_from_camera` (None when the file gives none)."""
    spec = load_yaml_spec(Path(path), PosedCamera)
    pose = None if spec.map_from_camera is None else np.asarray(spec.map_from_camera, dtype=np.float64)
    return spec.camera, pose


def camera_mapping(camera: Camera) -> dict:
    """The camera as camera.yaml holds it (an observation's adds `map_from_camera`)."""
    data = camera.model_dump(exclude_none=True)
    if camera.distortion is None:
        del data["distortion_model"]  # the camera.yaml of a distortion-free camera stays as it was
    return data


def save_camera(camera: Camera, path: Path) -> None:
    write_yaml(Path(path), camera_mapping(camera))
