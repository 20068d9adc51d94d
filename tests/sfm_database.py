"""A COLMAP database for some of the photos of a larger run, started from that run's own: the
chosen photos' features, and the matches with their verified geometry of the pairs asked for,
copied with the images numbered by name as the pipeline numbers them (image_numbering).

SIFT finds a photo's features from that photo alone, and a pair's matches and their
verification depend on its two photos only (RANSAC is seeded per pair: pairing.
verification_options). COLMAP's extractor skips a photo the database holds features of, and its
matcher a pair it holds matches of, so `run_sfm` on the subset, started on this database,
finds what it would have found on its own and pays only for what the larger run did not do.
"""

from __future__ import annotations

import shutil
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from photogrammetry.image_numbering import write_numbered


@contextmanager
def kept_after_matching(copy: Path) -> Iterator[None]:
    """Within it, SfM's database is copied to `copy` once its photos are matched (the pipeline's
    own is in a scratch folder, gone when the command ends)."""
    from photogrammetry import sfm

    match = sfm._match

    def matching_kept(database: Path, *args, **kwargs) -> str:
        method = match(database, *args, **kwargs)
        shutil.copyfile(database, copy)
        return method

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(sfm, "_match", matching_kept)
        yield


def copy_features(source: Path, names: Iterable[str], target: Path) -> None:
    """A new database `target` with the rigs and cameras of `source` and the images `names`
    with their frames, pose priors, keypoints and descriptors, numbered 1... by name."""
    import pycolmap

    wanted = set(names)
    old = pycolmap.Database.open(source)
    new = pycolmap.Database.open(target)
    try:
        images = sorted((im for im in old.read_all_images() if im.name in wanted), key=lambda im: im.name)
        missing = wanted - {im.name for im in images}
        if missing:
            raise ValueError(f"{source}: no features of {sorted(missing)}")
        for camera in old.read_all_cameras():
            new.write_camera(camera, use_camera_id=True)
        for rig in old.read_all_rigs():
            new.write_rig(rig, use_rig_id=True)
        rig_of = {data.id: frame.rig_id for frame in old.read_all_frames() for data in frame.data_ids}
        priors = {prior.corr_data_id.id: prior for prior in old.read_all_pose_priors()}
        for new_id, image in enumerate(images, start=1):
            old_id = image.image_id
            features = old.read_keypoints(old_id), old.read_descriptors(old_id)
            write_numbered(new, image, new_id, rig_of[old_id], priors.get(old_id), *features)
    finally:
        new.close()
        old.close()


def copy_matches(source: Path, target: Path, pairs: Iterable[tuple[str, str]]) -> int:
    """The matches and verified two-view geometry `source` holds of each pair of photo names in
    `pairs` written into `target` (which holds the photos' features); returns how many pairs."""
    import pycolmap

    old = pycolmap.Database.open(source)
    new = pycolmap.Database.open(target)
    try:
        old_id = {im.name: im.image_id for im in old.read_all_images()}
        new_id = {im.name: im.image_id for im in new.read_all_images()}
        copied = 0
        for a, b in pairs:
            if not old.exists_two_view_geometry(old_id[a], old_id[b]):
                continue
            new.write_matches(new_id[a], new_id[b], old.read_matches(old_id[a], old_id[b]))
            new.write_two_view_geometry(new_id[a], new_id[b], old.read_two_view_geometry(old_id[a], old_id[b]))
            copied += 1
        return copied
    finally:
        new.close()
        old.close()
