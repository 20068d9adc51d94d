"""`camera.yaml`: pinhole intrinsics in OpenCV's convention (pixel centres at integer
coordinates, x right, y down, z forward), optional distortion, and the depth PNGs' scale."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pydantic
import yaml

from homemodel.core.atomic import write_text_atomic
from homemodel.core.yaml_specs import load_yaml_spec

_Positive = pydantic.PositiveFloat
_Finite = pydantic.FiniteFloat


class Camera(pydantic.BaseModel):
    model_config = pydantic.ConfigDict(extra="forbid")

    width: int = pydantic.Field(gt=0, le=16384)
    height: int = pydantic.Field(gt=0, le=16384)
    fx: _Positive = pydantic.Field(allow_inf_nan=False)
    fy: _Positive = pydantic.Field(allow_inf_nan=False)
    cx: _Finite
    cy: _Finite
    # OpenCV k1 k2 p1 p2 k3.
    distortion: tuple[_Finite, _Finite, _Finite, _Finite, _Finite] | None = None
    depth_scale_m: _Positive = pydantic.Field(default=0.001, allow_inf_nan=False)

    @property
    def matrix(self) -> np.ndarray:
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def distortion_coefficients(self) -> np.ndarray:
        return np.zeros(5) if self.distortion is None else np.asarray(self.distortion, dtype=np.float64)

    @property
    def has_distortion(self) -> bool:
        return self.distortion is not None and any(self.distortion)


def load_camera(path: Path) -> Camera:
    return load_yaml_spec(Path(path), Camera)


def save_camera(camera: Camera, path: Path) -> None:
    write_text_atomic(Path(path), yaml.safe_dump(camera.model_dump(exclude_none=True), sort_keys=False))
