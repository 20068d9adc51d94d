"""Build an articulated model from a measurement spec, in Blender."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from articulation.model import Model
from homemodel.core.errors import SpecError
from homemodel.core.yaml_specs import FieldError
from modeller.blender_scene import reset_scene, save_blend
from modeller.blender_textures import PhotoPlacement, apply_photos
from modeller.blender_to_model import Assembly, model_from_scene
from modeller.builders.appliances import (
    build_dishwasher,
    build_fridge,
    build_microwave,
    build_oven,
    build_washing_machine,
)
from modeller.builders.bed import build_bed
from modeller.builders.boxes import build_box, build_pill_box
from modeller.builders.cup import build_cup
from modeller.builders.cupboard import (
    build_cupboard,
    build_wall_cabinet,
    build_wardrobe,
)
from modeller.builders.cutlery import build_fork, build_knife, build_spoon
from modeller.builders.remote_control import build_remote_control
from modeller.builders.seating import build_chair, build_sofa
from modeller.builders.shelving import build_shelving
from modeller.builders.table import build_table
from modeller.builders.vessels import (
    build_bottle,
    build_bowl,
    build_glass,
    build_jar,
    build_plate,
)
from modeller.photo_texture import FaceTextureOptions, texture_folder
from modeller.spec_loading import load_spec
from modeller.specs import Spec

_BUILDERS: dict[str, Callable[..., Assembly]] = {"cupboard": build_cupboard, "table": build_table, "cup": build_cup}
_BUILDERS |= {"chair": build_chair, "sofa": build_sofa, "bed": build_bed, "shelving": build_shelving, "mug": build_cup, "glass": build_glass, "plate": build_plate, "bowl": build_bowl, "bottle": build_bottle, "box": build_box, "jar": build_jar, "pill_box": build_pill_box, "spoon": build_spoon, "fork": build_fork, "knife": build_knife, "remote_control": build_remote_control}
_BUILDERS |= {"wall_cabinet": build_wall_cabinet, "wardrobe": build_wardrobe, "fridge": build_fridge, "oven": build_oven, "dishwasher": build_dishwasher, "washing_machine": build_washing_machine, "microwave": build_microwave}


def build_model(spec_path: Path, *, blend_path: Path | None = None) -> Model:
    """Load the spec at `spec_path`, build it in a fresh Blender scene, and return its model.

    The model is named by the spec's `name`, else by the file's name without `.yaml`.
    With `blend_path`, the scene is saved there too: one object per part, parented as the
    links are, each link's object named as the link and placed at its frame.
    Raises `SpecError` for a bad spec.
    """
    spec_path = Path(spec_path)
    spec = load_spec(spec_path)
    return build_from_spec(spec, spec.name or spec_path.stem, blend_path=blend_path, spec_path=spec_path)


def build_from_spec(spec: Spec, name: str, *, blend_path: Path | None = None, spec_path: Path | None = None) -> Model:
    """`build_model` for a spec already in memory (an editor's, say); relative photo paths
    are taken from `spec_path`'s folder (else the working folder), which errors name."""
    return build_textured(spec, name, blend_path=blend_path, spec_path=spec_path).model


@dataclass(kw_only=True)
class TexturedBuild:
    """A built model and where each of its spec's photos went."""

    model: Model
    photos: list[PhotoPlacement]


def build_textured(
    spec: Spec,
    name: str,
    *,
    blend_path: Path | None = None,
    spec_path: Path | None = None,
    texture_options: FaceTextureOptions | None = None,
) -> TexturedBuild:
    """`build_from_spec`, also returning the photos' placements (for comparison pictures).

    After the builder, the spec's photos are rectified and put on their faces; their
    texture images live in a folder of this process (removed at exit) until exported.
    """
    reset_scene()
    assembly = _BUILDERS[spec.kind](spec, name)
    placements = []
    if spec.photos:
        folder = Path(spec_path).parent if spec_path is not None else Path.cwd()
        photos = [p.model_copy(update={"photo": folder / p.photo}) for p in spec.photos]
        try:
            placements = apply_photos(photos, texture_folder(), texture_options or FaceTextureOptions())
        except FieldError as exc:
            where = spec_path if spec_path is not None else f"spec {name!r}"
            raise SpecError(f"{where}: {'.'.join(str(part) for part in exc.loc)}: {exc}") from None
    model = model_from_scene(assembly)
    if blend_path is not None:
        save_blend(Path(blend_path))
    return TexturedBuild(model=model, photos=placements)
