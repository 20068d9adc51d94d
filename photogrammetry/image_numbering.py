"""Image ids in COLMAP's database by photo name, whatever order the extraction finished in.

COLMAP's feature extractor numbers each photo when its features are written, and with
several extraction threads that is whichever photo finished first: the same photos got
other ids from run to run. The ids order the matching, the choice of the first pair and
the mapper's random draws, so the reconstruction changed with them (on Kermit, the camera
poses differed in every run). Numbering the photos by name after extraction makes a run
repeat itself.
"""

from __future__ import annotations

from pathlib import Path


def number_images_by_name(database: Path) -> None:
    """Renumber the images (and their frames, pose priors and features) of a database that
    holds features only (no matches yet) so that image and frame ids follow the names.
    Each image is in a frame of its own, as COLMAP's feature extractor writes them."""
    import pycolmap

    db = pycolmap.Database.open(database)
    try:
        images = sorted(db.read_all_images(), key=lambda image: image.name)
        if all(image.image_id == i and image.frame_id == i for i, image in enumerate(images, start=1)):
            return
        if db.num_matched_image_pairs() or db.num_verified_image_pairs():
            raise ValueError(f"{database}: images can only be renumbered before matching")
        rig_of = {data.id: frame.rig_id for frame in db.read_all_frames() for data in frame.data_ids}
        priors = {prior.corr_data_id.id: prior for prior in db.read_all_pose_priors()}
        features = {im.image_id: (db.read_keypoints(im.image_id), db.read_descriptors(im.image_id)) for im in images}
        for clear in (db.clear_pose_priors, db.clear_keypoints, db.clear_descriptors, db.clear_frames, db.clear_images):
            clear()
        for new_id, image in enumerate(images, start=1):
            old_id = image.image_id
            write_numbered(db, image, new_id, rig_of[old_id], priors.get(old_id), *features[old_id])
    finally:
        db.close()


def write_numbered(db, image, number: int, rig_id: int, prior, keypoints, descriptors) -> None:  # noqa: ANN001 (pycolmap's)
    """Write `image` into the open database `db` as image `number`, in a frame of its own (the
    same number) on rig `rig_id`, with its pose prior (or None) and its features."""
    import pycolmap

    image.image_id = image.frame_id = number
    frame = pycolmap.Frame()
    frame.frame_id, frame.rig_id = number, rig_id
    frame.add_data_id(image.data_id)
    db.write_frame(frame, use_frame_id=True)  # before the image, which must find its frame
    db.write_image(image, use_image_id=True)
    if prior is not None:
        prior.corr_data_id = image.data_id
        db.write_pose_prior(prior)
    db.write_keypoints(number, keypoints)
    db.write_descriptors(number, descriptors)
