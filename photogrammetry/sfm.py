"""Structure from motion with pycolmap: features, matching, incremental mapping, undistortion.

The result is a set of pinhole views (undistorted photos with their cameras and
`camera_from_world` poses) and the sparse points, in COLMAP's arbitrary frame and scale.
"""

from __future__ import annotations

import logging
import os
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Literal

import numpy as np

from homemodel.core.c_stdio_capture import captured_c_output
from homemodel.core.checks import require_at_least, require_between, require_choice
from homemodel.core.errors import ModelError
from homemodel.core.progress import Progress, StageClock
from homemodel.geometry.camera import Camera
from photogrammetry import merge_check, pairing
from photogrammetry.image_numbering import number_images_by_name
from photogrammetry.photo_cameras import (
    PhotoCamera,
    group_by_camera,
    read_photo_camera,
    sfm_photo_folder,
)
from photogrammetry.undistortion import undistort_photos

log = logging.getLogger(__name__)

MIN_REGISTERED_IMAGES = 3
UPSAMPLE_BELOW_PX = 1200
# Groups that share fewer verified matches than this show unrelated scenes.
MIN_BRIDGE_INLIERS = 30


class RegistrationError(ModelError):
    """The photos do not make one reconstruction (too few register, or unrelated scenes)."""


@dataclass(kw_only=True)
class SfmOptions:
    """Options of the structure-from-motion stage."""

    max_image_size_px: int = 1600  # features are found on photos shrunk to this longer side
    max_num_features: int = 4096
    # None: SIFT's upsampled first octave (-1) on photos under UPSAMPLE_BELOW_PX, where small
    # features need it; above, the photo as it is (0: a quarter of the pixels) with a lower
    # contrast threshold than COLMAP's 0.0067, which on the 1600 px Buddha photos finds ~2,800
    # features instead of ~1,500 (the upsampled octave finds ~4,100 at four times the cost).
    first_octave: int | None = None
    peak_threshold: float = 0.003
    # "auto": preemptive up to `exhaustive_max_images` photos (every pair tried on its largest
    # features, in any order and any number of rings; the pairs that share them matched in
    # full), image retrieval with a vocabulary tree learnt from the photos beyond.
    matching: Literal["auto", "exhaustive", "preemptive", "retrieval"] = "auto"
    # A pair cost 0.34 s at ~2,800 features on two cores under a load of 15 (Buddha's 67 photos:
    # 13 minutes), 0.06 s at ~1,500 features under a load of 5: 120 photos are 7,140 pairs.
    exhaustive_max_images: int = 120
    retrieval_neighbours: int = 40
    # The undistorted views are written at most this large (the texture is sampled from 1600 px,
    # depth from fewer); None: at the photos' size.
    undistorted_max_px: int | None = 1600
    num_threads: int = -1
    random_state: int = 0
    verbose: bool = False  # let COLMAP log (glog) and C libraries print

    def check(self) -> None:
        require_at_least("max_image_size_px", self.max_image_size_px, 200)
        require_at_least("max_num_features", self.max_num_features, 256)
        if self.undistorted_max_px is not None:
            require_at_least("undistorted_max_px", self.undistorted_max_px, 200)
        require_choice("first_octave", self.first_octave, (None, -1, 0))
        require_between("peak_threshold", self.peak_threshold, 1e-4, 0.1)
        require_choice("matching", self.matching, ("auto", "exhaustive", "preemptive", "retrieval"))
        require_at_least("exhaustive_max_images", self.exhaustive_max_images, 2)
        require_at_least("retrieval_neighbours", self.retrieval_neighbours, 2)
        if self.num_threads != -1:
            require_at_least("num_threads", self.num_threads, 1)

    @property
    def threads(self) -> int:
        """`num_threads`, with -1 made the number of cores this process may use (for our own
        thread pools; COLMAP takes -1 itself)."""
        return self.num_threads if self.num_threads > 0 else len(os.sched_getaffinity(0))


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
    matching: str = ""  # how pairs were chosen, and whether groups had to be bridged
    cameras: int = 1  # camera models (one per camera and zoom)
    median_features: int = 0  # SIFT features per photo (median): enough kept of large photos?

    def without(self, names: set[str]) -> SparseModel:
        """This model less the named views (then reported unregistered), with the points the
        other views still see from two or more."""
        kept = [i for i, v in enumerate(self.views) if v.name not in names]
        index = {old: new for new, old in enumerate(kept)}
        points, point_views = [], []
        for point, seen_by in zip(self.points_world, self.point_views):
            seen = np.array([index[i] for i in seen_by if i in index], dtype=np.int64)
            if len(seen) >= 2:
                points.append(point)
                point_views.append(seen)
        return replace(
            self,
            views=[self.views[i] for i in kept],
            points_world=np.asarray(points, np.float64).reshape(-1, 3),
            point_views=point_views,
            unregistered=[*self.unregistered, *sorted(names)],
        )


@contextmanager
def quiet_c_libraries(verbose: bool) -> Iterator[None]:
    """COLMAP's glog lines and what C libraries (libpng, libjpeg) print go to the debug log,
    not the terminal, unless `verbose`."""
    import pycolmap

    if verbose:
        yield
        return
    level = pycolmap.logging.minloglevel
    pycolmap.logging.minloglevel = 2  # errors only
    try:
        with captured_c_output(fds=(2,)) as lines:  # glog and libpng write to stderr; progress bars to stdout
            yield
    finally:
        pycolmap.logging.minloglevel = level
    for line in lines:
        log.debug("colmap: %s", line)


def _extract_features(database: Path, image_dir: Path, cameras: dict[str, PhotoCamera], options: SfmOptions) -> int:
    """SIFT features of every photo, one camera model per camera (EXIF focal length as its prior)."""
    import pycolmap

    extraction = pycolmap.FeatureExtractionOptions(
        max_image_size=options.max_image_size_px, num_threads=options.num_threads
    )
    extraction.sift.max_num_features = options.max_num_features
    longest_px = min(max(max(c.width, c.height) for c in cameras.values()), options.max_image_size_px)
    octave = options.first_octave
    if octave is None:
        octave = -1 if longest_px < UPSAMPLE_BELOW_PX else 0
    extraction.sift.first_octave = octave
    extraction.sift.peak_threshold = options.peak_threshold
    groups = group_by_camera(cameras)
    for names in groups:
        camera = cameras[names[0]]
        reader = pycolmap.ImageReaderOptions()
        if camera.focal_px is not None:
            # Given parameters are COLMAP's focal length prior (SIMPLE_RADIAL: f, cx, cy, k).
            reader.camera_params = f"{camera.focal_px},{camera.width / 2},{camera.height / 2},0"
        pycolmap.extract_features(database, image_dir, image_names=names, camera_mode=pycolmap.CameraMode.SINGLE,
                                  reader_options=reader, extraction_options=extraction)  # fmt: skip
    number_images_by_name(database)
    return len(groups)


def _median_features(database: Path) -> int:
    """The median number of SIFT features found per photo."""
    import pycolmap

    db = pycolmap.Database.open(database)
    try:
        return int(np.median([db.num_keypoints_for_image(im.image_id) for im in db.read_all_images()]))
    finally:
        db.close()


def _match(database: Path, n_images: int, work_dir: Path, options: SfmOptions) -> str:
    method = options.matching
    if method == "auto":
        method = "preemptive" if n_images <= options.exhaustive_max_images else "retrieval"
    if method == "exhaustive":
        pairing.match_exhaustive(database, num_threads=options.num_threads, seed=options.random_state)
    elif method == "preemptive":
        pairs = pairing.preemptive_pairs(database)
        pairing.match_listed_pairs(database, pairs, work_dir / "preemptive_pairs.txt", num_threads=options.num_threads,
                                   seed=options.random_state)  # fmt: skip
    else:
        tree = pairing.build_vocabulary_tree(
            database, work_dir / "vocabulary_tree.bin", num_threads=options.num_threads, seed=options.random_state
        )
        pairing.match_by_retrieval(
            database, tree, neighbours=options.retrieval_neighbours, num_threads=options.num_threads,
            seed=options.random_state,
        )
    return method


def _mapping_options(options: SfmOptions, *, relaxed: bool):
    import pycolmap

    # One thread: with two, the same matches gave slightly different poses from run to run
    # (and on Kermit one more or one fewer point), so nothing downstream repeated itself.
    mapping = pycolmap.IncrementalPipelineOptions(min_model_size=MIN_REGISTERED_IMAGES, num_threads=1)
    mapping.random_seed = options.random_state
    # Global bundle adjustment, the mapper's main cost, less often and on the points that add
    # coverage only: on the 50 rendered photos 46 s -> 36 s, the same 50 registered at the
    # same reprojection error (0.54 px).
    mapping.mapper.ba_global_ignore_redundant_points3D = True
    mapping.ba_global_frames_ratio = mapping.ba_global_points_ratio = 1.25
    # The sparse points' colours are never used: COLMAP would decode every photo again for
    # them (50 rendered 1600 px PNGs: ~5 CPU-s; a 12-megapixel JPEG costs several times more).
    mapping.extract_colors = False
    if relaxed:
        # The second pass, continuing from the largest model: photos with fewer, or fewer
        # clean, matches may join (each one still checked by its reprojection errors).
        mapping.min_num_matches = 10
        mapping.mapper.abs_pose_min_num_inliers = 15
        mapping.mapper.abs_pose_min_inlier_ratio = 0.1
        mapping.mapper.max_reg_trials = 6
    return mapping


def _most_registered(reconstructions: dict) -> int:
    return max((r.num_reg_images() for r in reconstructions.values()), default=0)


def _groups(names: list[str], reconstructions: dict) -> list[list[str]]:
    """The photos of each model, largest first, then each unregistered photo alone."""
    models = sorted((sorted(im.name for im in r.images.values()) for r in reconstructions.values()), key=len,
                    reverse=True)  # fmt: skip
    placed = {n for g in models for n in g}
    return models + [[n] for n in names if n not in placed]


def _map(database: Path, image_dir: Path, photos_dir: Path, names: list[str], work_dir: Path, options: SfmOptions):
    """The largest model the photos make. When the first, incremental pass leaves photos out
    or in several groups, COLMAP's global mapper tries them all at once on the same matches;
    if photos are still left out, every pair across the groups is matched, mapping continues
    from the largest model with relaxed thresholds, and the global mapper tries again. A
    joined model is kept only when it registers more photos and keeps each first-pass group's
    shape and aim (`merge_check`). Raises RegistrationError only when the photos really do not
    connect."""
    import pycolmap

    first = work_dir / "sparse_first"
    first.mkdir(exist_ok=True)
    reconstructions = pycolmap.incremental_mapping(
        database, image_dir, first, options=_mapping_options(options, relaxed=False)
    )
    groups = _groups(names, reconstructions)
    note = ""
    if reconstructions and len(groups) > 1:
        parts = list(reconstructions.values())
        # On the 33 all-round Buddha photos (two groups and two photos left out) the global
        # mapper alone registers all 33 at the reference poses in 3.6 CPU-s; bridging and the
        # second pass before it cost ~30.
        reconstructions, refusal = _joined_if_sound(
            reconstructions, _global_mapping(database, image_dir, work_dir / "global_first", options), parts
        )
        note = f"; {len(groups)} groups after the first pass, then the global mapper" + refusal
        if _most_registered(reconstructions) < len(names):
            bridged = pairing.bridge_groups(
                database, groups, work_dir, num_threads=options.num_threads, seed=options.random_state
            )
            largest = max(parts, key=lambda r: r.num_reg_images())
            seed_dir = work_dir / "sparse_seed"
            seed_dir.mkdir(exist_ok=True)
            largest.write(seed_dir)
            second = work_dir / "sparse_second"
            second.mkdir(exist_ok=True)
            continued = pycolmap.incremental_mapping(
                database, image_dir, second, options=_mapping_options(options, relaxed=True), input_path=seed_dir
            )
            reconstructions, refusal = _joined_if_sound(reconstructions, continued, parts)
            note += f"; {bridged} pairs matched across the groups, mapped again" + refusal
            if _most_registered(reconstructions) < len(names):
                # The global mapper registered 29 of 30 sparse Buddha photos where the
                # incremental one stopped at 24 (after the bridging).
                solved = _global_mapping(database, image_dir, work_dir / "global_bridged", options)
                reconstructions, refusal = _joined_if_sound(reconstructions, solved, parts)
                note += ", then the global mapper again" + refusal
        log.info("SfM%s", note)
    return _check_registration(database, photos_dir, names, reconstructions), note


def _global_mapping(database: Path, image_dir: Path, out_dir: Path, options: SfmOptions) -> dict:
    """COLMAP's global mapper (GLOMAP: every rotation and position solved at once) on the
    matches in `database`, run on a copy of it (the mapper writes its own view graph there)."""
    import pycolmap

    out_dir.mkdir(exist_ok=True)
    shutil.copyfile(database, out_dir / "global.db")
    mapping = pycolmap.GlobalPipelineOptions(min_model_size=MIN_REGISTERED_IMAGES, num_threads=options.num_threads)
    mapping.random_seed = options.random_state
    return pycolmap.global_mapping(out_dir / "global.db", image_dir, out_dir, options=mapping)


def _joined_if_sound(current: dict, joined: dict, parts: list) -> tuple[dict, str]:
    """`joined` when its largest model registers more photos than `current`'s and keeps every
    first-pass model's geometry, else `current`; with a note of a refusal."""
    if _most_registered(joined) <= _most_registered(current):
        return current, ""
    refused = merge_check.refusal(max(joined.values(), key=lambda r: r.num_reg_images()), parts)
    if refused is None:
        return joined, ""
    log.warning("SfM: a model of %d photos refused: %s", _most_registered(joined), refused)
    return current, f" (its {_most_registered(joined)}-photo model refused: {refused})"


def _check_registration(database: Path, photos_dir: Path, names: list[str], reconstructions: dict):
    """The largest reconstruction, or a RegistrationError when there is none worth having: too
    few photos register, or another group of photos shares no geometry with it (unrelated
    scenes). Groups that do share geometry but would not merge are not refused: their photos
    are reported unregistered."""
    groups = _groups(names, reconstructions)
    registered = len(groups[0]) if reconstructions else 0
    if registered < MIN_REGISTERED_IMAGES:
        raise RegistrationError(
            f"{photos_dir}: only {registered} of {len(names)} photos registered (at least {MIN_REGISTERED_IMAGES} "
            "are needed): the photos overlap too little or have too little texture"
        )
    others = [g for g in groups[1:] if len(g) >= MIN_REGISTERED_IMAGES]
    unrelated = [g for g in others if pairing.shared_inliers(database, groups[0], g) < MIN_BRIDGE_INLIERS]
    if unrelated:
        listing = "; ".join(f"{len(g)} photos ({g[0]} ...)" for g in [groups[0], *unrelated][:4])
        raise RegistrationError(
            f"{photos_dir}: the photos show unrelated scenes: they form {1 + len(unrelated)} groups that share no "
            f"geometry: {listing}"
        )
    if 2 * registered < len(names):
        raise RegistrationError(
            f"{photos_dir}: only {registered} of {len(names)} photos registered together: "
            "most photos do not overlap the others enough, or have too little texture"
        )
    return max(reconstructions.values(), key=lambda r: r.num_reg_images())


def run_sfm(
    photos: list[Path],
    work_dir: Path,
    options: SfmOptions | None = None,
    progress: Progress | None = None,
) -> SparseModel:
    """Register `photos` (all in one folder, already checked by `list_photos`) and undistort
    them into `work_dir`; progress stages features, matching, mapping, undistortion."""
    import pycolmap

    options = options or SfmOptions()
    work_dir.mkdir(parents=True, exist_ok=True)
    database = work_dir / "database.db"
    clock = StageClock(progress)
    pycolmap.set_random_seed(options.random_state)

    with quiet_c_libraries(options.verbose):
        clock.start("features")
        cameras = {p.name: read_photo_camera(p) for p in photos}
        image_dir, sfm_name = sfm_photo_folder(photos, cameras, work_dir)
        cameras = {sfm_name[n]: camera for n, camera in cameras.items()}
        names = [sfm_name[p.name] for p in photos]
        n_cameras = _extract_features(database, image_dir, cameras, options)
        features = _median_features(database)

        clock.start("matching")
        method = _match(database, len(photos), work_dir, options)

        clock.start("mapping")
        best, note = _map(database, image_dir, photos[0].parent, names, work_dir, options)

        clock.start("undistortion")
        model = _undistort(best, image_dir, work_dir, names, options)
    clock.stop()
    photo_name = {sfm: own for own, sfm in sfm_name.items()}
    for view in model.views:
        view.name = photo_name[view.name]
    model.unregistered = [photo_name[n] for n in model.unregistered]
    model.mean_reprojection_error_px = float(best.compute_mean_reprojection_error())
    model.times_s = clock.times_s
    model.matching = method + note
    model.cameras = n_cameras
    model.median_features = features
    log.info("SfM: %d/%d photos registered (%s matching)", len(model.views), len(names), model.matching)
    return model


def _undistort(best, image_dir: Path, work_dir: Path, names: list[str], options: SfmOptions) -> SparseModel:
    """The registered photos as pinhole views (written undistorted into work_dir/undistorted),
    with the sparse points."""
    written = undistort_photos(
        best, image_dir, work_dir / "undistorted", workers=options.threads, max_side_px=options.undistorted_max_px
    )
    images = sorted(best.images.values(), key=lambda im: im.name)
    views, index_of = [], {}
    for image in images:
        camera_from_world = np.eye(4)
        camera_from_world[:3, :] = image.cam_from_world().matrix()
        index_of[image.image_id] = len(views)
        path, camera = written[image.name]
        views.append(View(name=image.name, image_path=path, camera=camera, camera_from_world=camera_from_world))
    points, point_views = [], []
    for point in best.points3D.values():
        points.append(point.xyz)
        point_views.append(np.unique([index_of[e.image_id] for e in point.track.elements]))
    if not points:
        raise RegistrationError(f"{image_dir}: the reconstruction has no 3D points")
    registered = {v.name for v in views}
    return SparseModel(
        views=views,
        points_world=np.asarray(points, np.float64),
        point_views=point_views,
        mean_reprojection_error_px=0.0,
        unregistered=[n for n in names if n not in registered],
    )
