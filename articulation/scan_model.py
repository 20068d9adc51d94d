"""The one-link model of a scanned or completed object: what turntable, photogrammetry and
shape_completion hand to the exporter.

One link, `body` (as the modeller names the root of its objects, and the map registers a
model by its root link), holding the scan's two meshes (`articulation.scan_meshes`): the
visual mesh at full detail (`body_body.obj` in meshes/, and model.glb) and, as collisions, the
mesh's convex hull (`hull`) when it keeps within the tolerance of the surface, else its convex
parts (`part_0`, ...; their fidelity in the property `collision_parts`), and an inertial from
the mesh's volume (its hull's, when the mesh is not closed).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from articulation.inertia import inertial_from_meshes
from articulation.model import Collision, Link, Material, MeshGeometry, Model, Visual
from articulation.scan_meshes import ScanMeshPair, scan_meshes

LINK = "body"


def scan_model(
    mesh: trimesh.Trimesh,
    *,
    name: str,
    density_kg_m3: float,
    rgba: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0),
    texture: Path | None = None,
    textured_mesh: trimesh.Trimesh | None = None,
    uv: np.ndarray | None = None,
    category: str = "object",
    properties: dict[str, str] | None = None,
    meshes: ScanMeshPair | None = None,
) -> Model:
    """A model named `name` with one link holding `mesh`.

    `meshes` is the visual/collision pair `scan_meshes` made of `mesh` (with the points'
    figures for the summary); None: made here without points. With a `texture` image, the
    visual is `textured_mesh` (the mesh split along its UV seams, often decimated for the
    atlas; default `mesh`) with one `uv` per vertex; the inertial always comes from `mesh`.
    The material is `<name>_material`, so the exported texture is
    `meshes/<name>_material_texture.png`.
    """
    if meshes is None:
        textured = texture is not None
        meshes = scan_meshes(mesh, None, textured_mesh=textured_mesh if textured else None, uv=uv if textured else None)
    material = Material(name=f"{name}_material", rgba=rgba, texture=texture)
    properties = dict(properties or {})
    if meshes.decomposition is None:
        collisions = [Collision(name="hull", geometry=MeshGeometry(mesh=meshes.collisions[0]))]
    else:
        collisions = [
            Collision(name=f"part_{k}", geometry=MeshGeometry(mesh=part)) for k, part in enumerate(meshes.collisions)
        ]
        properties["collision_parts"] = meshes.decomposition.format()
    link = Link(
        name=LINK,
        visuals=[
            Visual(
                name=LINK,
                mesh=meshes.visual,
                material=material,
                uv=meshes.uv if texture is not None else None,
            )
        ],
        collisions=collisions,
        inertial=inertial_from_meshes([mesh], density_kg_m3=density_kg_m3),
    )
    return Model(name=name, links=[link], category=category, properties=properties)
