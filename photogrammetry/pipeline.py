"""Photos to a textured, metric, cleaned mesh: every stage of D3.1 section 3.3.3, offline.

`reconstruct` runs structure from motion (pycolmap), dense depth (CPU semi-global matching,
or PatchMatch where pycolmap has CUDA), fusion, markers for scale and levelling, cleaning,
Poisson meshing and texture baking; `write_reconstruction` exports the result as a model
folder through the articulated model type.
"""

from __future__ import annotations

import json
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh

from homemodel.core.errors import InputError, ModelError
from homemodel.geometry.mesh_ops import watertight_finish
from photogrammetry.cleaning import (
    CleaningOptions,
    downsample,
    mesh_object,
    segment_object,
)
from photogrammetry.markers import DICTIONARIES, detect_markers, triangulate_markers
from photogrammetry.metric_frame import ModelFrame, metric_frame
from photogrammetry.photos import list_photos
from photogrammetry.sfm import SfmOptions, SparseModel, View, run_sfm
from photogrammetry.stereo import DenseOptions, compute_depth_maps, depth_maps_to_points
from photogrammetry.support_plane import find_support_plane, focus_point
from photogrammetry.texturing import TexturedMesh, TextureBakingOptions, bake_texture
from photogrammetry.visibility import keep_surface_points

# progress(stage, done, total): total is None while a stage cannot say how far it is.
Progress = Callable[[str, int, int | None], None]


@dataclass(kw_only=True)
class ReconstructOptions:
    sfm: SfmOptions = field(default_factory=SfmOptions)
    dense: DenseOptions = field(default_factory=DenseOptions)
    cleaning: CleaningOptions = field(default_factory=CleaningOptions)
    texture: TextureBakingOptions = field(default_factory=TextureBakingOptions)
    marker_size_m: float | None = None  # the printed markers' black-square edge; None: no markers
    dictionary: str = "apriltag_36h11"
    max_faces: int = 40_000  # the mesh is decimated to this before texturing
    use_cuda: bool = True  # PatchMatch where pycolmap has CUDA; the CPU path otherwise

    def __post_init__(self) -> None:
        if self.marker_size_m is not None and not (np.isfinite(self.marker_size_m) and self.marker_size_m > 0):
            raise InputError(f"marker size must be a positive length in metres, got {self.marker_size_m}")
        if self.dictionary not in DICTIONARIES:
            raise InputError(f"unknown marker dictionary {self.dictionary!r}; choose one of {', '.join(DICTIONARIES)}")
        if self.max_faces < 100:
            raise InputError(f"max faces must be at least 100, got {self.max_faces}")


@dataclass(kw_only=True)
class Reconstruction:
    """A finished reconstruction in the model frame (metres when `frame.scaled`)."""

    textured: TexturedMesh
    views: list[View]  # poses in the model frame
    frame: ModelFrame
    summary: dict
    work_dir: Path  # holds the texture image until the export copies it

    @property
    def mesh(self) -> trimesh.Trimesh:
        return self.textured.mesh


class _Clock:
    """Times per stage and the progress callback, in one place."""

    def __init__(self, progress: Progress | None) -> None:
        self.progress = progress
        self.times_s: dict[str, float] = {}
        self._stage = ""
        self._start = 0.0

    def start(self, stage: str) -> None:
        self.stop()
        self._stage, self._start = stage, time.perf_counter()
        self.tick(0, None)

    def tick(self, done: int, total: int | None) -> None:
        if self.progress:
            self.progress(self._stage, done, total)

    def stop(self) -> None:
        if self._stage:
            self.times_s[self._stage] = self.times_s.get(self._stage, 0.0) + time.perf_counter() - self._start
            self._stage = ""


def _dense_points(sparse: SparseModel, undistorted: Path, options: ReconstructOptions, clock: _Clock):
    from photogrammetry.patch_match import cuda_available, patch_match_points

    if options.use_cuda and cuda_available():
        # COLMAP's fusion checks visibility itself: no depth maps are handed on.
        return (*patch_match_points(undistorted, options.dense.max_image_size_px), [], "patch-match (CUDA)")
    maps = compute_depth_maps(sparse, options.dense, progress=clock.tick)
    points, colours, to_camera = depth_maps_to_points(sparse, maps)
    return points, colours, to_camera, maps, "semi-global matching (CPU)"


def _markers(sparse: SparseModel, options: ReconstructOptions, clock: _Clock):
    """Markers seen in the undistorted views, triangulated in the SfM frame."""
    import cv2

    sightings = []
    for index, view in enumerate(sparse.views):
        gray = cv2.imread(str(view.image_path), cv2.IMREAD_GRAYSCALE)
        sightings += detect_markers(gray, view.name, options.dictionary)
        clock.tick(index + 1, len(sparse.views))
    projections = {v.name: v.intrinsics @ v.camera_from_world[:3, :] for v in sparse.views}
    return triangulate_markers(sightings, projections)


def reconstruct(photos_dir: Path, options: ReconstructOptions | None = None, progress: Progress | None = None,
                *, work_dir: Path) -> Reconstruction:  # fmt: skip
    """Run every stage on the photos in `photos_dir`, with intermediate files in `work_dir`."""
    options = options or ReconstructOptions()
    clock = _Clock(progress)
    photos = list_photos(Path(photos_dir))

    def sfm_progress(stage: str) -> None:
        clock.start(stage)

    sparse = run_sfm(photos, work_dir, options.sfm, progress=sfm_progress)
    clock.stop()
    clock.start("dense")
    points, colours, to_camera, depth_maps, dense_method = _dense_points(
        sparse, work_dir / "undistorted", options, clock
    )
    if len(points) < 1000:
        raise ModelError(f"{photos_dir}: dense matching found only {len(points)} points: too little texture or overlap")

    clock.start("markers")
    centres = np.array([v.centre_world for v in sparse.views])
    focus = focus_point(centres, np.array([v.optical_axis_world for v in sparse.views]))
    scene_scale = float(np.median(np.linalg.norm(centres - focus, axis=1)))
    voxel = options.cleaning.voxel_fraction * scene_scale
    points, colours, to_camera = downsample(points, colours, to_camera, voxel)
    # The object lies where the cameras look, well inside the ring of cameras: far-off walls
    # and furniture are cut away before any plane or piece is looked for.
    near_focus = np.linalg.norm(points - focus, axis=1) <= options.cleaning.roi_fraction * scene_scale
    points, colours, to_camera = points[near_focus], colours[near_focus], to_camera[near_focus]
    camera_up = -np.mean([v.camera_from_world[1, :3] for v in sparse.views], axis=0)
    plane = find_support_plane(
        points,
        centres,
        camera_up,
        seed=options.sfm.seed,
        threshold=options.cleaning.plane_clearance_fraction * scene_scale / 2,
    )
    markers = _markers(sparse, options, clock) if options.marker_size_m is not None else []
    if options.marker_size_m is not None and not markers:
        raise ModelError(
            f"{photos_dir}: no {options.dictionary} marker was found in two or more registered photos "
            "(check --dictionary, or leave out --marker-size-m for an unscaled model)"
        )
    frame = metric_frame(
        plane=plane,
        markers=markers,
        marker_size_m=options.marker_size_m,
        object_centre_sfm=focus,
        x_hint_sfm=sparse.views[0].camera_from_world[0, :3],
    )

    clock.start("cleaning")
    model_points = frame.apply(points)
    model_scale = scene_scale * frame.scale
    if plane is None and not markers:
        # Nothing to stand on: the frame is lowered so that no point counts as a support plane
        # (the cameras move with it, so the texture still lines up).
        clearance = options.cleaning.plane_clearance_fraction * model_scale
        frame.model_from_sfm[2, 3] -= model_points[:, 2].min() - 2 * clearance
        model_points = frame.apply(points)
    model_focus = frame.apply(focus[None])[0]
    # Points near or above the support plane that views see through are smeared depth: drop them.
    candidates = np.nonzero(model_points[:, 2] > options.cleaning.plane_clearance_fraction * model_scale)[0]
    in_free_space = ~keep_surface_points(points[candidates], depth_maps, sparse.views) if depth_maps else []
    keep = np.ones(len(points), bool)
    keep[candidates[in_free_space]] = False
    obj = segment_object(model_points[keep], colours[keep], to_camera[keep] @ frame.model_from_sfm[:3, :3].T / frame.scale,
                         model_focus, model_scale, options.cleaning)  # fmt: skip

    clock.start("meshing")
    mesh = watertight_finish(mesh_object(obj, model_scale, options.cleaning), options.max_faces)

    clock.start("texturing")
    views = [frame.view(v) for v in sparse.views]
    textured = bake_texture(mesh, views, options.texture, progress=clock.tick)
    clock.stop()

    summary = {
        "photos": len(photos),
        "registered": len(sparse.views),
        "unregistered": sparse.unregistered,
        "sparse_points": len(sparse.points_world),
        "reprojection_error_px": round(sparse.mean_reprojection_error_px, 4),
        "dense_method": dense_method,
        "dense_points": int(len(points)),
        "object_points": int(len(obj.points)),
        "support_plane_found": plane is not None,
        "support_plane_points_removed": obj.removed_plane_points,
        "free_space_points_removed": int((~keep).sum()),
        "pieces_dropped": obj.dropped_pieces,
        "scaled": frame.scaled,
        "units": "m" if frame.scaled else "SfM units (no markers: unscaled)",
        "scale_per_sfm_unit": frame.scale,
        "levelled": frame.levelled,
        "markers": frame.markers,
        "marker_edge_spread": round(frame.marker_edge_spread, 5),
        "faces": int(len(textured.mesh.faces)),
        "vertices": int(len(textured.mesh.vertices)),
        "watertight": bool(mesh.is_watertight),
        "extents": [round(float(e), 5) for e in mesh.extents],
        "texture_px": options.texture.size_px,
        "texture_covered_share": round(textured.covered_share, 4),
        "times_s": {k: round(v, 3) for k, v in {**sparse.times_s, **clock.times_s}.items()},
    }
    return Reconstruction(textured=textured, views=views, frame=frame, summary=summary, work_dir=work_dir)


def to_model(result: Reconstruction, *, name: str, density_kg_m3: float):
    """The articulated model: one link, the textured visual, a convex-hull collision, an inertial."""
    import cv2

    from articulation.inertia import inertial_from_meshes
    from articulation.model import (
        Collision,
        Link,
        Material,
        MeshGeometry,
        Model,
        Visual,
    )
    from homemodel.core.atomic import write_bytes_atomic

    texture_path = result.work_dir / "texture.png"
    ok, png = cv2.imencode(".png", cv2.cvtColor(result.textured.texture, cv2.COLOR_RGB2BGR))
    if not ok:
        raise ModelError("cannot encode the texture as PNG")
    write_bytes_atomic(texture_path, png.tobytes())
    mesh = result.mesh
    material = Material(name=f"{name}_material", rgba=(1.0, 1.0, 1.0, 1.0), texture=texture_path)
    link = Link(
        name="body",
        visuals=[Visual(name="body", mesh=mesh, material=material, uv=result.textured.uv)],
        collisions=[Collision(name="body_hull", geometry=MeshGeometry(mesh=mesh.convex_hull))],
        inertial=inertial_from_meshes([mesh], density_kg_m3=density_kg_m3),
    )
    properties = {"source": "photogrammetry", "scaled": str(result.frame.scaled).lower()}
    return Model(name=name, links=[link], category="object", properties=properties)


def write_reconstruction(result: Reconstruction, folder: Path, *, name: str, density_kg_m3: float) -> dict:
    """Write the model files, cameras.json and summary.json into an existing (temporary) folder."""
    from articulation.export import write_model_files
    from homemodel.core.atomic import write_text_atomic

    model = to_model(result, name=name, density_kg_m3=density_kg_m3)
    write_model_files(model, folder)
    cameras = [
        {"name": v.name, "intrinsics": v.intrinsics.tolist(), "camera_from_model": v.camera_from_world.tolist(),
         "width_px": v.width_px, "height_px": v.height_px}
        for v in result.views
    ]  # fmt: skip
    write_text_atomic(folder / "cameras.json", json.dumps(cameras, indent=1))
    summary = {**result.summary, "mass_kg": round(model.links[0].inertial.mass_kg, 6)}
    write_text_atomic(folder / "summary.json", json.dumps(summary, indent=1))
    return summary


def temporary_work_dir() -> tempfile.TemporaryDirectory:
    """A scratch folder for COLMAP's database and the undistorted photos."""
    return tempfile.TemporaryDirectory(prefix="homemodel-photogrammetry-")
