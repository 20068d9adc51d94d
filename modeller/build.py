"""Build an articulated model from a measurement spec, in Blender; `build`, the modeller's
entry, also exports it as a model folder, validates it and, for a spec with photos, renders
the model beside each photo."""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from articulation.model import Model
from articulation.naming import check_model_name
from homemodel.core.atomic import prepare_out_dir
from homemodel.core.checks import check_nested
from homemodel.core.errors import SpecError
from homemodel.core.progress import Progress, StageClock
from homemodel.core.yaml_specs import FieldError
from homemodel.geometry.cycles_scene import reset_to_empty_scene
from modeller.blender_scene import save_blend
from modeller.blender_textures import PhotoPlacement, apply_photos
from modeller.blender_to_model import model_from_scene
from modeller.joint_physics import set_joint_physics
from modeller.kinds import KINDS
from modeller.photo_texture import FaceTextureOptions, texture_folder
from modeller.spec_loading import load_spec
from modeller.specs import Spec
from modeller.specs.cabinets import CabinetSpec
from modeller.specs.cabinet_geometry import hinge_tape_warnings
from homemodel.model_folder.map_entry import MapEntry
from homemodel.model_folder.result import ModelResult

if TYPE_CHECKING:
    from homemodel.model_folder.gate.validate import ValidationReport
    from modeller.comparison_picture import PictureOptions, PictureRow

logger = logging.getLogger(__name__)

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
    reset_to_empty_scene()
    assembly = KINDS[spec.kind].builder(spec, name)
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
    set_joint_physics(model)
    if blend_path is not None:
        save_blend(Path(blend_path))
    return TexturedBuild(model=model, photos=placements)


@dataclass(kw_only=True)
class BuildOptions:
    name: str | None = None  # the model's name; None: the spec's `name`, else the file's name without .yaml
    texture: FaceTextureOptions = field(default_factory=FaceTextureOptions)
    # Also render comparison_<i>.png, the model beside each of the spec's photos (which it must have).
    pictures: PictureOptions | None = None
    map_entry: MapEntry | None = None  # register the model into this map

    def check(self) -> None:
        if self.name is not None:
            check_model_name(self.name)
        check_nested("texture", self.texture)
        if self.pictures is not None:
            check_nested("pictures", self.pictures)


@dataclass(kw_only=True)
class SpecBuild(ModelResult):
    """A built, exported and validated spec; `summary` is what summary.json holds."""

    out_dir: Path
    model: Model
    validation: ValidationReport
    pictures: list[PictureRow]
    times_s: dict[str, float]  # build, export, validate (and render)
    warnings: list[str] = field(default_factory=list)  # what the spec's readings disagree on

    @property
    def valid(self) -> bool:
        return self.validation.ok

    @property
    def failed_checks(self) -> list[str]:
        return self.summary.gate.failed_checks


def build(
    spec_path: Path,
    out_dir: Path,
    options: BuildOptions | None = None,
    *,
    progress: Progress | None = None,
    force: bool = False,
) -> SpecBuild:
    """The modeller's entry: the spec at `spec_path` to a model folder at `out_dir`
    (model.urdf, model.glb, meshes/ with the textures, model.blend, summary.json with the
    figures and the validation report; comparison pictures with `options.pictures`).

    The model is validated by the gate (`homemodel.model_folder.gate`); a model that fails it is still
    written, with `valid` false. Refuses a non-empty `out_dir` unless `force`; the folder
    appears whole or not at all; registered into `options.map_entry` when given. Raises
    `SpecError` for a bad spec or photo. Progress stages: build, export, validate, render.
    """
    from homemodel.model_folder.write import PipelineSummary, write_model_folder

    options = options or BuildOptions()
    options.check()
    spec_path, out_dir = Path(spec_path), Path(out_dir)
    prepare_out_dir(out_dir, force=force, inputs=[spec_path])  # before the build, not after it
    if options.map_entry is not None:
        options.map_entry.check()  # an unknown parent or a taken id fails now, not after the work
    clock = StageClock(progress)
    clock.start("build")
    spec = load_spec(spec_path)
    warnings = spec_warnings(spec)
    for warning in warnings:
        logger.warning("%s: %s", spec_path, warning)
    if options.pictures is not None and not spec.photos:
        raise SpecError(f"{spec_path}: photos: the spec gives no photos to compare with")
    built = build_textured(spec, spec.name or spec_path.stem, spec_path=spec_path, texture_options=options.texture)
    model = built.model
    if options.name is not None:
        model.name = options.name
    clock.stop()
    times_s = dict(clock.times_s)
    pictures: list[PictureRow] = []
    figures: dict = {
        "grasp_points": len(model.grasp_points),
        "masses_kg": {link.name: round(link.inertial.mass_kg, 4) for link in model.links if link.inertial},
        "pictures": [],
    }

    def add_files(tmp: Path) -> None:
        save_blend(tmp / "model.blend")  # the scene is still the one built above
        if options.pictures is not None:
            from modeller.comparison_picture import comparison_pictures

            clock.start("render")
            pictures.extend(comparison_pictures(model, built.photos, tmp, options.pictures))
            clock.stop()
            figures["pictures"] = [vars(row) for row in pictures]
            times_s["render"] = clock.times_s["render"]

    folder = write_model_folder(
        model,
        out_dir,
        PipelineSummary(source="modeller", figures=figures, times_s=times_s, inputs={"spec": spec_path}, warnings=warnings),
        force=force,
        add_files=add_files,
        progress=progress,
    )
    built = SpecBuild(
        out_dir=out_dir,
        model=model,
        validation=folder.validation,
        pictures=pictures,
        times_s=folder.summary.times_s,
        summary=folder.summary,
        warnings=warnings,
    )
    built.register(out_dir, options.map_entry)
    return built


def spec_warnings(spec: Spec) -> list[str]:
    """What a spec's measurements disagree on without being impossible (a door's tape
    readings against its thickness); the model is built all the same."""
    return hinge_tape_warnings(spec) if isinstance(spec, CabinetSpec) else []
