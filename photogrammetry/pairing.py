"""Which photos are matched with which: the least matching that still registers every photo.

Exhaustive matching tries every pair: sure, whatever order the photos were taken in, but most
pairs of a set shot in rings see nothing in common. Preemptive matching also looks at every
pair, on its photos' largest features only (a few seconds for a hundred photos), and matches in
full only the pairs that share some. Beyond about a hundred photos, each photo is matched with
the photos most like it by image retrieval, with a vocabulary tree built from the photos' own
features (none can be downloaded here). When mapping leaves the photos in several groups,
`bridge_groups` matches every pair across the groups that was not tried yet, and
`shared_inliers` says whether two groups share geometry at all (one scene) or not.
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
# Preemptive matching (Wu, "Towards linear-time incremental structure from motion", 3DV 2013):
# the largest features of two photos that see the same thing match each other.
PREEMPTIVE_FEATURES = 100
PREEMPTIVE_RATIO = 0.8
# Measured on Buddha's 67 photos against exhaustive matching: pairs with 3 or more such matches
# were 31% of all pairs and held 92% of the verified inliers (at 2: 46% and 96%). On a set where
# nearly every pair overlaps (the rendered one: 81% of its pairs share 3), each photo keeps its
# 10 best: Buddha then matches 419 of 2,211 pairs, the rendered set 282 of 1,225, and both
# register every photo at the reprojection error of exhaustive matching. With 15 (562 and 437
# pairs) every real set registered the same photos with the same refusals, and the rendered set's
# matching and mapping took 30.3 and 21.4 CPU-s against 21.3 and 18.1 (back to back, load 4-6).
PREEMPTIVE_MIN_MATCHES = 3
PREEMPTIVE_PER_PHOTO = 8  # partners each photo keeps whatever their count
PREEMPTIVE_MAX_PER_PHOTO = 10  # partners each photo asks for at most


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


def _largest_features(db, image_id: int, count: int) -> np.ndarray:
    """The unit descriptors (float32) of an image's `count` largest-scale features."""
    keypoints = np.asarray(db.read_keypoints(image_id), dtype=np.float64).reshape(-1, 6)
    descriptors = np.asarray(db.read_descriptors(image_id).data, dtype=np.float32)
    # A keypoint's affine shape (a11, a12, a21, a22): its scale is the square root of the determinant.
    scale = np.sqrt(np.abs(keypoints[:, 2] * keypoints[:, 5] - keypoints[:, 3] * keypoints[:, 4]))
    chosen = descriptors[np.argsort(-scale, kind="stable")[:count]]
    return chosen / np.maximum(np.linalg.norm(chosen, axis=1, keepdims=True), 1e-9)


def preemptive_match_counts(database: Path, *, features: int = PREEMPTIVE_FEATURES) -> tuple[list[str], np.ndarray]:
    """The photos by name, and for every pair the matches among their `features` largest-scale
    features (Wu 2013's preemptive matching: large features are the ones most likely to be
    seen again from another view)."""
    import pycolmap

    db = pycolmap.Database.open(database)
    try:
        images = sorted(db.read_all_images(), key=lambda im: im.name)
        chosen = [_largest_features(db, im.image_id, features) for im in images]
    finally:
        db.close()
    return [im.name for im in images], mutual_match_counts(chosen)


def mutual_match_counts(descriptor_sets: list[np.ndarray]) -> np.ndarray:
    """(n, n) symmetric: for each pair of sets of unit descriptors, how many are each other's
    nearest neighbour and pass the ratio test (both ways: the smaller count of the two)."""
    n, h = len(descriptor_sets), max((len(d) for d in descriptor_sets), default=0)
    stacked = np.zeros((n, h, 128), np.float32)
    present = np.zeros((n, h), bool)
    for i, descriptors in enumerate(descriptor_sets):
        stacked[i, : len(descriptors)] = descriptors
        present[i, : len(descriptors)] = True
    flat = stacked.reshape(n * h, 128)
    counts = np.zeros((n, n), np.int32)
    for i in range(n):
        # Cosine similarity of set i's descriptors with every descriptor of every set: (h, n, h).
        similarity = (stacked[i] @ flat.T).reshape(h, n, h)
        similarity[:, ~present] = -2.0
        order = np.argsort(-similarity, axis=2)[:, :, :2]
        best, second = np.take_along_axis(similarity, order, axis=2).transpose(2, 0, 1)
        # Unit vectors: the squared distance is 2 - 2 cos.
        passes = np.sqrt(np.maximum(2 - 2 * best, 0)) < PREEMPTIVE_RATIO * np.sqrt(np.maximum(2 - 2 * second, 0))
        closest_in_i = np.argmax(np.where(present[i][:, None, None], similarity, -3.0), axis=0)  # (n, h)
        mutual = closest_in_i[np.arange(n)[None, :], order[:, :, 0]] == np.arange(h)[:, None]  # (h, n)
        counts[i] = np.sum(passes & mutual & present[i][:, None] & (best > -2.0), axis=0)
    np.fill_diagonal(counts, 0)
    return np.minimum(counts, counts.T)


def preemptive_pairs(database: Path) -> list[tuple[str, str]]:
    """The pairs of photos in `database` worth matching in full (`chosen_pairs`)."""
    return chosen_pairs(*preemptive_match_counts(database))


def chosen_pairs(names: list[str], counts: np.ndarray) -> list[tuple[str, str]]:
    """Each photo with its best partners by their largest features' matches `counts`: up to
    `PREEMPTIVE_MAX_PER_PHOTO` of those with at least `PREEMPTIVE_MIN_MATCHES`, and at least
    `PREEMPTIVE_PER_PHOTO` whatever their count (a photo with few large features is still tried)."""
    chosen = np.zeros(counts.shape, bool)
    for i, row in enumerate(counts):
        ranked = [j for j in np.argsort(-row, kind="stable") if j != i]  # never itself, even among zeros
        asked = ranked[:PREEMPTIVE_MAX_PER_PHOTO]
        asked = [j for j in asked if row[j] >= PREEMPTIVE_MIN_MATCHES] + ranked[:PREEMPTIVE_PER_PHOTO]
        chosen[i, asked] = chosen[asked, i] = True
    return [(names[i], names[j]) for i, j in zip(*np.nonzero(np.triu(chosen, 1)))]


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
    match_listed_pairs(database, pairs, work_dir / "bridge_pairs.txt", num_threads=num_threads, seed=seed)
    return len(pairs)


def match_listed_pairs(database: Path, pairs: list[tuple[str, str]], list_path: Path, *, num_threads: int, seed: int) -> None:
    """Match and verify the given pairs of photo names (written to `list_path` for COLMAP)."""
    import pycolmap

    list_path.write_text("".join(f"{a} {b}\n" for a, b in pairs))
    pycolmap.match_image_pairs(
        database,
        matching_options=matching_options(num_threads),
        pairing_options=pycolmap.ImportedPairingOptions(match_list_path=str(list_path)),
        verification_options=verification_options(seed),
    )


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
