"""Mesh files of a scene export, one folder per object (`meshes/<object id>/`), each file
written once under a name unique in the scene, referred to by its path relative to the
exported file."""

from __future__ import annotations

from pathlib import Path

import trimesh

from articulation.naming import file_stem, unique
from articulation.obj_io import obj_text
from articulation.scene import SceneObject
from homemodel.core.atomic import write_text_atomic

MESH_DIR = "meshes"


class SceneMeshes:
    def __init__(self, folder: Path) -> None:
        self.folder = Path(folder)
        self.taken: set[str] = set()

    def name(self, obj: SceneObject, part: str) -> str:
        """A name unique across the scene's meshes and geoms (MJCF shares one namespace)."""
        return unique(file_stem(obj.name(part)), self.taken)

    def write(self, obj: SceneObject, part: str, mesh: trimesh.Trimesh) -> tuple[str, str]:
        """(unique name, path relative to the export folder) of `mesh` written as OBJ."""
        name = self.name(obj, part)
        relative = f"{MESH_DIR}/{obj.id}/{name}.obj"
        write_text_atomic(self.folder / relative, obj_text(mesh, mtl_file=None, material=None, uv=None))
        return name, relative
