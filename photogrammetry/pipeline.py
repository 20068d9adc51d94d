"""Photos to a textured, metric, cleaned mesh: every stage of D3.1 section 3.3.3, offline.

`reconstruct_photos` runs structure from motion (pycolmap), dense depth (CPU semi-global
matching, or PatchMatch where pycolmap has CUDA), fusion, markers for scale and levelling,
cleaning, Poisson meshing and texture baking, in memory; `reconstruct`, the entry, also
exports the result as a model folder (the one-link model of `articulation.scan_model`) and
registers it into a semantic map when asked.
"""

from __future__ import annotations

import logging
import tempfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh

from articulation.naming import check_model_name
from homemodel.core.atomic import prepare_out_dir, write_bytes_atomic
from homemodel.core.checks import check_nested, require_at_least, require_between, require_choice
from homemodel.core.errors import InputError, ModelError
from homemodel.core.images import read_image
from homemodel.core.progress import Progress, StageClock
from homemodel.exchange.cameras import CAMERAS_FILE, CameraView, write_cameras
from homemodel.geometry.mesh_ops import watertight_finish
from photogrammetry.cleaning import (
    CleaningOptions,
    downsample,
    face_the_cameras,
    mesh_object,
    segment_object,
)
from photogrammetry.convergence import aimed_focus, in_frame_share
from photogrammetry.markers import DICTIONARIES, MarkerDictionary, detect_markers, triangulate_markers
from photogrammetry.metric_frame import ModelFrame, metric_frame
from photogrammetry.photos import list_photos
from photogrammetry.sfm import SfmOptions, SparseModel, View, quiet_c_libraries, run_sfm
from photogrammetry.stereo import DenseOptions, compute_depth_maps, depth_image_side_px, depth_maps_to_points
from photogrammetry.support_plane import find_support_plane, scene_up
from photogrammetry.texturing import TexturedMesh, TextureBakingOptions, bake_texture
from photogrammetry.visibility import keep_surface_points
from homemodel.model_folder.map_entry import MapEntry
from homemodel.model_folder.result import ModelResult

log = logging.getLogger(__name__)


@dataclass(kw_only=True)
class ReconstructOptions:
    sfm: SfmOptions = field(default_factory=SfmOptions)
    dense: DenseOptions = field(default_factory=DenseOptions)
    cleaning: CleaningOptions = field(default_factory=CleaningOptions)
    texture: TextureBakingOptions = field(default_factory=TextureBakingOptions)
    marker_size_m: float | None = None  # the printed markers' black-square edge; None: no markers
    dictionary: MarkerDictionary = "apriltag_36h11"
    max_faces: int = 500_000  # the visual mesh is decimated to this before texturing
    use_cuda: bool = True  # PatchMatch where pycolmap has CUDA; the CPU path otherwise
    # The model folder (`reconstruct`):
    name: str = "object"  # the model's name
    density_kg_m3: float = 500.0  # for the inertial
    picture: bool = False  # also draw cameras.png: the cameras around the mesh
    map_entry: MapEntry | None = None  # register the model into this map; needs markers (a metric model)

    def check(self) -> None:
        check_nested("sfm", self.sfm)
        check_nested("dense", self.dense)
        check_nested("cleaning", self.cleaning)
        check_nested("texture", self.texture)
        if self.marker_size_m is not None and not (np.isfinite(self.marker_size_m) and self.marker_size_m > 0):
            raise InputError(
                f"marker_size_m: the marker size must be a positive length in metres, got {self.marker_size_m}"
            )
        require_choice("dictionary", self.dictionary, DICTIONARIES)
        require_at_least("max_faces", self.max_faces, 100)
        require_between("density_kg_m3", self.density_kg_m3, 1e-3, 1e5)
        check_model_name(self.name)
        if self.map_entry is not None and self.marker_size_m is None:
            raise InputError("map_entry: a map needs a metric model: give marker_size_m and photograph markers")


@dataclass(kw_only=True)
class Reconstruction(ModelResult):
    """A finished reconstruction in the model frame (metres when `frame.scaled`)."""

    textured: TexturedMesh
    views: list[View]  # poses in the model frame
    frame: ModelFrame
    figures: dict  # the stages' figures (summary.json's `photogrammetry` key) and their times
    work_dir: Path  # holds the texture image until the export copies it (gone after `reconstruct`)
    object_points: np.ndarray | None = None  # (N, 3) the object's fused dense points the mesh was made from
    # (N, 3) the fused dense points the cleaning started from: where the photos look, free space
    # removed, the support surface and any stray pieces still in (what the cut is judged against)
    scene_points: np.ndarray | None = None

    @property
    def mesh(self) -> trimesh.Trimesh:
        return self.textured.mesh


def _dense_points(sparse: SparseModel, undistorted: Path, options: ReconstructOptions, clock: StageClock, side_px: int,
                  roi: tuple[np.ndarray, float]):  # fmt: skip
    from photogrammetry.patch_match import cuda_available, patch_match_points

    if options.use_cuda and cuda_available():
        # COLMAP's fusion checks visibility itself: no depth maps are handed on.
        return (*patch_match_points(undistorted, side_px), [], "patch-match (CUDA)")
    maps = compute_depth_maps(sparse, options.dense, progress=clock.progress, side_px=side_px,
                              workers=options.sfm.threads, roi=roi)  # fmt: skip
    points, colours, to_camera = depth_maps_to_points(sparse, maps, options.dense.point_step_px)
    return points, colours, to_camera, maps, "semi-global matching (CPU)"


def _markers(sparse: SparseModel, options: ReconstructOptions, clock: StageClock):
    """Markers seen in the undistorted views, triangulated in the SfM frame; the views are
    searched on all cores (OpenCV's decoding and detection release the GIL)."""
    import cv2

    def detect(view: View):
        return detect_markers(read_image(view.image_path, cv2.IMREAD_GRAYSCALE), view.name, options.dictionary)

    sightings = []
    with ThreadPoolExecutor(max_workers=options.sfm.threads) as pool:
        for index, found in enumerate(pool.map(detect, sparse.views)):
            sightings += found
            clock.tick(index + 1, len(sparse.views))
    projections = {v.name: v.camera.matrix @ v.camera_from_world[:3, :] for v in sparse.views}
    return triangulate_markers(sightings, projections)


def reconstruct_photos(photos_dir: Path, options: ReconstructOptions | None = None,
                       progress: Progress | None = None, *, work_dir: Path) -> Reconstruction:  # fmt: skip
    """Run every stage on the photos in `photos_dir`, with intermediate files in `work_dir`."""
    options = options or ReconstructOptions()
    with quiet_c_libraries(options.sfm.verbose):  # libpng's warnings on odd PNG headers
        photos = list_photos(Path(photos_dir))
    sparse = run_sfm(photos, work_dir, options.sfm, progress=progress)
    clock = StageClock(progress)
    clock.start("dense")
    focus, aimed = aimed_focus(sparse.views)
    # Photos registered looking past what the others look at are wrongly placed: their depth
    # would be matched against the wrong views.
    looking_away = [v.name for v, a in zip(sparse.views, aimed) if not a]
    if looking_away:
        log.warning("%s: %d photos dropped, looking away from the others' aim: %s", photos_dir, len(looking_away),
                    ", ".join(looking_away))  # fmt: skip
        sparse = sparse.without(set(looking_away))
    centres = np.array([v.centre_world for v in sparse.views])
    scene_scale = float(np.median(np.linalg.norm(centres - focus, axis=1)))
    voxel = options.cleaning.voxel_fraction * scene_scale
    dense_side_px = depth_image_side_px(sparse, options.dense, focus=focus, voxel=voxel)
    # Only what lies near the focus is kept after the fusion: only that is matched.
    points, colours, to_camera, depth_maps, dense_method = _dense_points(
        sparse, work_dir / "undistorted", options, clock, dense_side_px, (focus, options.cleaning.roi_fraction * scene_scale)
    )
    if len(points) < 1000:
        raise ModelError(f"{photos_dir}: dense matching found only {len(points)} points: too little texture or overlap")

    clock.start("fusion")
    points, colours, to_camera = downsample(points, colours, to_camera, voxel)
    # The object lies where the cameras look, well inside the ring of cameras: far-off walls
    # and furniture are cut away before any plane or piece is looked for.
    near = np.linalg.norm(points - focus, axis=1) <= options.cleaning.roi_fraction * scene_scale
    points, colours, to_camera = points[near], colours[near], to_camera[near]
    keep = np.ones(len(points), bool)
    if options.marker_size_m is None:
        # Nothing printed marks the object out: it is what (nearly) every photo keeps in frame.
        share = in_frame_share(points, sparse.views, margin=options.cleaning.in_frame_margin)
        keep = share >= options.cleaning.min_in_frame_share
    if keep.sum() < 100:
        raise ModelError(
            f"{photos_dir}: only {keep.sum()} dense points lie where the photos look and stay in frame: "
            "no one object is seen from all round (take the photos circling the object, or give --marker-size-m)"
        )
    camera_from_world = np.array([v.camera_from_world for v in sparse.views])
    # The table reaches beyond the frames' common part: up and the plane are looked for in every
    # point near the object, and must have what stays in frame above them. Their threshold is
    # wider than the cut's clearance: a seat's cushion or a warped board is not quite flat.
    plane_threshold = options.cleaning.plane_clearance_fraction * scene_scale
    seed = options.sfm.random_state
    up = scene_up(points, points[keep], camera_from_world, focus, threshold=plane_threshold, seed=seed)
    plane = None
    if options.cleaning.remove_support:
        plane = find_support_plane(points, points[keep], camera_from_world, focus, threshold=plane_threshold, seed=seed, up=up)
    points, colours, to_camera = points[keep], colours[keep], to_camera[keep]
    if options.marker_size_m is not None:
        clock.start("markers")
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
        up_hint_sfm=up,
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
                         model_focus, model_scale, options.cleaning,
                         plane_noise=plane.noise * frame.scale if plane is not None else None)  # fmt: skip
    if plane is None and not markers:
        # The object stands where its own lowest point is, not the scene's (a stray point far
        # below would otherwise put the flat bottom Poisson closes on far under the object).
        lift = obj.points[:, 2].min() - 2 * clearance
        obj.points[:, 2] -= lift
        frame.model_from_sfm[2, 3] -= lift

    clock.start("meshing")
    mesh = watertight_finish(mesh_object(obj, model_scale, options.cleaning), options.max_faces)
    mesh = face_the_cameras(mesh, frame.apply(centres))

    clock.start("texturing")
    views = [frame.view(v) for v in sparse.views]
    textured = bake_texture(mesh, views, options.texture, progress=clock.progress, workers=options.sfm.threads)
    clock.stop()

    figures = {
        "photos": len(photos),
        "registered": len(sparse.views),
        "unregistered": sparse.unregistered,
        "matching": sparse.matching,
        "cameras": sparse.cameras,
        "features_per_photo": sparse.median_features,
        "sparse_points": len(sparse.points_world),
        "reprojection_error_px": round(sparse.mean_reprojection_error_px, 4),
        "dense_method": dense_method,
        "dense_image_px": dense_side_px,
        "dense_points": int(len(points)),
        "object_points": int(len(obj.points)),
        "support_plane_found": plane is not None,
        "support_plane": plane.figures() if plane is not None else None,
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
    return Reconstruction(textured=textured, views=views, frame=frame, figures=figures, work_dir=work_dir,
                          object_points=obj.points, scene_points=frame.apply(points[keep]))  # fmt: skip


def reconstruct(
    photos_dir: Path,
    out_dir: Path,
    options: ReconstructOptions | None = None,
    *,
    progress: Progress | None = None,
    force: bool = False,
) -> Reconstruction:
    """The photogrammetry entry: the photos in `photos_dir` to a model folder at `out_dir`
    (model.urdf, model.glb, meshes/, cameras.json, summary.json; cameras.png on request),
    registered into `options.map_entry` when given. Refuses a non-empty `out_dir` unless
    `force`; the folder appears whole or not at all. Progress stages: features, matching,
    mapping, undistortion, dense, fusion, markers (with markers), cleaning, meshing, texturing, export."""
    options = options or ReconstructOptions()
    options.check()
    if options.map_entry is not None:
        options.map_entry.check()  # a bad map or parent fails now, not after the reconstruction
    prepare_out_dir(Path(out_dir), force=force, inputs=[Path(photos_dir)])  # a full --out fails now, not at the end
    with temporary_work_dir() as work:
        result = reconstruct_photos(photos_dir, options, progress, work_dir=Path(work))
        write_reconstruction(result, out_dir, options, photos_dir=Path(photos_dir), force=force, progress=progress)
    result.register(out_dir, options.map_entry)
    return result


def write_reconstruction(
    result: Reconstruction,
    out_dir: Path,
    options: ReconstructOptions,
    *,
    photos_dir: Path,
    force: bool = False,
    progress: Progress | None = None,
) -> None:
    """Write the model folder (`write_model_folder`: model files, the gate, summary.json) with
    cameras.json and cameras.png (`options.picture`); sets `result.summary`."""
    import cv2

    from homemodel.model_folder.write import PipelineSummary, write_model_folder
    from articulation.scan_meshes import scan_meshes
    from articulation.scan_model import scan_model

    texture_path = result.work_dir / "texture.png"
    ok, png = cv2.imencode(".png", cv2.cvtColor(result.textured.texture, cv2.COLOR_RGB2BGR))
    if not ok:
        raise ModelError("cannot encode the texture as PNG")
    write_bytes_atomic(texture_path, png.tobytes())
    meshes = scan_meshes(result.mesh, result.object_points, uv=result.textured.uv, metric=result.frame.scaled,
                         progress=progress)  # fmt: skip
    model = scan_model(
        result.mesh,
        meshes=meshes,
        name=options.name,
        density_kg_m3=options.density_kg_m3,
        texture=texture_path,
        uv=result.textured.uv,
        properties={"source": "photogrammetry", "scaled": str(result.frame.scaled).lower()},
    )

    def add_files(folder: Path) -> None:
        write_cameras(folder / CAMERAS_FILE, [CameraView(name=v.name, camera=v.camera, camera_from_frame=v.camera_from_world)
                                              for v in result.views], frame="model")  # fmt: skip
        if options.picture:
            from photogrammetry.picture import draw_cameras

            draw_cameras(
                result.mesh, result.views, folder / "cameras.png", title=f"{options.name}: {len(result.views)} cameras"
            )

    # The summary's top level holds units, extents_m, mass_kg and times_s; without markers
    # the size stays here, in SfM units.
    figures = {k: v for k, v in result.figures.items() if k not in ("units", "extents", "times_s")}
    if not result.frame.scaled:
        figures["extents_sfm_units"] = result.figures["extents"]
    written = write_model_folder(
        model,
        out_dir,
        PipelineSummary(
            source="photogrammetry",
            figures=figures,
            metric=result.frame.scaled,
            times_s=dict(result.figures["times_s"]),
            inputs={"photos": photos_dir},
            meshes=meshes.figures,
        ),
        force=force,
        add_files=add_files,
        progress=progress,
    )
    result.summary = written.summary


def temporary_work_dir() -> tempfile.TemporaryDirectory:
    """A scratch folder for COLMAP's database and the undistorted photos."""
    return tempfile.TemporaryDirectory(prefix="homemodel-photogrammetry-")
