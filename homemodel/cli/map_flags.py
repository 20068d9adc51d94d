"""The flags a reconstruction command (turntable, photogrammetry, completion) takes to register
its model into a semantic map: `--map --parent --id --xyz`. They live apart from `homemodel
map`'s commands, whose options are read from the sources of six modules when imported: a
completion query paid that for these four flags (0.011 CPU-s)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import typer

from homemodel.cli.option_fields import old_spellings

if TYPE_CHECKING:
    from homemodel.model_folder.map_entry import MapEntry, Registration

# A reconstruction command's flags for `map_entry_from_flags`.
MAP_OPTION = typer.Option(None, "--map", metavar="MAP.xml", help="register the model into this semantic map")
PARENT_OPTION = old_spellings(
    typer.Option(None, "--parent", help="with --map: a room, or the large object the model stands on"), "--room"
)
ID_OPTION = typer.Option(None, "--id", help="with --map: the object's id (default: the model's name)")
XYZ_OPTION = typer.Option((0.0, 0.0, 0.0), "--xyz", help="with --map: position in the parent's frame (m)")


def map_entry_from_flags(
    map_path: Path | None, parent_id: str | None, object_id: str, xyz: tuple[float, float, float]
) -> MapEntry | None:
    """Where a reconstruction command's `--map --parent --id --xyz` register its model, or None
    without `--map`."""
    from homemodel.core.errors import InputError

    if (map_path is None) != (parent_id is None):
        raise InputError("--map and --parent go together (the parent: the room, or large object, the object belongs to)")
    if map_path is None:
        return None
    from homemodel.core.transforms import transform_from_xyz_rpy
    from homemodel.model_folder.map_entry import MapEntry

    return MapEntry(
        map_path=map_path,
        object_id=object_id,
        parent_id=parent_id,
        parent_from_object=transform_from_xyz_rpy(xyz, (0.0, 0.0, 0.0)),
    )


def echo_registration(registration: Registration) -> None:
    """The line `map add`, and the pipelines given --map, print for a model added to a map."""
    node = registration.node
    typer.echo(f"added {node.id} ({node.type}) at {' > '.join(registration.path)} to {registration.map_path}")
