"""Adding a model folder to a map file: what `homemodel map add` does, and the pipelines
when given a map (`turntable.reconstruct`, `photogrammetry.reconstruct`)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from homemodel.core.errors import MapError, OutputExistsError
from semantic_map.hierarchy import SemanticMap
from semantic_map.nodes import MapObject, ParkingPosition, Relation
from semantic_map.xml_io import load_map, save_map


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
    # it and before ROS_PACKAGE_PATH (see articulation.mesh_paths).
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


def add_model_folder(model_dir: Path, entry: MapEntry, *, force: bool = False) -> Registration:
    """Register the model in `model_dir` (a model folder or a .urdf file) as `entry` says and
    save the map atomically; `force` replaces an existing `entry.out_path`.

    The map refers to the model's URDF by a path relative to the map's folder, so a map and
    its models move together.
    """
    from articulation import urdf_import

    out_path = Path(entry.out_path or entry.map_path)
    entry.check(force=force)
    urdf = urdf_import.find_urdf(Path(model_dir))
    smap = entry.load()
    model = urdf_import.load_urdf(urdf, package_paths=entry.package_paths)
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
