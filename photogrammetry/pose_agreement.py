"""How well recovered camera poses agree with reference poses, up to a similarity.

An SfM frame is arbitrary in position, orientation and scale, so the recovered camera centres
are first aligned to the reference ones by the least-squares similarity (Umeyama 1991); what
remains is the error: each centre's distance to its reference, as a share of the reference
cameras' spread, and each camera's rotation error after the alignment.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from homemodel.core.errors import InputError
from homemodel.core.input_files import read_bounded

MAX_REFERENCE_BYTES = 16 * 1024 * 1024


def similarity_from_points(source: np.ndarray, target: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(scale, rotation, translation) minimising |target - (scale R source + t)|^2 over (N, 3) points."""
    source, target = np.asarray(source, np.float64), np.asarray(target, np.float64)
    if source.shape != target.shape or source.ndim != 2 or source.shape[1] != 3 or len(source) < 3:
        raise ValueError(f"{source.shape=} and {target.shape=} but expected two (N, 3), N >= 3")
    mu_s, mu_t = source.mean(axis=0), target.mean(axis=0)
    s, t = source - mu_s, target - mu_t
    u, d, vt = np.linalg.svd(t.T @ s / len(source))
    sign = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))])
    rotation = u @ sign @ vt
    scale = float(np.trace(np.diag(d) @ sign) / (s**2).sum(axis=1).mean())
    return scale, rotation, mu_t - scale * rotation @ mu_s


@dataclass(kw_only=True)
class PoseAgreement:
    views: int  # views in both sets
    median_centre_error: float  # share of the reference cameras' spread (RMS distance to their mean)
    max_centre_error: float
    median_rotation_error_deg: float
    max_rotation_error_deg: float


def pose_agreement(estimated: dict[str, np.ndarray], reference: dict[str, np.ndarray]) -> PoseAgreement:
    """Compare `camera_from_world` poses (4x4, by image name) on the names both hold."""
    names = sorted(set(estimated) & set(reference))
    if len(names) < 3:
        raise ValueError(f"only {len(names)} views in common: at least 3 are needed for a similarity")

    def centre(pose: np.ndarray) -> np.ndarray:
        return -pose[:3, :3].T @ pose[:3, 3]

    ours = np.array([centre(estimated[n]) for n in names])
    theirs = np.array([centre(reference[n]) for n in names])
    scale, rotation, translation = similarity_from_points(ours, theirs)
    aligned = ours @ (scale * rotation).T + translation
    spread = np.sqrt(((theirs - theirs.mean(axis=0)) ** 2).sum(axis=1).mean())
    centre_errors = np.linalg.norm(aligned - theirs, axis=1) / spread
    # camera_from_reference = camera_from_ours @ ours_from_reference, and ours_from_reference turns by R^T.
    relative = [estimated[n][:3, :3] @ rotation.T @ reference[n][:3, :3].T for n in names]
    rotation_errors = np.degrees(Rotation.from_matrix(np.array(relative)).magnitude())
    return PoseAgreement(
        views=len(names),
        median_centre_error=float(np.median(centre_errors)),
        max_centre_error=float(centre_errors.max()),
        median_rotation_error_deg=float(np.median(rotation_errors)),
        max_rotation_error_deg=float(np.max(rotation_errors)),
    )


def load_reference_cameras(path: Path) -> dict[str, np.ndarray]:
    """`camera_from_world` by image name from a JSON file {"cameras": {name: {"R": 3x3, "t": 3}}}."""
    path = Path(path)
    try:
        cameras = json.loads(read_bounded(path, MAX_REFERENCE_BYTES))["cameras"]
        poses = {}
        for name, camera in cameras.items():
            pose = np.eye(4)
            pose[:3, :3] = np.asarray(camera["R"], np.float64).reshape(3, 3)
            pose[:3, 3] = np.asarray(camera["t"], np.float64).reshape(3)
            poses[name] = pose
    except (ValueError, KeyError, TypeError) as error:
        raise InputError(f"{path}: not a reference camera file: {error}") from error
    return poses
