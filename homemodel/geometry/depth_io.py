"""Depth images: 16-bit PNGs in units of `depth_scale_m`, or float32 EXRs in metres.

A missing measurement is 0 in a PNG and 0 or not finite in an EXR; in memory it is NaN.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from homemodel.core.atomic import write_bytes_atomic
from homemodel.core.errors import InputError
from homemodel.core.images import MAX_IMAGE_BYTES, check_pixel_count, read_image
from homemodel.core.input_files import read_bounded

_UINT16_MAX = 65535


def read_depth_m(path: Path, *, depth_scale_m: float) -> np.ndarray:
    """Depth in metres, (H, W) float32, NaN where missing."""
    path = Path(path)
    if path.suffix.lower() == ".exr":
        depth = _decode_exr(path, read_bounded(path, MAX_IMAGE_BYTES))
    else:
        import cv2

        raw = read_image(path, cv2.IMREAD_UNCHANGED)
        if raw.ndim != 2 or raw.dtype != np.uint16:
            raise InputError(f"{path}: depth PNG must be single-channel 16-bit, got {raw.dtype} with shape {raw.shape}")
        depth = raw.astype(np.float32) * np.float32(depth_scale_m)
        depth[raw == 0] = np.nan
    depth[~(np.isfinite(depth) & (depth > 0))] = np.nan
    return depth


def _decode_exr(path: Path, data: bytes) -> np.ndarray:
    import OpenEXR

    if not data.startswith(b"\x76\x2f\x31\x01"):
        raise InputError(f"{path}: not an OpenEXR file")
    try:
        with OpenEXR.File(io.BytesIO(data), header_only=True) as exr:
            (x_min, y_min), (x_max, y_max) = exr.header()["dataWindow"]
        check_pixel_count(path, int(x_max - x_min + 1), int(y_max - y_min + 1))
        with OpenEXR.File(io.BytesIO(data)) as exr:
            channels = exr.channels()
            name = next((c for c in ("Z", "Y", "R", "depth", "Depth") if c in channels), None)
            if name is None:
                raise InputError(f"{path}: EXR has none of the depth channels Z, Y, R (has {sorted(channels)})")
            pixels = np.array(channels[name].pixels, dtype=np.float32)
    except InputError:
        raise
    except Exception as exc:  # OpenEXR raises bare RuntimeErrors for corrupt files
        raise InputError(f"{path}: cannot read the EXR: {exc}") from None
    if pixels.ndim != 2:
        raise InputError(f"{path}: EXR channel {name} has shape {pixels.shape}, expected (H, W)")
    return pixels


def write_depth(path: Path, depth_m: np.ndarray, *, depth_scale_m: float) -> None:
    """Write metres (NaN = missing) as a 16-bit PNG (depth beyond its range becomes missing) or an EXR."""
    path = Path(path)
    depth = np.asarray(depth_m, dtype=np.float64)
    if path.suffix.lower() == ".exr":
        import OpenEXR

        pixels = np.where(np.isfinite(depth), depth, 0.0).astype(np.float32)
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
        tmp = path.with_name(f".{path.name}.tmp.exr")
        with OpenEXR.File(header, {"Z": pixels}) as exr:
            exr.write(str(tmp))
        tmp.replace(path)
        return
    import cv2

    units = np.where(np.isfinite(depth), np.round(depth / depth_scale_m), 0.0)
    units[(units < 0) | (units > _UINT16_MAX)] = 0
    ok, encoded = cv2.imencode(".png", units.astype(np.uint16))
    if not ok:
        raise InputError(f"{path}: could not encode the depth PNG")
    write_bytes_atomic(path, encoded.tobytes())
