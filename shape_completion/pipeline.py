"""The completion pipeline of Rock et al. (CVPR 2015): Matching, Fitting, Filling.

`ShapeCompleter.fit(library)` renders every library mesh from `n_views` viewpoints on a
sphere, learns the retrieval forest on the views' pixel tests and shape codes, and trains
the boosted filler on completions of the library's own meshes (each with its own views
left out of retrieval, so the filler sees the errors a novel object brings).
`ShapeCompleter.complete(depth_m, camera)` turns one object-only depth image into a mesh in
the camera's frame (OpenCV: x right, y down, z forward), keeping every stage's result.
"""

from __future__ import annotations

import hashlib
import json
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import trimesh
from scipy import ndimage
from scipy.spatial import cKDTree
from sklearn.base import BaseEstimator

from homemodel.core.errors import InputError, ModelError
from homemodel.evaluation.surface import distances_to_surface
from homemodel.evaluation.voxels import VoxelGrid, iou_of_occupancies, solid_occupancy
from homemodel.geometry.camera import Camera
from homemodel.geometry.raycast import RayCaster
from shape_completion.deformation import symmetric_controls, tps_deform
from shape_completion.features import PixelTests, clean_object_depth, view_features
from shape_completion.filling import CarvedGrid, TrainingGrid, VoxelFiller, carve
from shape_completion.library import Library, working_mesh
from shape_completion.matching import ViewForest
from shape_completion.registration import apply, camera_facing_normals, trimmed_icp
from shape_completion.render import camera_from_object_on_sphere, sphere_directions
from shape_completion.shape_codes import ObjectOccupancy, ShapeBasis
from shape_completion.spin_images import spin_image_alignment
from shape_completion.symmetry import (
    Plane,
    RevolutionAxis,
    revolution_axis,
    symmetry_planes,
)

logger = logging.getLogger(__name__)

Progress = Callable[[str, int, int], None]

# Training views: a small square image; the object's bounding sphere fills ~80% of it.
VIEW_IMAGE_PX = 96
VIEW_CAMERA = Camera(
    width=VIEW_IMAGE_PX,
    height=VIEW_IMAGE_PX,
    fx=100.0,
    fy=100.0,
    cx=(VIEW_IMAGE_PX - 1) / 2,
    cy=(VIEW_IMAGE_PX - 1) / 2,
)
# The queries the filler trains on: a VGA-like depth camera at half resolution.
FILLER_CAMERA = Camera(width=320, height=240, fx=285.0, fy=285.0, cx=159.5, cy=119.5)
MIN_QUERY_PIXELS = 30
CLOUD_POINTS = 400
MODEL_SAMPLES = 2500
FILLER_SAMPLES_PER_QUERY = 6000
MAX_DEFORMATION_STRETCH = 1.5
LEVEL_CHECK_QUERIES = 10  # training completions the final level is chosen on
LEVEL_STEPS = (0.0, 0.05, 0.1, 0.15)
AXIS_FIT_POINTS = 4000
AXIS_FIT_TOLERANCE_M = 0.003
QUERY_QUARTER_TURNS = (0, 1, 2, 3)


@dataclass(kw_only=True)
class LibraryShape:
    """What the pipeline keeps of one library mesh."""

    class_name: str
    name: str
    mesh: trimesh.Trimesh
    samples: np.ndarray  # surface samples (object frame), for registration
    normals: np.ndarray
    planes: list[Plane]
    axis: RevolutionAxis | None


@dataclass(kw_only=True)
class Fit:
    """Matching and fitting of one query, in the query camera's frame."""

    query: np.ndarray
    shape_index: int
    view_index: int
    match_distance_m: float
    retrieved: trimesh.Trimesh  # the library mesh placed at its view's pose: retrieval only
    camera_from_object: np.ndarray  # after spin images and ICP
    deformed: trimesh.Trimesh  # after the symmetric TPS
    fit_distance_m: float
    planes_camera: list[Plane]
    # For a revolved retrieved mesh: its axis, moved onto the query (an addition to Rock et
    # al.). Filling only: moving the deformation's controls through the plane it gives made
    # the fits worse in our tests.
    axis: RevolutionAxis | None
    seconds: dict[str, float] = field(default_factory=dict)


@dataclass(kw_only=True)
class Completion:
    """Every stage of one completion, in the query camera's frame."""

    fit: Fit
    mesh: trimesh.Trimesh
    class_name: str
    retrieved_name: str
    seconds: dict[str, float]

    @property
    def retrieved(self) -> trimesh.Trimesh:
        return self.fit.retrieved

    @property
    def deformed(self) -> trimesh.Trimesh:
        return self.fit.deformed


def view_distance_m(radius_m: float) -> float:
    """Camera distance at which a bounding sphere of `radius_m` spans ~80% of a training view."""
    return radius_m / np.tan(np.arctan(0.5 * VIEW_IMAGE_PX / VIEW_CAMERA.fx) * 0.8)


def check_query(depth_m: np.ndarray, camera: Camera, mask: np.ndarray | None) -> np.ndarray:
    """The object-only depth (NaN elsewhere) of a query, or an InputError saying what is wrong."""
    depth = np.asarray(depth_m, dtype=np.float32)
    if depth.shape != (camera.height, camera.width):
        raise InputError(
            f"depth image is {depth.shape[1]}x{depth.shape[0]} px but the camera is {camera.width}x{camera.height} px"
        )
    depth = np.where(np.isfinite(depth) & (depth > 0), depth, np.nan).astype(np.float32)
    if mask is not None:
        if mask.shape != depth.shape:
            raise InputError(
                f"mask is {mask.shape[1]}x{mask.shape[0]} px but the depth image is {camera.width}x{camera.height}"
            )
        depth[~mask.astype(bool)] = np.nan
    count = int(np.isfinite(depth).sum())
    if count == 0:
        raise InputError("depth image has no valid depth on the object (empty, all zero or all NaN)")
    if count < MIN_QUERY_PIXELS:
        raise InputError(f"depth image has only {count} valid pixels on the object (need {MIN_QUERY_PIXELS})")
    depth = clean_object_depth(depth)
    rows, cols = np.nonzero(np.isfinite(depth))
    median = float(np.nanmedian(depth))
    across = max(cols.ptp() / camera.fx, rows.ptp() / camera.fy) * median
    if not (0.005 <= across <= 2.0) or median > 20.0:
        raise InputError(
            f"the object would be {across:.3g} m across at {median:.3g} m: the depth image does not match the camera"
            " (check depth_scale_m and the focal lengths)"
        )
    return depth


class ShapeCompleter(BaseEstimator):
    """Rock et al.'s Matching, Fitting and Filling, trained on a class library (scikit-learn contract)."""

    def __init__(
        self,
        *,
        n_views: int = 40,
        n_silhouette_tests: int = 300,
        n_depth_tests: int = 700,
        n_shape_features: int = 12,
        n_trees: int = 40,
        n_candidates: int = 8,
        tps_smoothing: float = 0.05,
        fill_resolution: int = 96,
        filler_queries_per_class: int = 20,
        random_state: int = 0,
    ) -> None:
        self.n_views = n_views
        self.n_silhouette_tests = n_silhouette_tests
        self.n_depth_tests = n_depth_tests
        self.n_shape_features = n_shape_features
        self.n_trees = n_trees
        self.n_candidates = n_candidates
        self.tps_smoothing = tps_smoothing
        self.fill_resolution = fill_resolution
        self.filler_queries_per_class = filler_queries_per_class
        self.random_state = random_state

    # ---- training -------------------------------------------------------------------------

    def fit(self, library: Library, progress: Progress | None = None) -> ShapeCompleter:
        """Learn retrieval and filling from `library`; `progress(stage, done, total)` reports."""
        report = progress or (lambda stage, done, total: None)
        if self.n_views < 4:
            raise InputError(f"n_views={self.n_views}: at least 4 views per mesh")
        if self.filler_queries_per_class < 1:
            raise InputError(f"filler_queries_per_class={self.filler_queries_per_class}: at least 1")
        started = time.perf_counter()
        self.tests_ = PixelTests.draw(
            n_silhouette=self.n_silhouette_tests, n_depth=self.n_depth_tests, seed=self.random_state
        )
        self.shapes_, features, occupancies = [], [], []
        view_shape, view_poses, view_clouds = [], [], []
        directions = sphere_directions(self.n_views)
        rng = np.random.default_rng(self.random_state)
        for index, entry in enumerate(library.meshes):
            report("rendering views", index, len(library.meshes))
            mesh = working_mesh(entry.mesh)
            samples, faces = trimesh.sample.sample_surface(mesh, MODEL_SAMPLES, seed=self.random_state + index)
            self.shapes_.append(
                LibraryShape(
                    class_name=entry.class_name,
                    name=entry.name,
                    mesh=mesh,
                    samples=np.asarray(samples),
                    normals=np.asarray(mesh.face_normals[faces]),
                    planes=symmetry_planes(mesh, seed=self.random_state),
                    axis=revolution_axis(mesh, seed=self.random_state),
                )
            )
            occupancy = ObjectOccupancy(mesh)
            caster = RayCaster(mesh)
            distance = view_distance_m(occupancy.radius_m)
            for direction in directions:
                camera_from_object = camera_from_object_on_sphere(occupancy.centre_m, direction, distance)
                depth = caster.depth(VIEW_CAMERA, camera_from_object)
                if np.isfinite(depth).sum() < MIN_QUERY_PIXELS:
                    continue  # a spoon seen edge-on can vanish at this resolution
                cloud = _subsample(VIEW_CAMERA.depth_to_points(depth), CLOUD_POINTS, rng)
                features.append(view_features(depth, VIEW_CAMERA, self.tests_))
                occupancies.append(occupancy.in_view(camera_from_object))
                view_shape.append(index)
                view_poses.append(camera_from_object)
                view_clouds.append(cloud)
        report("rendering views", len(library.meshes), len(library.meshes))
        self.view_shape_ = np.asarray(view_shape)
        self.view_poses_ = np.asarray(view_poses)
        self.view_clouds_ = view_clouds
        report("shape codes (NMF)", 0, 1)
        basis = ShapeBasis(n_components=self.n_shape_features, random_state=self.random_state)
        occupancy_matrix = np.asarray(occupancies, dtype=np.float64)
        codes = basis.fit(occupancy_matrix).codes(occupancy_matrix)
        self.shape_basis_ = basis
        report("retrieval forest", 0, 1)
        self.forest_ = ViewForest(n_estimators=self.n_trees, random_state=self.random_state).fit(
            np.asarray(features), codes
        )
        self.fingerprint_ = training_fingerprint(library.fingerprint, self.get_params())
        self.library_fingerprint_ = library.fingerprint
        self.class_names_ = library.class_names
        self.filler_ = self._fit_filler(library, report)
        self.training_seconds_ = time.perf_counter() - started
        return self

    def _fit_filler(self, library: Library, report: Progress) -> VoxelFiller:
        """Complete renders of library meshes with their own views excluded; learn the voxels' truth."""
        rng = np.random.default_rng(self.random_state + 1)
        jobs = []
        for class_name in library.class_names:
            members = [i for i, s in enumerate(self.shapes_) if s.class_name == class_name]
            for q in range(self.filler_queries_per_class):
                jobs.append(members[q % len(members)])
        grids, held = [], []
        hold_every = max(1, len(jobs) // LEVEL_CHECK_QUERIES)
        for done, shape_index in enumerate(jobs):
            report("filler training", done, len(jobs))
            shape = self.shapes_[shape_index]
            camera_from_object = random_query_pose(shape.mesh, rng)
            depth = render_query(shape.mesh, FILLER_CAMERA, camera_from_object)
            if np.isfinite(depth).sum() < MIN_QUERY_PIXELS:
                continue
            fit = self._match_and_fit(depth, FILLER_CAMERA, exclude=self.view_shape_ == shape_index, rng=rng)
            carved = self._carve(depth, FILLER_CAMERA, fit)
            truth_mesh = shape.mesh.copy().apply_transform(camera_from_object)
            truth = solid_occupancy(truth_mesh, carved.grid)
            grids.append(TrainingGrid.sampled(carved, truth, FILLER_SAMPLES_PER_QUERY, rng))
            if done % hold_every == 0:
                held.append((carved, truth_mesh))
        report("filler training", len(jobs), len(jobs))
        if not grids:
            raise ModelError("no filler training query could be rendered from the library")
        filler = VoxelFiller(random_state=self.random_state).fit_grids(grids)
        report("filler level", 0, 1)
        filler.level_ = _best_mesh_level(filler, held)
        return filler

    # ---- completion -----------------------------------------------------------------------

    def complete(self, depth_m: np.ndarray, camera: Camera, mask: np.ndarray | None = None) -> Completion:
        """A mesh of the whole object seen in `depth_m` (metres, NaN or 0 = no measurement)."""
        started = time.perf_counter()
        depth = check_query(depth_m, camera, mask)
        fit = self._match_and_fit(depth, camera, exclude=None, rng=np.random.default_rng(self.random_state))
        t0 = time.perf_counter()
        carved = self._carve(depth, camera, fit)
        level = self.filler_.level_
        field = carved.occupancy_field(self.filler_.occupancy_probability(carved.features), level)
        mesh = mesh_from_field(field, carved.grid, level=level)
        seconds = dict(fit.seconds, filling=time.perf_counter() - t0, total=time.perf_counter() - started)
        shape = self.shapes_[fit.shape_index]
        return Completion(fit=fit, mesh=mesh, class_name=shape.class_name, retrieved_name=shape.name, seconds=seconds)

    def _carve(self, depth: np.ndarray, camera: Camera, fit: Fit) -> CarvedGrid:
        return carve(
            depth_m=depth,
            camera=camera,
            deformed=fit.deformed,
            planes_camera=fit.planes_camera,
            axis_camera=fit.axis,
            match_distance_m=fit.match_distance_m,
            fit_distance_m=fit.fit_distance_m,
            class_index=self.class_names_.index(self.shapes_[fit.shape_index].class_name),
            resolution=self.fill_resolution,
        )

    def _match_and_fit(
        self, depth: np.ndarray, camera: Camera, *, exclude: np.ndarray | None, rng: np.random.Generator
    ) -> Fit:
        seconds = {}
        t0 = time.perf_counter()
        query = _subsample(camera.depth_to_points(depth), 1500, rng)
        candidates = self._candidate_views(depth, camera, exclude)
        if len(candidates) == 0:
            raise ModelError("the retrieval forest found no candidate view")
        query_tree = cKDTree(query)
        scored = [
            (aligned_chamfer(self.view_clouds_[view], query, query_tree, quarter_turns=turns), view)
            for view, turns in candidates
        ]
        (match_distance, alignment), view_index = min(scored, key=lambda item: item[0][0])
        shape_index = int(self.view_shape_[view_index])
        shape = self.shapes_[shape_index]
        initial = alignment @ self.view_poses_[view_index]
        retrieved = shape.mesh.copy().apply_transform(initial)
        seconds["matching"] = time.perf_counter() - t0

        t0 = time.perf_counter()
        size = float(np.linalg.norm(shape.mesh.extents))
        camera_from_object = self._rigid_fit(query, shape, initial, size, rng)
        planes = [plane.transformed(camera_from_object) for plane in shape.planes]
        axis = None if shape.axis is None else self._fitted_axis(depth, camera, shape.axis, camera_from_object, rng)
        seconds["rigid_fit"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        deformed = self._deform(query, shape, camera_from_object, planes, size, rng)
        fit_distance = float(distances_to_surface(query, deformed).mean())
        seconds["deformation"] = time.perf_counter() - t0
        return Fit(
            query=query,
            shape_index=shape_index,
            view_index=int(view_index),
            match_distance_m=match_distance,
            retrieved=retrieved,
            camera_from_object=camera_from_object,
            deformed=deformed,
            fit_distance_m=fit_distance,
            planes_camera=planes,
            axis=axis,
            seconds=seconds,
        )

    def _candidate_views(
        self, depth: np.ndarray, camera: Camera, exclude: np.ndarray | None
    ) -> list[tuple[int, int]]:
        """(view, quarter turns) pairs: the forest's candidates for the query image turned by each
        of QUERY_QUARTER_TURNS. Training views all have the object's +z up in the image; an
        object lying down (a spoon on a table) seen from above can point any way in the query,
        so the turned images find views the upright one misses (an addition to Rock et al.)."""
        pairs = []
        for turns in QUERY_QUARTER_TURNS:
            features = view_features(np.rot90(depth, turns), _quarter_turned(camera, turns), self.tests_)
            pairs += [(int(view), turns) for view in self.forest_.candidates(features, self.n_candidates, exclude)]
        return pairs

    @staticmethod
    def _fitted_axis(
        depth: np.ndarray,
        camera: Camera,
        axis: RevolutionAxis,
        camera_from_object: np.ndarray,
        rng: np.random.Generator,
    ) -> RevolutionAxis:
        """The revolved retrieved mesh's axis at its fitted pose, moved onto the query."""
        points = _subsample(camera.depth_to_points(depth), AXIS_FIT_POINTS, rng)
        return axis.transformed(camera_from_object).fitted_to(
            points, camera_facing_normals(points, neighbours=24), tolerance_m=AXIS_FIT_TOLERANCE_M
        )

    def _rigid_fit(
        self, query: np.ndarray, shape: LibraryShape, initial: np.ndarray, size: float, rng: np.random.Generator
    ) -> np.ndarray:
        """Spin-image RANSAC from the view's pose, then ICP; the better of that and ICP from the view's pose."""
        query_normals = camera_facing_normals(query)
        model = apply(initial, shape.samples)
        model_normals = shape.normals @ initial[:3, :3].T
        correction, inliers = spin_image_alignment(
            query, query_normals, model, model_normals, radius_m=0.25 * size, n_keypoints=120, rng=rng
        )
        starts = [initial]
        if inliers >= 6:
            starts.append(correction @ initial)
        refined = [
            trimmed_icp(query, shape.samples, shape.normals, start, max_distance_m=0.2 * size) for start in starts
        ]
        pose, _ = min(refined, key=lambda item: item[1])
        return pose

    def _deform(
        self,
        query: np.ndarray,
        shape: LibraryShape,
        camera_from_object: np.ndarray,
        planes: list[Plane],
        size: float,
        rng: np.random.Generator,
    ) -> trimesh.Trimesh:
        """The symmetric approximating TPS that pulls the mesh's camera-facing surface onto the query."""
        points = apply(camera_from_object, shape.samples)
        normals = shape.normals @ camera_from_object[:3, :3].T
        facing = np.einsum("ni,ni->n", normals, -points) > 0
        if facing.sum() < 10:
            facing[:] = True
        controls = _subsample(query, 250, rng)
        distances, nearest = cKDTree(points[facing]).query(controls)
        keep = distances < 0.15 * size
        model_points = points[facing][nearest[keep]]
        control_points, displacements = symmetric_controls(model_points, controls[keep] - model_points, planes)
        vertices = apply(camera_from_object, np.asarray(shape.mesh.vertices))
        moved = tps_deform(vertices, control_points, displacements, scale_m=size, smoothing=self.tps_smoothing)
        if not deformation_is_trusted(vertices, moved, camera_from_object[:3, :3]):
            moved = vertices
        return trimesh.Trimesh(moved, shape.mesh.faces, process=False)


def deformation_is_trusted(placed: np.ndarray, moved: np.ndarray, camera_from_object_rotation: np.ndarray) -> bool:
    """Whether a deformation of the `placed` vertices to `moved` keeps the mesh's box, along the
    object's own axes, within MAX_DEFORMATION_STRETCH of its size. Few or one-sided controls can
    make the spline run away (seen: a spoon blown up to 40 times its volume); the rigid fit
    then stands."""
    stretch = np.ptp(moved @ camera_from_object_rotation, axis=0) / np.maximum(
        np.ptp(placed @ camera_from_object_rotation, axis=0), 1e-9
    )
    return bool(np.all(stretch <= MAX_DEFORMATION_STRETCH) and np.all(stretch >= 1 / MAX_DEFORMATION_STRETCH))


def training_fingerprint(library_fingerprint: str, params: dict) -> str:
    """A hash of the library's files and the training options."""
    text = library_fingerprint + json.dumps(params, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def random_query_pose(mesh: trimesh.Trimesh, rng: np.random.Generator) -> np.ndarray:
    """A camera 0.35-0.7 m from the object on a random direction of the upper 3/4 of the sphere,
    the object a little off the optical axis: how a robot's head camera sees a table top."""
    direction = rng.normal(size=3)
    direction[2] = abs(direction[2]) if rng.uniform() < 0.75 else direction[2]
    direction /= np.linalg.norm(direction)
    centre = mesh.bounds.mean(axis=0)
    camera_from_object = camera_from_object_on_sphere(centre, direction, rng.uniform(0.35, 0.7))
    camera_from_object[:3, 3] += np.append(rng.uniform(-0.05, 0.05, size=2), 0.0)
    return camera_from_object


def render_query(mesh: trimesh.Trimesh, camera: Camera, camera_from_object: np.ndarray) -> np.ndarray:
    return RayCaster(mesh).depth(camera, camera_from_object)


def mesh_from_field(field: np.ndarray, grid: VoxelGrid, *, level: float = 0.5) -> trimesh.Trimesh:
    """The `level` set of a lightly smoothed occupancy field (marching cubes), in the grid's frame."""
    from skimage.measure import marching_cubes

    padded = np.pad(ndimage.gaussian_filter(field, sigma=0.6), 1)
    if padded.max() < level:
        raise ModelError("the completed shape is empty: no voxel is occupied")
    vertices, faces, _, _ = marching_cubes(padded, level=level, spacing=(grid.voxel_size_m,) * 3)
    vertices += grid.origin_m - 0.5 * grid.voxel_size_m  # padded index i is voxel i - 1, centred at +0.5
    mesh = trimesh.Trimesh(vertices, faces[:, ::-1], process=True)
    if mesh.volume < 0:
        mesh.invert()
    return mesh


def _best_mesh_level(filler: VoxelFiller, held: list[tuple[CarvedGrid, trimesh.Trimesh]]) -> float:
    """The filler's level raised by the step that gives the best mean IoU of the finished meshes
    of `held` training completions, voxelised at twice the carving's resolution (about Rock et
    al.'s 200^3 over the object). The filler's own level is the best for voxel decisions;
    smoothing and marching cubes then shift the surface, and on the generated classes the
    finished meshes were best 0.05-0.15 higher."""
    scores = np.zeros(len(LEVEL_STEPS))
    for carved, truth_mesh in held:
        grid = carved.grid
        fine = VoxelGrid(
            origin_m=grid.origin_m, voxel_size_m=grid.voxel_size_m / 2, shape=tuple(2 * n for n in grid.shape)
        )
        truth = solid_occupancy(truth_mesh, fine)
        probability = filler.occupancy_probability(carved.features)
        for i, step in enumerate(LEVEL_STEPS):
            level = filler.level_ + step
            mesh = mesh_from_field(carved.occupancy_field(probability, level), grid, level=level)
            scores[i] += iou_of_occupancies(solid_occupancy(mesh, fine), truth)
    return filler.level_ + LEVEL_STEPS[int(np.argmax(scores))]


def _subsample(points: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    if len(points) <= count:
        return points
    return points[rng.choice(len(points), size=count, replace=False)]


def _quarter_turned(camera: Camera, turns: int) -> Camera:
    """The intrinsics of np.rot90(image, turns): each turn puts old row r, column c at row
    width - 1 - c, column r."""
    for _ in range(turns % 4):
        camera = Camera(
            width=camera.height,
            height=camera.width,
            fx=camera.fy,
            fy=camera.fx,
            cx=camera.cy,
            cy=camera.width - 1 - camera.cx,
        )
    return camera


def aligned_chamfer(
    view_cloud: np.ndarray, query: np.ndarray, query_tree: cKDTree, *, quarter_turns: int = 0
) -> tuple[float, np.ndarray]:
    """Mean two-way nearest-point distance after moving the view's cloud onto the query: rolled
    about the view camera's optical axis to undo a `quarter_turns` np.rot90 of the query image,
    turned so its centroid lies on the query centroid's ray, then shifted to the query's
    centroid. Returns the distance and that motion (4x4, query camera from view camera)."""
    roll = np.eye(4)
    # np.rot90 maps a point's image coordinates (x, y) to (y, -x): undo it with +90 degrees about z.
    roll[:3, :3] = np.linalg.matrix_power(np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]), quarter_turns)
    rolled = apply(roll, view_cloud)
    view_centre, query_centre = rolled.mean(axis=0), query.mean(axis=0)
    a, b = view_centre / np.linalg.norm(view_centre), query_centre / np.linalg.norm(query_centre)
    rotation = _rotation_between(a, b)
    motion = np.eye(4)
    motion[:3, :3] = rotation
    motion[:3, 3] = query_centre - rotation @ view_centre
    moved = apply(motion, rolled)
    distance = 0.5 * (query_tree.query(moved)[0].mean() + cKDTree(moved).query(query)[0].mean())
    return float(distance), motion @ roll


def _rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation taking unit vector a to unit vector b (Rodrigues)."""
    axis = np.cross(a, b)
    sin, cos = np.linalg.norm(axis), float(a @ b)
    if sin < 1e-12:
        return np.eye(3)
    k = axis / sin
    skew = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + sin * skew + (1 - cos) * skew @ skew
