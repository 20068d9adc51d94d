"""A completed mesh as a one-link model folder (model.urdf, model.glb, meshes/) plus summary.json."""

from __future__ import annotations

import json
from pathlib import Path

import trimesh

from articulation.export import write_model_files
from articulation.inertia import inertial_from_meshes
from articulation.model import Collision, Link, Material, MeshGeometry, Model, Visual
from homemodel.core.atomic import atomic_dir, write_text_atomic


def completion_model(mesh: trimesh.Trimesh, *, name: str, category: str, density_kg_m3: float) -> Model:
    """One link holding the mesh as visual and (convex-hull) collision, with its inertial."""
    link = Link(
        name="object",
        visuals=[Visual(name="completed", mesh=mesh, material=Material(name="completed", rgba=(0.7, 0.7, 0.75, 1.0)))],
        collisions=[Collision(name="hull", geometry=MeshGeometry(mesh=mesh))],
        inertial=inertial_from_meshes([mesh], density_kg_m3=density_kg_m3),
    )
    return Model(name=name, links=[link], category=category)


def export_completion(
    model: Model, out_dir: Path, *, summary: dict, force: bool = False, inputs: tuple[Path, ...] = ()
) -> Path:
    """Write the model folder and its summary.json atomically (all or nothing)."""
    with atomic_dir(Path(out_dir), force=force, inputs=inputs) as tmp:
        write_model_files(model, tmp)
        write_text_atomic(tmp / "summary.json", json.dumps(summary, indent=2, sort_keys=True) + "\n")
    return Path(out_dir)
