"""Adding a model folder to a map file: what `homemodel map add` does, and the pipelines
when given a map (`turntable.reconstruct`, `photogrammetry.reconstruct`); and a raw asset
(a downloaded glb or OBJ, a ROS package's URDF) imported into a model folder first."""

from __future__ import annotations

import dataclasses
import os
import shutil
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from homemodel.core.errors import MapError, ModelError, OutputExistsError
from homemodel.exchange.map_xml import load_map, save_map
from semantic_map.hierarchy import SemanticMap
from semantic_map.nodes import MapObject, ParkingPosition, Relation

if TYPE_CHECKING:
    from homemodel.model_folder.asset_import import ImportOptions
    from homemodel.model_folder.repair import RepairOptions

IMPORTED_MODELS_DIR = "models"  # beside the map: an imported asset's model folder, models/<object id>/


@dataclass(kw_only=True)
class MapEntry:
    """Where a model goes in a map file, and what the map says of it beyond the model."""

    map_path: Path
    object_id: str
    parent_id: str  # a room (the model becomes a large object) or a large object (a small one)
    relation: Relation | None = None  # small objects: "on" (default), "in" or "under"
    parent_from_object: np.ndarray = field(default_factory=lambda: np.eye(4))
    parking_positions: Sequence[ParkingPosition] = ()  # large objects; one is the default
    category: str | None = None  # the object's type instead of the model's category
    properties: dict[str, str] | None = None  # merged over the model's
    graspable: bool | None = None  # default: small objects are, large ones are not
    out_path: Path | None = None  # write the extended map here; None: over `map_path`
    # Where a ROS URDF's package://NAME/... meshes find package NAME, after the package holding
    # it and before ROS_PACKAGE_PATH (see homemodel.exchange.urdf.mesh_paths).
    package_paths: Sequence[Path] = ()

    def check(self, *, force: bool = False) -> None:
        """Load the map, find the parent and make sure the id is free now, so a bad map, parent
        or id fails before any work (and before any output is written)."""
        smap = self.load()
        out_path = Path(self.out_path or self.map_path)
        if self.out_path is not None and out_path.exists() and not force:
            raise OutputExistsError(f"{out_path}: exists (use --force to replace it)")
        try:
            smap.node(self.parent_id)
            smap.check_new_id(self.object_id)
        except MapError as exc:
            raise MapError(f"{self.map_path}: {exc}") from None

    def load(self) -> SemanticMap:
        try:
            return load_map(self.map_path)
        except MapError as exc:
            raise MapError(exc if str(self.map_path) in str(exc) else f"{self.map_path}: {exc}") from None


@dataclass(kw_only=True)
class Registration:
    """A model added to a map file: the new object, its path from the apartment, the file."""

    node: MapObject
    path: list[str]
    map_path: Path
    model_dir: Path | None = None  # the model folder an asset was imported into
    repairs: list[str] = field(default_factory=list)  # what that import decided and repaired


def add_model_folder(model_dir: Path, entry: MapEntry, *, force: bool = False) -> Registration:
    """Register the model in `model_dir` (a model folder or a .urdf file) as `entry` says and
    save the map atomically; `force` replaces an existing `entry.out_path`.

    The map refers to the model's URDF by a path relative to the map's folder, so a map and
    its models move together.
    """
    from homemodel.exchange.urdf import read as urdf_read

    out_path = Path(entry.out_path or entry.map_path)
    entry.check(force=force)
    urdf = urdf_read.find_urdf(Path(model_dir))
    smap = entry.load()
    model = urdf_read.load_urdf(urdf, package_paths=entry.package_paths)
    if entry.category:
        model.category = entry.category
    try:
        node = smap.register_model(
            model,
            object_id=entry.object_id,
            parent_id=entry.parent_id,
            relation=entry.relation,
            parent_from_object=entry.parent_from_object,
            model_ref=Path(os.path.relpath(urdf.resolve(), out_path.resolve().parent)).as_posix(),
            parking_positions=entry.parking_positions,
            graspable=entry.graspable,
            properties=entry.properties,
        )
    except MapError as exc:
        raise MapError(f"{entry.map_path}: {exc}") from None
    save_map(smap, out_path)
    return Registration(node=node, path=smap.path_to(node.id), map_path=out_path)


def add_asset(
    asset: Path,
    entry: MapEntry,
    *,
    model_dir: Path | None = None,
    options: ImportOptions | None = None,
    repair_options: RepairOptions | None = None,
    force: bool = False,
) -> Registration:
    """Import a raw asset (one mesh file of a small object, a URDF such as a ROS description
    package's, a PartNet-Mobility folder) into a model folder of its own, its gaps repaired as
    `repair_options` state (the defaults otherwise, each repair listed), and register that
    folder: a self-contained model the map can keep whatever happens to the asset. The
    folder is `model_dir`, by default models/<object id>/ beside the map written. Refused,
    with nothing written, when the imported model fails the validation gate."""
    from homemodel.model_folder.asset_import import import_model_folder
    from homemodel.model_folder.repair import RepairOptions

    entry.check(force=force)
    out_path = Path(entry.out_path or entry.map_path)
    model_dir = Path(model_dir) if model_dir is not None else out_path.parent / IMPORTED_MODELS_DIR / entry.object_id
    if model_dir.exists() and not force and (model_dir.is_file() or any(model_dir.iterdir())):
        raise OutputExistsError(f"{model_dir}: exists (give another --model-dir, or --force to replace it)")
    done = import_model_folder(
        asset, model_dir, name=entry.object_id, options=options, repair_options=repair_options or RepairOptions(), force=True
    )
    try:
        if not done.folder.valid:
            failed = "; ".join(f"{c.name}: {c.detail}" for c in done.folder.validation.checks if not c.passed)
            raise ModelError(f"{asset}: imported, it fails the validation gate: {failed}")
        # Its meshes are now in the folder: no package paths are needed to read it.
        registration = add_model_folder(model_dir, dataclasses.replace(entry, package_paths=()), force=force)
    except BaseException:
        shutil.rmtree(model_dir, ignore_errors=True)
        raise
    registration.model_dir = model_dir
    registration.repairs = done.repairs
    return registration
