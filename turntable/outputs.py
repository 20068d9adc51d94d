"""Write a reconstruction as a model folder: the one-link model through the articulation
exporter (model.urdf, meshes/, model.glb), the full-resolution coloured PLY, cameras.json,
summary.json and, on request, a picture of the mesh with the camera orbit."""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import trimesh

from articulation.scan_meshes import scan_meshes
from articulation.scan_model import scan_model
from homemodel.core.atomic import write_bytes_atomic
from homemodel.core.errors import ModelError
from homemodel.core.progress import Progress
from homemodel.exchange.cameras import CAMERAS_FILE, CameraView, write_cameras

if TYPE_CHECKING:
    from homemodel.model_folder.write import ModelFolder
    from turntable.reconstruction import Reconstruction, ReconstructOptions

MESH_PLY = "mesh.ply"
TEXTURE_PNG = "texture.png"


def write_reconstruction(
    result: Reconstruction,
    out_dir: Path,
    options: ReconstructOptions,
    *,
    inputs: list[Path],
    force: bool = False,
    progress: Progress | None = None,
) -> ModelFolder:
    """Everything into `out_dir` at once (atomic: a failure leaves it as it was) through
    `write_model_folder`; the export's and the gate's times join `result.times_s`. `inputs`
    holds the capture folder."""
    import cv2

    from homemodel.model_folder.write import PipelineSummary, write_model_folder

    (capture_dir,) = inputs
    with tempfile.TemporaryDirectory(prefix="homemodel-turntable-") as staging:
        texture_path = None
        if result.texture is not None:
            # Staged outside the folder: the URDF exporter copies it in under its own name.
            texture_path = Path(staging) / TEXTURE_PNG
            ok, encoded = cv2.imencode(".png", cv2.cvtColor(result.texture, cv2.COLOR_RGB2BGR))
            if not ok:
                raise ModelError("could not encode the texture as PNG")
            write_bytes_atomic(texture_path, encoded.tobytes())
        # The model is in the table frame; without a texture its colour is the scan's mean.
        mean = tuple(float(v) for v in np.clip(result.vertex_colors.mean(axis=0), 0, 1))
        textured = texture_path is not None
        meshes = scan_meshes(result.mesh, result.cloud.points, textured_mesh=result.textured_mesh if textured else None,
                             uv=result.uv if textured else None, progress=progress)  # fmt: skip
        model = scan_model(
            result.mesh,
            meshes=meshes,
            name=options.name,
            density_kg_m3=options.density_kg_m3,
            rgba=(1.0, 1.0, 1.0, 1.0) if texture_path is not None else (*mean, 1.0),
            texture=texture_path,
            textured_mesh=result.textured_mesh,
            uv=result.uv,
            properties={"source": "turntable"},
        )

        def add_files(tmp: Path) -> None:
            colors = np.round(np.clip(result.vertex_colors, 0, 1) * 255).astype(np.uint8)
            ply = trimesh.Trimesh(result.mesh.vertices, result.mesh.faces, vertex_colors=colors, process=False)
            write_bytes_atomic(tmp / MESH_PLY, ply.export(file_type="ply"))
            views = [
                CameraView(name=s, camera=result.camera, camera_from_frame=p.camera_from_table,
                           figures={"tags": p.tags, "corners": p.inlier_corners,
                                    "reprojection_error_px": round(p.reprojection_error_px, 4)})
                for s, p in result.poses.items()
            ]  # fmt: skip
            write_cameras(tmp / CAMERAS_FILE, views, frame="table", skipped=result.skipped)
            if options.picture:
                from turntable.picture import draw_mesh_and_orbit

                cameras_from_table = [p.camera_from_table for p in result.poses.values()]
                draw_mesh_and_orbit(
                    result.mesh, result.vertex_colors, cameras_from_table, result.axis.axis_xy_m, tmp / "picture.png"
                )

        figures = result.figures()
        del figures["times_s"], figures["extent_m"]  # the summary's own times_s and extents_m
        figures["density_kg_m3"] = options.density_kg_m3
        return write_model_folder(
            model,
            out_dir,
            PipelineSummary(source="turntable", figures=figures, times_s=result.times_s, inputs={"capture": capture_dir},
                            meshes=meshes.figures),  # fmt: skip
            force=force,
            add_files=add_files,
            progress=progress,
        )
