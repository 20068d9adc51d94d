"""Write a reconstruction as a model folder: the one-link model through the articulation
exporter (model.urdf, meshes/, model.glb), the full-resolution coloured PLY, poses.json,
summary.json and, on request, a picture of the mesh with the camera orbit."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import trimesh

from articulation.export import write_model_files
from articulation.inertia import inertial_from_meshes
from articulation.model import Collision, Link, Material, MeshGeometry, Model, Visual
from homemodel.core.atomic import atomic_dir, write_bytes_atomic, write_text_atomic
from homemodel.core.errors import ModelError
from turntable.poses_io import write_poses
from turntable.reconstruct import Reconstruction

MESH_PLY = "mesh.ply"
TEXTURE_PNG = "texture.png"


def turntable_model(result: Reconstruction, *, name: str, texture_path: Path | None, density_kg_m3: float) -> Model:
    """One link in the table frame: the textured visual, its convex hull as collision, and an
    inertial from the closed mesh's volume (its hull's, if the mesh is not closed)."""
    if result.textured_mesh is not None and texture_path is not None:
        visual_mesh, uv = result.textured_mesh, result.uv
        material = Material(name=f"{name}_surface", rgba=(1.0, 1.0, 1.0, 1.0), texture=texture_path)
    else:
        visual_mesh, uv = result.mesh, None
        mean = tuple(float(v) for v in np.clip(result.vertex_colors.mean(axis=0), 0, 1))
        material = Material(name=f"{name}_surface", rgba=(*mean, 1.0))
    link = Link(
        name=f"{name}_link",
        visuals=[Visual(name="scan", mesh=visual_mesh, material=material, uv=uv)],
        collisions=[Collision(name="hull", geometry=MeshGeometry(mesh=result.mesh))],
        inertial=inertial_from_meshes([result.mesh], density_kg_m3=density_kg_m3),
    )
    return Model(name=name, links=[link], category="object", properties={"source": "turntable"})


def write_reconstruction(
    result: Reconstruction,
    out_dir: Path,
    *,
    name: str,
    inputs: list[Path],
    density_kg_m3: float = 500.0,
    picture: bool = False,
    force: bool = False,
) -> Path:
    """Everything into `out_dir` at once (atomic: a failure leaves it as it was)."""
    import cv2

    with atomic_dir(Path(out_dir), force=force, inputs=inputs) as tmp:
        texture_path = None
        if result.texture is not None:
            # Staged outside meshes/: the URDF exporter copies it in under its own name.
            staging = tmp / ".texture"
            staging.mkdir()
            texture_path = staging / TEXTURE_PNG
            ok, encoded = cv2.imencode(".png", cv2.cvtColor(result.texture, cv2.COLOR_RGB2BGR))
            if not ok:
                raise ModelError("could not encode the texture as PNG")
            write_bytes_atomic(texture_path, encoded.tobytes())
        model = turntable_model(result, name=name, texture_path=texture_path, density_kg_m3=density_kg_m3)
        write_model_files(model, tmp)
        if texture_path is not None:
            texture_path.unlink()
            texture_path.parent.rmdir()
        colors = np.round(np.clip(result.vertex_colors, 0, 1) * 255).astype(np.uint8)
        ply = trimesh.Trimesh(result.mesh.vertices, result.mesh.faces, vertex_colors=colors, process=False)
        write_bytes_atomic(tmp / MESH_PLY, ply.export(file_type="ply"))
        write_poses(
            tmp / "poses.json",
            {s: p.camera_from_table for s, p in result.poses.items()},
            figures={
                s: {
                    "tags": p.tags,
                    "corners": p.inlier_corners,
                    "reprojection_error_px": round(p.reprojection_error_px, 4),
                }
                for s, p in result.poses.items()
            },
            skipped=result.skipped,
        )
        summary = result.summary()
        summary["model"] = {"name": name, "mass_kg": model.links[0].inertial.mass_kg, "density_kg_m3": density_kg_m3}
        if picture:
            from turntable.picture import draw_mesh_and_orbit

            draw_mesh_and_orbit(result, tmp / "picture.png")
        write_text_atomic(tmp / "summary.json", json.dumps(summary, indent=1) + "\n")
    return Path(out_dir)
