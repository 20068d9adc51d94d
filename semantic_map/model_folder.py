"""Adding a model folder to a map file: what `homemodel map add` does, and the pipelines
when given a map (`turntable.reconstruct`, `photogrammetry.reconstruct`)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from homemodel.core.errors import OutputExistsError
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
    properties: dict[str, str] | None = None  # merged over the model's
    graspable: bool | None = None  # default: small objects are, large ones are not
    out_path: Path | None = None  # write the extended map here; None: over `map_path`

    def check(self) -> None:
        """Load the map and find the parent now, so a bad map or parent fails before any work."""
        load_map(self.map_path).node(self.parent_id)


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
    if entry.out_path is not None and out_path.exists() and not force:
        raise OutputExistsError(f"{out_path}: exists (use --force to replace it)")
    urdf = urdf_import.find_urdf(Path(model_dir))
    smap = load_map(entry.map_path)
    node = smap.register_model(
        urdf_import.load_urdf(urdf),
        object_id=entry.object_id,
        parent_id=entry.parent_id,
        relation=entry.relation,
        parent_from_object=entry.parent_from_object,
        model_ref=Path(os.path.relpath(urdf.resolve(), out_path.resolve().parent)).as_posix(),
        parking_positions=entry.parking_positions,
        graspable=entry.graspable,
        properties=entry.properties,
    )
    save_map(smap, out_path)
    return Registration(node=node, path=smap.path_to(node.id), map_path=out_path)
