"""Structure from motion with pycolmap: features, matching, incremental mapping, undistortion.

The result is a set of pinhole views (undistorted photos with their cameras and
`camera_from_world` poses) and the sparse points, in COLMAP's arbitrary frame and scale.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np

from homemodel.core.checks import require_at_least, require_choice
from homemodel.core.errors import ModelError
from homemodel.core.images import read_image_size
from homemodel.core.progress import Progress, StageClock
from homemodel.geometry.camera import Camera

log = logging.getLogger(__name__)

MIN_REGISTERED_IMAGES = 3
UPSAMPLE_BELOW_PX = 1200


class RegistrationError(ModelError):
    """The photos do not make one reconstruction (too few register, or unrelated scenes)."""


@dataclass(kw_only=True)
class SfmOptions:
    """Options of the structure-from-motion stage."""

    max_image_size_px: int = 1600  # features are found on photos shrunk to this longer side
    max_num_features: int = 4096
    # "auto": exhaustive up to `exhaustive_max_images` photos, sequential (by file name) beyond.
    # A vocabulary tree would need a tree file that cannot be downloaded here.
    matching: Literal["auto", "exhaustive", "sequential"] = "auto"
    exhaustive_max_images: int = 60
    sequential_overlap: int = 12
    num_threads: int = -1
    random_state: int = 0

    def check(self) -> None:
        require_at_least("max_image_size_px", self.max_image_size_px, 200)
        require_at_least("max_num_features", self.max_num_features, 256)
        require_choice("matching", self.matching, ("auto", "exhaustive", "sequential"))
        require_at_least("exhaustive_max_images", self.exhaustive_max_images, 2)
        require_at_least("sequential_overlap", self.sequential_overlap, 1)
        if self.num_threads != -1:
            require_at_least("num_threads", self.num_threads, 1)


@dataclass(kw_only=True)
class View:
    """One registered, undistorted photo: a pinhole camera at a pose."""

    name: str
    image_path: Path  # the undistorted image
    camera: Camera  # of the undistorted image: no distortion
    camera_from_world: np.ndarray  # 4x4, OpenCV convention

    @property
    def centre_world(self) -> np.ndarray:
        r, t = self.camera_from_world[:3, :3], self.camera_from_world[:3, 3]
        return -r.T @ t

    @property
    def optical_axis_world(self) -> np.ndarray:
        return self.camera_from_world[2, :3].copy()


@dataclass(kw_only=True)
class SparseModel:
    """What the SfM stage found."""

    views: list[View]
    points_world: np.ndarray  # (N, 3)
    point_views: list[np.ndarray]  # per point, indices into `views` that observe it
    mean_reprojection_error_px: float
    unregistered: list[str]
    times_s: dict[str, float] = field(default_factory=dict)


def _camera_mode(photos: list[Path]):
    import pycolmap

    sizes = {read_image_size(p) for p in photos}
    # One size: one camera shared by all photos (a better calibration); else per photo.
    return pycolmap.CameraMode.SINGLE if len(sizes) == 1 else pycolmap.CameraMode.PER_IMAGE


def _match(database: Path, n_images: int, options: SfmOptions) -> str:
    import pycolmap

    matching = pycolmap.FeatureMatchingOptions(num_threads=options.num_threads)
    method = options.matching
    if method == "auto":
        method = "exhaustive" if n_images <= options.exhaustive_max_images else "sequential"
    if method == "exhaustive":
        pycolmap.match_exhaustive(database, matching_options=matching)
    else:
        pairing = pycolmap.SequentialPairingOptions(overlap=options.sequential_overlap, quadratic_overlap=True)
        pycolmap.match_sequential(database, matching_options=matching, pairing_options=pairing)
    return method


def _check_registration(photos_dir: Path, names: list[str], reconstructions: dict) -> object:
    """The one reconstruction the photos make, or a RegistrationError that says why not."""
    sizes = sorted(((r.num_reg_images(), k) for k, r in reconstructions.items()), reverse=True)
    if not sizes or sizes[0][0] < MIN_REGISTERED_IMAGES:
        registered = sizes[0][0] if sizes else 0
        raise RegistrationError(
            f"{photos_dir}: only {registered} of {len(names)} photos registered (at least {MIN_REGISTERED_IMAGES} "
            "are needed): the photos overlap too little or have too little texture"
        )
    if len(sizes) > 1 and sizes[1][0] >= MIN_REGISTERED_IMAGES:
        groups = [sorted(im.name for im in reconstructions[k].images.values()) for _, k in sizes]
        listing = "; ".join(f"{len(g)} photos ({g[0]} ...)" for g in groups)
        raise RegistrationError(
            f"{photos_dir}: the photos show unrelated scenes: they form {len(groups)} groups: {listing}"
        )
    best = reconstructions[sizes[0][1]]
    if 2 * best.num_reg_images() < len(names):
        raise RegistrationError(
            f"{photos_dir}: only {best.num_reg_images()} of {len(names)} photos registered together: "
            "most photos do not show the same scene"
        )
    return best


def run_sfm(
    photos: list[Path],
    work_dir: Path,
    options: SfmOptions | None = None,
    progress: Progress | None = None,
) -> SparseModel:
    """Register `photos` (all in one folder) and undistort them into `work_dir`; progress
    stages features, matching, mapping, undistortion."""
    import pycolmap

    options = options or SfmOptions()
    photos_dir = photos[0].parent
    names = [p.name for p in photos]
    work_dir.mkdir(parents=True, exist_ok=True)
    database = work_dir / "database.db"
    clock = StageClock(progress)
    pycolmap.set_random_seed(options.random_state)

    clock.start("features")
    extraction = pycolmap.FeatureExtractionOptions(
        max_image_size=options.max_image_size_px, num_threads=options.num_threads
    )
    extraction.sift.max_num_features = options.max_num_features
    # SIFT's upsampled first octave finds the many small features small photos need; on large
    # photos it costs four times the pixels for little gain.
    longest_px = min(max(max(read_image_size(p)) for p in photos), options.max_image_size_px)
    extraction.sift.first_octave = -1 if longest_px < UPSAMPLE_BELOW_PX else 0
    pycolmap.extract_features(
        database, photos_dir, image_names=names, camera_mode=_camera_mode(photos), extraction_options=extraction
    )

    clock.start("matching")
    method = _match(database, len(photos), options)

    clock.start("mapping")
    mapping = pycolmap.IncrementalPipelineOptions(min_model_size=MIN_REGISTERED_IMAGES, num_threads=options.num_threads)
    mapping.random_seed = options.random_state
    sparse_raw = work_dir / "sparse_raw"
    sparse_raw.mkdir(exist_ok=True)
    reconstructions = pycolmap.incremental_mapping(database, photos_dir, sparse_raw, options=mapping)
    best = _check_registration(photos_dir, names, reconstructions)

    clock.start("undistortion")
    best.write(sparse_raw)
    undistorted = work_dir / "undistorted"
    pycolmap.undistort_images(undistorted, sparse_raw, photos_dir)
    model = _load_undistorted(undistorted, photos_dir, names)
    clock.stop()
    model.mean_reprojection_error_px = float(best.compute_mean_reprojection_error())
    model.times_s = clock.times_s
    log.info("SfM: %d/%d photos registered (%s matching)", len(model.views), len(names), method)
    return model


def _load_undistorted(undistorted: Path, photos_dir: Path, names: list[str]) -> SparseModel:
    import pycolmap

    sparse_dir = undistorted / "sparse"
    reconstruction = pycolmap.Reconstruction(sparse_dir)
    images = sorted(reconstruction.images.values(), key=lambda im: im.name)
    views, index_of = [], {}
    for image in images:
        camera = image.camera
        camera_from_world = np.eye(4)
        camera_from_world[:3, :] = image.cam_from_world().matrix()
        index_of[image.image_id] = len(views)
        views.append(
            View(
                name=image.name,
                image_path=undistorted / "images" / image.name,
                camera=Camera.from_matrix(
                    camera.calibration_matrix(), width=int(camera.width), height=int(camera.height)
                ),
                camera_from_world=camera_from_world,
            )
        )
    points, point_views = [], []
    for point in reconstruction.points3D.values():
        points.append(point.xyz)
        point_views.append(np.unique([index_of[e.image_id] for e in point.track.elements]))
    if not points:
        raise RegistrationError(f"{photos_dir}: the reconstruction has no 3D points")
    registered = {v.name for v in views}
    return SparseModel(
        views=views,
        points_world=np.asarray(points, np.float64),
        point_views=point_views,
        mean_reprojection_error_px=0.0,
        unregistered=[n for n in names if n not in registered],
    )
