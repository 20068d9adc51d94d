"""Which photos are matched with which: the least matching that still registers every photo.

Exhaustive matching tries every pair: sure, whatever order the photos were taken in, and on
two cores affordable up to about a hundred photos (its cost grows with their square). Beyond that, each photo
is matched with the photos most like it by image retrieval, with a vocabulary tree built from
the photos' own features (none can be downloaded here). When mapping leaves the photos in
several groups, `bridge_groups` matches every pair across the groups that was not tried yet,
and `shared_inliers` says whether two groups share geometry at all (one scene) or not.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np

# The words are learnt by k-means, whose time grows with descriptors x words x iterations: a
# sample is enough (faiss asks for about 40 training descriptors per word), and 20 iterations
# of one round instead of COLMAP's 100 x 3 (on 11 Kermit photos: 175 s under load, now ~15 s).
MAX_TREE_DESCRIPTORS = 200_000
DESCRIPTORS_PER_WORD = 40
KMEANS_ITERATIONS = 20


def matching_options(num_threads: int):
    import pycolmap

    return pycolmap.FeatureMatchingOptions(num_threads=num_threads)


def verification_options(seed: int):
    """Geometric verification with its RANSAC seeded per pair: unseeded, each matching thread
    draws from its own generator, and which pairs a thread gets changes from run to run."""
    import pycolmap

    options = pycolmap.TwoViewGeometryOptions()
    options.ransac.random_seed = seed
    return options


def match_exhaustive(database: Path, *, num_threads: int, seed: int) -> None:
    import pycolmap

    pycolmap.match_exhaustive(
        database, matching_options=matching_options(num_threads), verification_options=verification_options(seed)
    )


def build_vocabulary_tree(database: Path, tree_path: Path, *, num_threads: int, seed: int) -> Path:
    """A vocabulary tree learnt from (a sample of) the descriptors in `database`."""
    import pycolmap

    db = pycolmap.Database.open(database)
    try:
        descriptors = [np.asarray(db.read_descriptors(im.image_id).data) for im in db.read_all_images()]
    finally:
        db.close()
    every = np.vstack([d for d in descriptors if len(d)]).astype(np.float32)
    rng = np.random.default_rng(seed)
    if len(every) > MAX_TREE_DESCRIPTORS:
        every = every[rng.choice(len(every), MAX_TREE_DESCRIPTORS, replace=False)]
    index = pycolmap.VisualIndex.create(128, 64)
    build = pycolmap.VisualIndex.BuildOptions()
    build.num_visual_words = int(np.clip(len(every) // DESCRIPTORS_PER_WORD, 256, 65536))
    build.num_threads = num_threads
    build.num_iterations, build.num_rounds = KMEANS_ITERATIONS, 1
    index.build(build, pycolmap.FeatureDescriptorsFloat(type=pycolmap.FeatureExtractorType.SIFT, data=every))
    index.write(tree_path)
    return tree_path


def match_by_retrieval(database: Path, tree_path: Path, *, neighbours: int, num_threads: int, seed: int) -> None:
    """Match each photo with its `neighbours` most similar photos by the vocabulary tree."""
    import pycolmap

    pairing = pycolmap.VocabTreePairingOptions(
        num_images=neighbours, vocab_tree_path=str(tree_path), num_threads=num_threads
    )
    pycolmap.match_vocabtree(database, matching_options=matching_options(num_threads), pairing_options=pairing,
                             verification_options=verification_options(seed))  # fmt: skip


def bridge_groups(database: Path, groups: list[list[str]], work_dir: Path, *, num_threads: int, seed: int) -> int:
    """Match every not yet matched pair of photos that lie in different `groups` (lists of
    names; unregistered photos make groups of one). Returns the number of pairs newly matched."""
    import pycolmap

    db = pycolmap.Database.open(database)
    try:
        id_of = {im.name: im.image_id for im in db.read_all_images()}
        pairs = [
            (a, b)
            for group_a, group_b in itertools.combinations(groups, 2)
            for a in group_a
            for b in group_b
            if not db.exists_matches(id_of[a], id_of[b])
        ]
    finally:
        db.close()
    if not pairs:
        return 0
    match_list = work_dir / "bridge_pairs.txt"
    match_list.write_text("".join(f"{a} {b}\n" for a, b in pairs))
    pycolmap.match_image_pairs(
        database,
        matching_options=matching_options(num_threads),
        pairing_options=pycolmap.ImportedPairingOptions(match_list_path=str(match_list)),
        verification_options=verification_options(seed),
    )
    return len(pairs)


def shared_inliers(database: Path, names_a: list[str], names_b: list[str]) -> int:
    """The most geometrically verified matches a photo of `names_a` shares with one of
    `names_b`: near zero when the two groups show unrelated scenes."""
    import pycolmap

    db = pycolmap.Database.open(database)
    try:
        side = {db.read_image_with_name(n).image_id: 0 for n in names_a}
        side |= {db.read_image_with_name(n).image_id: 1 for n in names_b}
        pair_ids, counts = db.read_two_view_geometry_num_inliers()
    finally:
        db.close()
    best = 0
    for pair_id, count in zip(pair_ids, counts):
        a, b = pycolmap.pair_id_to_image_pair(int(pair_id))
        if a in side and b in side and side[a] != side[b]:
            best = max(best, int(count))
    return best
