"""The one-link model of a scanned or completed object: what turntable, photogrammetry and
shape_completion hand to the exporter.

One link, `body` (as the modeller names the root of its objects, and the map registers a
model by its root link), holding the mesh as its visual (`body_body.obj` in meshes/), the
mesh as its collision (the exporters write its convex hull, which pybullet and the gate's
collision sweep load as one convex shape) or, for a closed concave mesh (a cup, a bowl),
its convex parts (`articulation.convex_parts`, their fidelity in the property
`collision_parts`), and an inertial from the mesh's volume (its hull's, when the mesh is
not closed).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from articulation.convex_parts import decompose, is_concave
from articulation.inertia import inertial_from_meshes
from articulation.model import Collision, Link, Material, MeshGeometry, Model, Visual

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
) -> Model:
    """A model named `name` with one link holding `mesh`.

    With a `texture` image, the visual is `textured_mesh` (the mesh split along its UV
    seams, often decimated for the atlas; default `mesh`) with one `uv` per vertex; collision
    and inertial always come from `mesh`. The material is `<name>_material`, so the exported
    texture is `meshes/<name>_material_texture.png`.
    """
    material = Material(name=f"{name}_material", rgba=rgba, texture=texture)
    visual_mesh = textured_mesh if texture is not None and textured_mesh is not None else mesh
    link = Link(
        name=LINK,
        visuals=[Visual(name=LINK, mesh=visual_mesh, material=material, uv=uv if texture is not None else None)],
        collisions=[Collision(name="hull", geometry=MeshGeometry(mesh=mesh))],
        inertial=inertial_from_meshes([mesh], density_kg_m3=density_kg_m3),
    )
    properties = dict(properties or {})
    if is_concave(mesh):
        split = decompose(mesh)
        link.collisions = [
            Collision(name=f"part_{k}", geometry=MeshGeometry(mesh=part.mesh)) for k, part in enumerate(split.parts)
        ]
        properties["collision_parts"] = split.format()
    return Model(name=name, links=[link], category=category, properties=properties)
