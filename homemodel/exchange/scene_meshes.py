"""Mesh files of a scene export, one folder per object (`meshes/<object id>/`), each file
written once under a name unique in the scene, referred to by its path relative to the
exported file."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import trimesh
from PIL import Image

from articulation.naming import file_stem, unique
from articulation.scene import SceneObject
from homemodel.core.atomic import write_bytes_atomic, write_text_atomic
from homemodel.exchange.obj import obj_text

MESH_DIR = "meshes"


class SceneMeshes:
    def __init__(self, folder: Path) -> None:
        self.folder = Path(folder)
        self.taken: set[str] = set()
        self.textures: dict[tuple[str, Path], tuple[str, str]] = {}

    def name(self, obj: SceneObject, part: str) -> str:
        """A name unique across the scene's meshes and geoms (MJCF shares one namespace)."""
        return unique(file_stem(obj.name(part)), self.taken)

    def write(self, obj: SceneObject, part: str, mesh: trimesh.Trimesh, uv: np.ndarray | None = None) -> tuple[str, str]:
        """(unique name, path relative to the export folder) of `mesh` written as OBJ, with one
        texture coordinate per vertex when `uv` is given."""
        name = self.name(obj, part)
        relative = f"{MESH_DIR}/{obj.id}/{name}.obj"
        write_text_atomic(self.folder / relative, obj_text(mesh, mtl_file=None, material=None, uv=uv))
        return name, relative

    def texture(self, obj: SceneObject, image: Path) -> tuple[str, str]:
        """(unique name, relative path) of `image` copied as PNG (the format every simulator reads)."""
        key = (obj.id, Path(image))
        if key not in self.textures:
            name = self.name(obj, Path(image).stem)
            relative = f"{MESH_DIR}/{obj.id}/{name}.png"
            buffer = io.BytesIO()
            Image.open(image).convert("RGB").save(buffer, format="PNG")
            write_bytes_atomic(self.folder / relative, buffer.getvalue())
            self.textures[key] = (name, relative)
        return self.textures[key]
