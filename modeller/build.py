"""Build an articulated model from a measurement spec, in Blender."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from articulation.model import Model
from modeller.blender_scene import reset_scene, save_blend
from modeller.blender_to_model import Assembly, model_from_scene
from modeller.builders.cup import build_cup
from modeller.builders.cupboard import build_cupboard
from modeller.builders.table import build_table
from modeller.spec_loading import load_spec
from modeller.specs import Spec

_BUILDERS: dict[str, Callable[..., Assembly]] = {"cupboard": build_cupboard, "table": build_table, "cup": build_cup}


def build_model(spec_path: Path, *, blend_path: Path | None = None) -> Model:
    """Load the spec at `spec_path`, build it in a fresh Blender scene, and return its model.

    The model is named by the spec's `name`, else by the file's name without `.yaml`.
    With `blend_path`, the scene is saved there too: one object per part, parented as the
    links are, each link's object named as the link and placed at its frame.
    Raises `SpecError` for a bad spec.
    """
    spec_path = Path(spec_path)
    spec = load_spec(spec_path)
    return build_from_spec(spec, spec.name or spec_path.stem, blend_path=blend_path)


def build_from_spec(spec: Spec, name: str, *, blend_path: Path | None = None) -> Model:
    """`build_model` for a spec already in memory (an editor's, say)."""
    reset_scene()
    assembly = _BUILDERS[spec.kind](spec, name)
    model = model_from_scene(assembly)
    if blend_path is not None:
        save_blend(Path(blend_path))
    return model
