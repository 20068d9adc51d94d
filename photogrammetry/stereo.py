"""Dense depth on the CPU: semi-global matching on rectified pairs of registered views.

pycolmap's PatchMatch stereo needs CUDA. Here each view (the reference) is paired with its
best neighbours; each pair is rectified (`cv2.stereoRectify`), matched with OpenCV's SGBM
(with its left-right check), and the disparity turned back into depth along the reference's
own pixel rays. A pixel keeps a depth only where at least `min_agreeing_pairs` pairs agree:
the consistency filter across views that removes occlusions and mismatches. The sparse points
a view sees check each pair's depth (`sparse_verdict`): a pair they refute is dropped, and a
view left with one pair they confirm keeps that pair's depth alone. A sparse set's views at
the object's foot share points with only one view at a good angle; without that they gave
no depth, and the side they face was missing.
"""

from __future__ import annotations

from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from homemodel.core.checks import require_at_least, require_between, require_positive
from homemodel.core.progress import Progress
from homemodel.geometry.camera import Camera
from photogrammetry.photos import read_rgb
from photogrammetry.sfm import SparseModel, View

MAX_DISPARITIES = 256


@dataclass(kw_only=True)
class DenseOptions:
    """Options of the dense depth stage."""

    # Depth maps are computed on views shrunk to this longer side; None: from the photos
    # (`depth_image_side_px`): as fine as the fusion keeps, within the photos' own pixels and
    # `max_work_px3`.
    max_image_size_px: int | None = None
    # Semi-global matching's time grows with pixels times disparities, the side cubed: all views'
    # sides cubed add up to at most this, the cost of 50 views at 800 px (Kermit's 640 px views
    # took 0.75 CPU-s each): 66 photos get 729 px views, 14 photos 1,223 px.
    max_work_px3: float = 50 * 800.0**3
    neighbours: int = 4  # source views paired with each reference view
    min_agreeing_pairs: int = 2
    depth_tolerance: float = 0.01  # pairs agree when their depths differ by less than this fraction
    min_angle_deg: float = 4.0  # triangulation angle of a good pair (at the scene)
    max_angle_deg: float = 35.0
    # 3 px blocks: 5 px ones carried the nearer surface's disparity further across its outline
    # (rendered set, six views' points: mean distance to the truth 0.35 -> 0.30 mm, same time).
    block_size_px: int = 3
    # Depth within this of a depth step is dropped (`without_depth_edges`; 0: kept): with 3 px
    # blocks, 0.30 -> 0.27 mm, and points over 3 mm off 0.11 % -> 0.03 %.
    edge_radius_px: int = 2
    # A pair searches the depths of the sparse points both views see, from their near / this to
    # their far * this, and the pixels they cover widened by this share of the photo's side.
    range_margin: float = 1.25
    region_margin: float = 0.05
    # Depth pixels become points every this many along rows and columns: neighbouring pixels
    # mostly land in one fusion voxel, which many views fill anyway (on the rendered set, fusion
    # 8.8 s -> 2.8 s, mean surface distance 0.184 % -> 0.196 % of the size).
    point_step_px: int = 2

    def check(self) -> None:
        if self.max_image_size_px is not None:
            require_at_least("max_image_size_px", self.max_image_size_px, 100)
        require_positive("max_work_px3", self.max_work_px3)
        require_at_least("neighbours", self.neighbours, 1)
        require_at_least("min_agreeing_pairs", self.min_agreeing_pairs, 1)
        require_positive("depth_tolerance", self.depth_tolerance)
        require_between("min_angle_deg", self.min_angle_deg, 0.0, self.max_angle_deg)
        require_between("max_angle_deg", self.max_angle_deg, self.min_angle_deg, 90.0)
        require_at_least("block_size_px", self.block_size_px, 1)
        require_at_least("edge_radius_px", self.edge_radius_px, 0)
        require_at_least("range_margin", self.range_margin, 1.0)
        require_at_least("region_margin", self.region_margin, 0.0)
        require_at_least("point_step_px", self.point_step_px, 1)


@dataclass(kw_only=True)
class DepthMap:
    """Depth (metres or SfM units, 0 = none) along the pixel rays of a shrunk view."""

    view_index: int
    depth: np.ndarray  # (H, W) float32
    colour: np.ndarray  # (H, W, 3) uint8
    camera: Camera  # of this resolution


def choose_neighbours(model: SparseModel, options: DenseOptions) -> list[list[int]]:
    """For each view, the views that share the most sparse points at a good triangulation angle."""
    n = len(model.views)
    centres = np.array([v.centre_world for v in model.views])
    shared = np.zeros((n, n))
    for point, seen_by in zip(model.points_world, model.point_views):
        rays = centres[seen_by] - point
        rays /= np.linalg.norm(rays, axis=1, keepdims=True)
        angles = np.degrees(np.arccos(np.clip(rays @ rays.T, -1, 1)))
        good = (angles >= options.min_angle_deg) & (angles <= options.max_angle_deg)
        shared[np.ix_(seen_by, seen_by)] += good
    np.fill_diagonal(shared, 0)
    return [[int(j) for j in np.argsort(-shared[i])[: options.neighbours] if shared[i, j] > 0] for i in range(n)]


MIN_DEPTH_IMAGE_PX = 320


def depth_image_side_px(model: SparseModel, options: DenseOptions, *, focus: np.ndarray, voxel: float) -> int:
    """The depth maps' longer side, from the photos: `options.max_image_size_px` when given;
    else so fine that the depth pixels made points (every `point_step_px`) lie a fusion
    `voxel` apart where the median view sees `focus` (finer only adds points the fusion
    averages away), never finer than the undistorted photos, and within `max_work_px3`."""
    if options.max_image_size_px is not None:
        return options.max_image_size_px
    sides = np.array([max(v.camera.width, v.camera.height) for v in model.views], np.float64)
    distances = np.array([np.linalg.norm(v.centre_world - focus) for v in model.views])
    focals = np.array([v.camera.fx for v in model.views])
    # A pixel at distance d spans d / f; at the side S' = k S the focal is k f.
    fusion_side = np.median(options.point_step_px * distances / (voxel * focals) * sides)
    budget_side = (options.max_work_px3 / len(model.views)) ** (1 / 3)
    side = min(fusion_side, float(np.median(sides)), budget_side)
    return int(max(MIN_DEPTH_IMAGE_PX, round(side)))


MIN_RANGE_POINTS = 10


@dataclass(frozen=True)
class PairWindow:
    """What one pair searches: depths in the reference from `near` to `far`, and the
    reference's pixels `region` (x0, y0, x1, y1 at the full photo's size, inclusive)."""

    near: float
    far: float
    region: tuple[float, float, float, float]


def seen_matrix(model: SparseModel) -> np.ndarray:
    """(points, views) bool: which views see each sparse point."""
    counts = np.array([len(seen_by) for seen_by in model.point_views])
    seen = np.zeros((len(model.points_world), len(model.views)), bool)
    if counts.sum():
        seen[np.repeat(np.arange(len(counts)), counts), np.concatenate(model.point_views).astype(int)] = True
    return seen


def in_frame_pixels(
    points: np.ndarray, camera_from_world: np.ndarray, camera: Camera, shape: tuple[int, ...]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Of `points` (N, 3, world), those in front of the camera whose pixel, rounded, lies in an
    image of `shape`: their indices, pixels (K, 2) as (x, y), and depths."""
    camera_points = points @ camera_from_world[:3, :3].T + camera_from_world[:3, 3]
    index = np.flatnonzero(camera_points[:, 2] > 0)
    pixels = np.round(camera.project(camera_points[index])).astype(np.int64)
    height, width = shape[:2]
    inside = (pixels[:, 0] >= 0) & (pixels[:, 0] < width) & (pixels[:, 1] >= 0) & (pixels[:, 1] < height)
    return index[inside], pixels[inside], camera_points[index[inside], 2]


def pair_windows(
    model: SparseModel, neighbours: list[list[int]], options: DenseOptions, *, roi: tuple[np.ndarray, float] | None = None
) -> dict[tuple[int, int], PairWindow]:
    """Per pair (reference, source), the depths and pixels of the sparse points both views see
    within the region of interest `roi` (centre, radius; None: everywhere), widened by
    `range_margin` and `region_margin`. SGBM's time grows with the pixels times the disparities
    it searches; a pair matches only what both views see, and the fusion keeps only the
    region's points. Pairs that share too few points take the reference's, views that see too
    few take all points."""
    seen = seen_matrix(model)
    if roi is not None:
        centre, radius = roi
        inside = np.linalg.norm(model.points_world - centre, axis=1) <= radius
        seen &= inside[:, None]
    windows = {}
    for i, view in enumerate(model.views):
        own = seen[:, i] if seen[:, i].sum() >= MIN_RANGE_POINTS else np.ones(len(seen), bool)
        margin_px = options.region_margin * max(view.camera.width, view.camera.height)
        for j in neighbours[i]:
            both = own & seen[:, j]
            points = model.points_world[both if both.sum() >= MIN_RANGE_POINTS else own]
            camera_points = points @ view.camera_from_world[:3, :3].T + view.camera_from_world[:3, 3]
            camera_points = camera_points[camera_points[:, 2] > 0]
            near, far = np.percentile(camera_points[:, 2], [1, 99])
            (x0, y0), (x1, y1) = view.camera.project(camera_points).min(axis=0), view.camera.project(camera_points).max(axis=0)
            windows[i, j] = PairWindow(
                near=float(near) / options.range_margin,
                far=float(far) * options.range_margin,
                region=(x0 - margin_px, y0 - margin_px, x1 + margin_px, y1 + margin_px),
            )
    return windows


def _centred_projections(
    k_ref: np.ndarray, k_src: np.ndarray, r1: np.ndarray, r2: np.ndarray, image_size: tuple[int, int],
    canvas: tuple[int, int], vertical: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """Rectified 3x3 intrinsics at the reference's focal length, each view's centre ray at the
    canvas's centre. Along the epipolar lines the two principal points differ (the disparity
    is offset by that difference); across them they are shared, so that the lines stay
    rows (columns for a vertical pair)."""
    (w, h), (cw, ch) = image_size, canvas
    f = float(k_ref[0, 0])
    offsets = []
    for k, r in ((k_ref, r1), (k_src, r2)):
        ray = r @ np.linalg.inv(k) @ np.array([(w - 1) / 2, (h - 1) / 2, 1.0])
        offsets.append(((cw - 1) / 2 - f * ray[0] / ray[2], (ch - 1) / 2 - f * ray[1] / ray[2]))
    (cx1, cy1), (cx2, cy2) = offsets
    if vertical:
        cx1 = cx2 = (cx1 + cx2) / 2
    else:
        cy1 = cy2 = (cy1 + cy2) / 2
    return (np.array([[f, 0, cx1], [0, f, cy1], [0, 0, 1.0]]), np.array([[f, 0, cx2], [0, f, cy2], [0, 0, 1.0]]))


def _pair_depth(
    ref: np.ndarray,
    src: np.ndarray,
    camera_ref: Camera,
    camera_src: Camera,
    src_from_ref: np.ndarray,
    depth_range: tuple[float, float],
    options: DenseOptions,
    region: tuple[float, float, float, float] | None = None,
) -> np.ndarray:
    """Depth along the reference's pixel rays from one rectified pair (0 where unmatched), matched
    only within `region` (x0, y0, x1, y1: the reference's pixels, inclusive; None: all)."""
    import cv2

    h, w = ref.shape[:2]
    k_ref, k_src = camera_ref.matrix, camera_src.matrix
    size = (round(w * 1.2), round(h * 1.2))  # a larger canvas: converging views rotate out of frame
    r1, r2, p1, p2, _, _, _ = cv2.stereoRectify(
        k_ref, None, k_src, None, (w, h), src_from_ref[:3, :3], src_from_ref[:3, 3],
        flags=cv2.CALIB_ZERO_DISPARITY, alpha=1, newImageSize=size,
    )  # fmt: skip
    vertical = abs(p2[1, 3]) > abs(p2[0, 3])
    axis = 1 if vertical else 0
    offset = 0.0  # the disparity of points at infinity
    new_ref, new_src = p1[:3, :3], p2[:3, :3]
    if p1[0, 0] <= 0:
        # OpenCV's scaling to keep every pixel (alpha=1) breaks down for some strongly
        # converging pairs: a negative focal length, and nothing matched (9 of Kermit's 36
        # pairs). Such pairs keep the reference's focal length, each view centred.
        new_ref, new_src = _centred_projections(k_ref, k_src, r1, r2, (w, h), size, vertical)
        offset = new_ref[axis, 2] - new_src[axis, 2]
    baseline_px = p2[axis, 3] / p2[axis, axis] * new_ref[axis, axis]  # focal length times the signed baseline
    rect_from_ref = r1 @ np.linalg.inv(k_ref)
    block = options.block_size_px
    mirrored = baseline_px > 0
    shift = -offset if mirrored else offset  # what SGBM's disparities carry beyond |baseline| / depth
    near, far = depth_range
    d_min = int(np.floor(abs(baseline_px) / far + shift))
    d_max = int(np.ceil(abs(baseline_px) / near + shift))
    num = int(np.clip(np.ceil((d_max - d_min) / 16) * 16, 16, MAX_DISPARITIES))
    along, across = size[axis], size[1 - axis]
    if max(abs(d_min), abs(d_min + num)) >= along // 2:
        return np.zeros((h, w), np.float32)  # the views converge too much to match along rows
    # SGBM's time goes with the pixels it matches: only the window of the canvas the region of
    # interest (`region`, reference pixels) covers, and the source's strip the disparities reach.
    x0, y0, x1, y1 = (0, 0, w - 1, h - 1)
    if region is not None:
        x0, y0, x1, y1 = max(x0, region[0]), max(y0, region[1]), min(x1, region[2]), min(y1, region[3])
    corners = cv2.perspectiveTransform(
        np.array([[[x0, y0], [x1, y0], [x0, y1], [x1, y1]]], np.float64), new_ref @ rect_from_ref
    )[0]
    lo, hi = np.floor(corners.min(axis=0)).astype(int), np.ceil(corners.max(axis=0)).astype(int)
    a0, a1 = (lo[axis], hi[axis]) if not mirrored else (along - 1 - hi[axis], along - 1 - lo[axis])
    # The matched columns (after the mirroring): a source pixel lies d columns left of its match.
    a0, a1 = max(0, a0 - max(0, d_min + num)), min(along, a1 + 1 + max(0, -d_min))
    c0, c1 = max(0, lo[1 - axis]), min(across, hi[1 - axis] + 1)
    # SGBM matches the columns from max(d_max, 0) to width + min(d_min, 0) (OpenCV's width1): a
    # window no wider than the disparities reach has nothing to match (and SGBM fails on it).
    if a1 - a0 + min(d_min, 0) - max(d_min + num, 0) <= block or c1 - c0 <= block:
        return np.zeros((h, w), np.float32)
    window = (a0, a1) if not mirrored else (along - a1, along - a0)  # along the canvas's own axis
    # The canvas window as (x, y) ranges; the rectifying maps are made for it alone.
    (wx0, wx1), (wy0, wy1) = (window, (c0, c1)) if not vertical else ((c0, c1), window)
    window_size = (wx1 - wx0, wy1 - wy0)

    def rectified(image: np.ndarray, k: np.ndarray, r: np.ndarray, new_k: np.ndarray) -> np.ndarray:
        moved = new_k.copy()
        moved[0, 2] -= wx0
        moved[1, 2] -= wy0
        maps = cv2.initUndistortRectifyMap(k, None, r, moved, window_size, cv2.CV_32FC1)
        return cv2.remap(image, *maps, cv2.INTER_LINEAR)

    rect_ref, rect_src = rectified(ref, k_ref, r1, new_ref), rectified(src, k_src, r2, new_src)
    # SGBM matches left to right along rows: transpose a vertical pair, mirror a pair whose
    # source lies on the reference's left, so disparities come out positive.
    if vertical:
        rect_ref, rect_src = rect_ref.transpose(1, 0, 2).copy(), rect_src.transpose(1, 0, 2).copy()
    if mirrored:
        rect_ref, rect_src = rect_ref[:, ::-1].copy(), rect_src[:, ::-1].copy()
    sgbm = cv2.StereoSGBM_create(
        minDisparity=d_min, numDisparities=num, blockSize=block,
        P1=8 * 3 * block**2, P2=32 * 3 * block**2, disp12MaxDiff=1,
        uniquenessRatio=10, speckleWindowSize=100, speckleRange=2, mode=cv2.STEREO_SGBM_MODE_SGBM_3WAY,
    )  # fmt: skip
    matched = sgbm.compute(rect_ref, rect_src).astype(np.float32) / 16.0
    if mirrored:
        matched = matched[:, ::-1]
    if vertical:
        matched = matched.T
    disparity = np.full((size[1], size[0]), d_min - 1, np.float32)  # SGBM's own "no match"
    disparity[wy0:wy1, wx0:wx1] = matched
    # |baseline| / depth; 0 where SGBM found no match (its d_min - 1) or behind the cameras.
    disparity = np.where(disparity > max(d_min, shift), disparity - shift, 0)
    # The disparity is looked up where each reference pixel's ray meets the rectified image:
    # reference pixels map to rectified ones by the homography P1 R1 K^-1 (pinhole views).
    sampled = cv2.warpPerspective(disparity, new_ref @ rect_from_ref, (w, h),
                                  flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP, borderValue=0)  # fmt: skip
    valid = sampled > 0
    rect_depth = np.where(valid, abs(baseline_px) / np.where(valid, sampled, 1), 0)  # depth along rectified z
    # A point on the ray at rectified depth Z has reference depth Z * ray_z / rect_ray_z (ray_z = 1),
    # and rect_ray_z is linear in the pixel's coordinates.
    u, v = np.arange(w, dtype=np.float64)[None, :], np.arange(h, dtype=np.float64)[:, None]
    depth = rect_depth / (rect_from_ref[2, 0] * u + rect_from_ref[2, 1] * v + rect_from_ref[2, 2])
    depth[(depth < near) | (depth > far)] = 0
    return depth.astype(np.float32)


def _agreeing_depth(candidates: np.ndarray, options: DenseOptions) -> np.ndarray:
    """Per pixel, the mean of the pair depths (0: none) that agree with their median, where
    enough do. The few depths of each pixel are sorted by a network of element-wise minima and
    maxima, a tenth of np.sort's time (numpy's nanmedian took over a second a view)."""
    found = candidates > 0
    count = found.sum(axis=0)
    layers = list(np.where(found, candidates, np.inf))  # the found depths sort first
    for end in range(len(layers) - 1, 0, -1):
        for i in range(end):
            layers[i], layers[i + 1] = np.minimum(layers[i], layers[i + 1]), np.maximum(layers[i], layers[i + 1])
    ordered = np.array(layers)
    low = np.take_along_axis(ordered, np.maximum(count - 1, 0)[None] // 2, axis=0)[0]
    high = np.take_along_axis(ordered, np.minimum(count // 2, len(candidates) - 1)[None], axis=0)[0]
    median = np.where(count > 0, (low + high) / 2, 0)
    agree = found & (np.abs(candidates - median) <= options.depth_tolerance * median)
    agreeing = agree.sum(axis=0)
    mean = np.where(agree, candidates, 0).sum(axis=0) / np.maximum(agreeing, 1)
    return np.where(agreeing >= options.min_agreeing_pairs, mean, 0).astype(np.float32)


# A pair's depth is judged on at least this many sparse points it covers: confirmed when this
# share of them lies within `depth_tolerance`, refuted when under half do. Single good pairs of
# Buddha's every 2nd photo: 91-99 % within 1 %; wrong ones (1.02-1.7 times too deep): 0-24 %.
MIN_CHECK_POINTS = 10
CONFIRMED_SHARE = 0.75
REFUTED_SHARE = 0.5


def sparse_verdict(depth: np.ndarray, sparse_pixels: np.ndarray, sparse_depths: np.ndarray, options: DenseOptions) -> bool | None:
    """Whether one pair's depth map agrees with the sparse points' depths at their pixels (x, y
    rounded, in frame): True (confirmed), False (refuted) or None (too few of them covered)."""
    found = depth[sparse_pixels[:, 1], sparse_pixels[:, 0]]
    covered = found > 0
    if covered.sum() < MIN_CHECK_POINTS:
        return None
    share = float(np.mean(np.abs(found[covered] - sparse_depths[covered]) <= options.depth_tolerance * sparse_depths[covered]))
    return True if share >= CONFIRMED_SHARE else False if share < REFUTED_SHARE else None


def checked_depth(candidates: list[np.ndarray], verdicts: list[bool | None], options: DenseOptions) -> np.ndarray:
    """The view's depth from its pairs' depths: the pairs the sparse points refute left out; the
    agreeing depth of the rest, or the one confirmed pair's own when no more are confirmed."""
    confirmed = [d for d, verdict in zip(candidates, verdicts) if verdict]
    if len(confirmed) == 1 and options.min_agreeing_pairs > 1:
        return confirmed[0]
    kept = [d for d, verdict in zip(candidates, verdicts) if verdict is not False]
    return _agreeing_depth(np.array(kept), options) if kept else np.zeros(candidates[0].shape, np.float32)


def without_depth_edges(depth: np.ndarray, radius_px: int, options: DenseOptions) -> np.ndarray:
    """The depth map without the pixels within `radius_px` of a depth step (neighbours more than
    `depth_tolerance` apart, or a hole): block matching carries the nearer surface's disparity
    across its silhouette, points just beside the object's true outline."""
    import cv2

    kernel = np.ones((2 * radius_px + 1, 2 * radius_px + 1), np.uint8)
    nearest = cv2.erode(np.where(depth > 0, depth, np.inf).astype(np.float32), kernel)
    farthest = cv2.dilate(depth, kernel)
    step = farthest - nearest > options.depth_tolerance * farthest  # a hole's inf: no step
    return np.where(step, 0, depth).astype(np.float32)


@contextmanager
def _opencv_single_threaded() -> Iterator[None]:
    """OpenCV's own threads off while the caller runs one OpenCV call per core: SGBM's
    parallel loop leaves the numpy work between its calls to one core (7 pairs one after the
    other with OpenCV on two threads: 1.5 s; two at a time on one thread each: 1.3 s)."""
    import cv2

    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        yield
    finally:
        cv2.setNumThreads(threads)


def compute_depth_maps(
    model: SparseModel,
    options: DenseOptions | None = None,
    progress: Progress | None = None,
    *,
    side_px: int,
    workers: int = 1,
    roi: tuple[np.ndarray, float] | None = None,
) -> list[DepthMap]:
    """A filtered depth map for every registered view, its longer side at most `side_px`
    (`depth_image_side_px`), `workers` views at a time (OpenCV and numpy release the GIL),
    matched where the sparse points within `roi` (centre, radius) lie; progress stage "dense"."""
    options = options or DenseOptions()
    neighbours = choose_neighbours(model, options)
    windows = pair_windows(model, neighbours, options, roi=roi)
    sparse_seen = seen_matrix(model)

    def read(view: View) -> np.ndarray:
        return read_rgb(view.image_path, max_side_px=side_px)

    def depth_map(i: int) -> DepthMap:
        view = model.views[i]
        camera_ref = view.camera.scaled(factors[i])
        _, pixels, point_depths = in_frame_pixels(
            model.points_world[sparse_seen[:, i]], view.camera_from_world, camera_ref, images[i].shape
        )
        candidates = []
        for j in neighbours[i]:
            src_from_ref = model.views[j].camera_from_world @ np.linalg.inv(view.camera_from_world)
            window = windows[i, j]
            candidates.append(
                _pair_depth(images[i], images[j], camera_ref, model.views[j].camera.scaled(factors[j]), src_from_ref,
                            (window.near, window.far), options, region=tuple(factors[i] * np.array(window.region)))
            )  # fmt: skip
        verdicts = [sparse_verdict(candidate, pixels, point_depths, options) for candidate in candidates]
        depth = checked_depth(candidates, verdicts, options) if candidates else np.zeros(images[i].shape[:2], np.float32)
        if options.edge_radius_px:
            depth = without_depth_edges(depth, options.edge_radius_px, options)
        return DepthMap(view_index=i, depth=depth, colour=images[i], camera=camera_ref)

    maps = []
    with _opencv_single_threaded(), ThreadPoolExecutor(max_workers=workers) as pool:
        images = list(pool.map(read, model.views))
        factors = [image.shape[1] / view.camera.width for image, view in zip(images, model.views)]
        for depth_map_done in pool.map(depth_map, range(len(model.views))):
            maps.append(depth_map_done)
            if progress:
                progress("dense", len(maps), len(model.views))
    return maps


def depth_maps_to_points(model: SparseModel, maps: list[DepthMap], step_px: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World points, their colours (0..1) and the unit direction from each point to its camera,
    from every `step_px`-th pixel of each depth map along rows and columns."""
    all_points, all_colours, all_dirs = [], [], []
    for depth_map in maps:
        view: View = model.views[depth_map.view_index]
        sampled = np.zeros(depth_map.depth.shape, bool)
        sampled[::step_px, ::step_px] = True
        valid = sampled & (depth_map.depth > 0)
        camera_points = depth_map.camera.depth_to_points(depth_map.depth, mask=valid)
        world_from_camera = np.linalg.inv(view.camera_from_world)
        points = camera_points @ world_from_camera[:3, :3].T + world_from_camera[:3, 3]
        to_camera = view.centre_world - points
        all_points.append(points)
        all_colours.append(depth_map.colour[valid] / 255.0)
        all_dirs.append(to_camera / np.linalg.norm(to_camera, axis=1, keepdims=True))
    return np.vstack(all_points), np.vstack(all_colours), np.vstack(all_dirs)
