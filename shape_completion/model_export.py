"""The shape-completion entry: one depth image to a model folder of the whole object.

`complete(model_file_or_completer, depth_png, out_dir, CompletionOptions(camera_path=...))`
reads the query (the depth image, its camera.yaml and an optional mask), completes it with a
trained `ShapeCompleter` and writes model.urdf, model.glb, meshes/ and summary.json: upright in
the object frame (+z up, origin on the support under the object) when camera.yaml gives the
camera's pose or a support plane is seen (`shape_completion.upright`), else in the query
camera's frame (OpenCV: x right, y down, z forward); summary.json names the frame. Metres.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import trimesh

from homemodel.model_folder.write import PipelineSummary, write_model_folder
from articulation.naming import check_model_name
from articulation.scan_meshes import ScanMeshOptions, scan_meshes
from articulation.scan_model import scan_model
from homemodel.core.errors import ModelError, errors_naming
from homemodel.core.atomic import prepare_out_dir
from homemodel.core.checks import check_nested, require_positive
from homemodel.core.progress import Progress, StageClock
from homemodel.model_folder.gate.gltf import start_khronos_validator
from shape_completion.pipeline import Completion, ShapeCompleter
from shape_completion.support import SupportPlane
from shape_completion.upright import object_frame

if TYPE_CHECKING:  # a map entry comes made: its modules are imported only to register a model
    from homemodel.model_folder.map_entry import MapEntry

GREY = (0.7, 0.7, 0.75, 1.0)  # a completed shape has no colour


@dataclass(kw_only=True)
class CompletionOptions:
    camera_path: Path | None = None  # the query's camera.yaml; None: camera.yaml beside the depth image
    mask_path: Path | None = None  # an 8-bit mask PNG, non-zero on the object
    library_dir: Path | None = None  # refuse a model trained on another version of this library
    name: str | None = None  # the model's name; None: the depth image's file name without suffix
    density_kg_m3: float = 700.0  # for the inertial
    map_entry: MapEntry | None = None  # register the model into this map
    meshes: ScanMeshOptions = field(default_factory=ScanMeshOptions)  # the visual and collision meshes

    def check(self) -> None:
        require_positive("density_kg_m3", self.density_kg_m3)
        check_nested("meshes", self.meshes)
        if self.name is not None:
            check_model_name(self.name)


def _matrix(m: np.ndarray | None) -> list[list[float]] | None:
    return None if m is None else [[float(v) for v in row] for row in m]


def completion_summary(
    completion: Completion, object_mesh: trimesh.Trimesh, support: SupportPlane | None = None
) -> dict:
    """The completion's own figures in summary.json (under `completion`), in the written
    mesh's frame; the size, triangles and times are the summary's common ones. `object_mesh` is
    the export's `completion.object_mesh` (a copy made per call: its watertightness is then the
    one the inertial's test already cached)."""
    fit = completion.fit
    frame = completion.frame or object_frame(completion.mesh, map_from_camera=None, support=None, axis=None)
    object_from_camera = np.linalg.inv(frame.camera_from_object)
    axis = None if fit.axis is None else fit.axis.transformed(object_from_camera)
    return {
        "class": completion.class_name,
        "retrieved": completion.retrieved_name,
        "query_points": int(len(fit.query)),
        "match_distance_m": fit.match_distance_m,
        "fit_distance_m": fit.fit_distance_m,
        "symmetry_planes": len(fit.planes_camera),
        # a revolved match's axis fitted to the query (e.g. a cup's, to grasp it around)
        "revolution_axis": None
        if axis is None
        else {"point_m": axis.point.tolist(), "direction": axis.direction.tolist()},
        "watertight": bool(object_mesh.is_watertight),
        "frame": frame.description,
        "up_from": frame.up_from,
        "camera_from_object": _matrix(frame.camera_from_object),
        "map_from_object": _matrix(frame.map_from_object),
        "support_plane": None
        if support is None
        else {"normal_camera": support.normal.tolist(), "offset_m": support.offset_m, "pixels": support.inlier_pixels},
    }


def complete(
    model: Path | ShapeCompleter,
    depth_png: Path,
    out_dir: Path,
    options: CompletionOptions | None = None,
    *,
    progress: Progress | None = None,
    force: bool = False,
) -> Completion:
    """Complete the object seen in `depth_png` (a 16-bit PNG in units of the camera's
    depth_scale_m, or a float EXR in metres) with `model` (a model file from `homemodel
    completion train`, or a fitted completer) into a model folder at `out_dir`. Refuses a
    non-empty `out_dir` unless `force`; the folder appears whole or not at all; registered
    into `options.map_entry` when given. Progress stages: load, query, matching, rigid_fit,
    deformation, filling, export."""
    from threadpoolctl import threadpool_limits

    # OpenBLAS's second thread spin-waits (sched_yield) between the query's many small products:
    # 64,100 sched_yield calls in one run of the README's query, 1,359 on one thread.
    with threadpool_limits(limits=1, user_api="blas"):
        return _complete(model, depth_png, out_dir, options, progress=progress, force=force)


def _complete(
    model: Path | ShapeCompleter,
    depth_png: Path,
    out_dir: Path,
    options: CompletionOptions | None,
    *,
    progress: Progress | None,
    force: bool,
) -> Completion:
    from shape_completion.library import fingerprint_files, library_files
    from shape_completion.model_io import load_model
    from shape_completion.query_input import load_query

    options = options or CompletionOptions()
    options.check()
    depth_png = Path(depth_png)
    camera_path = Path(options.camera_path or depth_png.parent / "camera.yaml")
    model_path = None if isinstance(model, ShapeCompleter) else Path(model)
    inputs = [p for p in (model_path, depth_png, camera_path) if p is not None]
    prepare_out_dir(Path(out_dir), force=force, inputs=inputs)  # before loading a large model
    if options.map_entry is not None:
        options.map_entry.check()  # an unknown parent or a taken id fails now, not after the work
    start_khronos_validator()  # node loads the gate's glTF validator while the completion runs
    clock = StageClock(progress)
    clock.start("load")
    if model_path is not None:
        expected = fingerprint_files(library_files(options.library_dir)) if options.library_dir is not None else None
        model = load_model(model_path, library_fingerprint=expected)
    query = load_query(depth_png, camera_path, options.mask_path)
    clock.stop()
    with errors_naming(depth_png):
        completion = model.complete(query.depth_m, query.camera, progress=progress)
    completion.times_s = {**clock.times_s, **completion.times_s}
    completion.frame = object_frame(
        completion.mesh, map_from_camera=query.map_from_camera, support=query.support, axis=completion.fit.axis
    )
    if options.map_entry is not None and completion.frame.up_from is None:
        # In the camera's frame the model would stand in the map as the camera saw it, tilted.
        raise ModelError(
            f"{depth_png}: the object's up is unknown (no map_from_camera in {camera_path.name}, no support "
            "plane seen), so it cannot be placed in a map"
        )
    model_inputs = {"completion_model": model_path} if model_path is not None else {}
    mask_input = {"mask": Path(options.mask_path)} if options.mask_path is not None else {}
    object_from_camera = np.linalg.inv(completion.frame.camera_from_object)
    query_points = completion.fit.query @ object_from_camera[:3, :3].T + object_from_camera[:3, 3]
    object_mesh = completion.object_mesh  # a transformed copy: made once
    meshes = scan_meshes(object_mesh, query_points, options=options.meshes, progress=progress)
    completion.summary = write_model_folder(
        scan_model(
            object_mesh,
            meshes=meshes,
            name=options.name or depth_png.stem,
            density_kg_m3=options.density_kg_m3,
            rgba=GREY,
            category=completion.class_name,
            properties={"source": "shape_completion"},
        ),
        out_dir,
        PipelineSummary(
            source="completion",
            figures=completion_summary(completion, object_mesh, query.support),
            times_s=completion.times_s,  # gains the export's and the gate's
            inputs={**model_inputs, "depth": depth_png, "camera": camera_path, **mask_input},
            meshes=meshes.figures,
        ),
        force=force,
        progress=progress,
    ).summary
    completion.register(out_dir, options.map_entry)
    return completion
