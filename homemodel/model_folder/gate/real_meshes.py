"""The real collision geometry of a URDF's links, to confirm what pybullet's hulls report.

pybullet turns every collision mesh into its convex hull, so a concave part (a microwave's
frame, an oven's cavity, a scanned cup) fills its own opening, and a door or turntable
inside it looks tens of millimetres deep in the body although the real surfaces never meet.
Here each link's collision elements are read as triangle meshes (primitives tessellated)
and tested with FCL through trimesh's collision manager, which intersects the triangles
themselves: a contact between hulls counts only if the real surfaces intersect too.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from trimesh.collision import CollisionManager

from homemodel.core.transforms import transform_from_xyz_rpy
from homemodel.exchange import urdf as urdf_doc
from homemodel.exchange.urdf.mesh_paths import resolve_mesh
from homemodel.model_folder.gate.mesh_files import load_gate_mesh

# Tessellation of primitives for FCL; boxes are exact.
_SPHERE_SUBDIVISIONS = 2
_CYLINDER_SECTIONS = 32


def _floats(text: str | None, default: tuple[float, ...]) -> tuple[float, ...]:
    return tuple(float(v) for v in text.split()) if text else default


def _shape(geometry: Any, urdf_dir: Path, package_paths: Sequence[Path]) -> trimesh.Trimesh | None:
    """A collision element's geometry as triangles in its own frame."""
    if geometry is None:
        return None
    box, cylinder, sphere, mesh = (geometry.find(tag) for tag in ("box", "cylinder", "sphere", "mesh"))
    if box is not None:
        return trimesh.creation.box(extents=_floats(box.get("size"), (0.0, 0.0, 0.0)))
    if cylinder is not None:
        radius, length = float(cylinder.get("radius", 0)), float(cylinder.get("length", 0))
        return trimesh.creation.cylinder(radius=radius, height=length, sections=_CYLINDER_SECTIONS)
    if sphere is not None:
        return trimesh.creation.icosphere(subdivisions=_SPHERE_SUBDIVISIONS, radius=float(sphere.get("radius", 0)))
    if mesh is not None and mesh.get("filename"):
        loaded = load_gate_mesh(resolve_mesh(mesh.get("filename"), urdf_dir, package_paths))
        loaded.apply_scale(_floats(mesh.get("scale"), (1.0, 1.0, 1.0)))
        return loaded
    return None


class RealMeshes:
    """Every link's collision geometry as triangles, tested with FCL at given link poses."""

    def __init__(self, urdf: Path, package_paths: Sequence[Path] = ()) -> None:
        robot = urdf_doc.read_urdf_robot(urdf)
        self._shapes: dict[str, list[tuple[trimesh.Trimesh, np.ndarray]]] = {}
        for link in urdf_doc.links(robot):
            shapes = []
            for _, collision in urdf_doc.link_parts(link, ("collision",)):
                mesh = _shape(collision.find("geometry"), urdf.parent, package_paths)
                origin = collision.find("origin")
                link_from_shape = transform_from_xyz_rpy(
                    _floats(None if origin is None else origin.get("xyz"), (0.0, 0.0, 0.0)),
                    _floats(None if origin is None else origin.get("rpy"), (0.0, 0.0, 0.0)),
                )
                if mesh is not None and len(mesh.faces):
                    shapes.append((mesh, link_from_shape))
            self._shapes[link.get("name")] = shapes
        self._managers: dict[str, CollisionManager] = {}

    def _manager(self, link: str, world_from_link: np.ndarray) -> CollisionManager:
        if link not in self._managers:
            manager = CollisionManager()
            for k, (mesh, link_from_shape) in enumerate(self._shapes.get(link, [])):
                manager.add_object(str(k), mesh, transform=world_from_link @ link_from_shape)
            self._managers[link] = manager
        manager = self._managers[link]
        for k, (_, link_from_shape) in enumerate(self._shapes.get(link, [])):
            manager.set_transform(str(k), world_from_link @ link_from_shape)
        return manager

    def touch(self, link_a: str, world_from_a: np.ndarray, link_b: str, world_from_b: np.ndarray) -> bool:
        """Whether the two links' real surfaces intersect at these poses."""
        if not self._shapes.get(link_a) or not self._shapes.get(link_b):
            return False
        return bool(self._manager(link_a, world_from_a).in_collision_other(self._manager(link_b, world_from_b)))
