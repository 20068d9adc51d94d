"""Export a model to a model folder: `model.urdf`, `meshes/`, `model.glb`."""

from __future__ import annotations

from pathlib import Path

from articulation.model import Model
from homemodel.core.atomic import atomic_dir
from homemodel.exchange.gltf import write_glb
from homemodel.exchange.urdf.write import write_urdf


def write_model_files(model: Model, folder: Path) -> list[Path]:
    """Write the model's files into an existing folder; returns the written top-level files."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    return [write_urdf(model, folder), write_glb(model, folder)]


def export_model(model: Model, out_dir: Path, *, force: bool = False) -> Path:
    """Export to `out_dir` atomically: on any error the folder is left as it was."""
    with atomic_dir(Path(out_dir), force=force) as tmp:
        write_model_files(model, tmp)
    return Path(out_dir)
