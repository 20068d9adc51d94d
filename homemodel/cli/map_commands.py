"""`homemodel map show|find|add|validate MAP.xml ...`: the hierarchical semantic map.

`find` replays the request walk of D3.1 section 6.2.2 ("bring me the blue cup"): the path
from the root to the object, its parent, and the parking positions to visit one at a time.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import typer

from homemodel.cli.errors import exit_on_error
from homemodel.cli.map_flags import echo_registration
from homemodel.cli.option_fields import field_option, from_options

if TYPE_CHECKING:
    from semantic_map import MapObject, Node, ParkingPosition, SemanticMap

map_app = typer.Typer(no_args_is_help=True, help="Show, query, extend and validate a hierarchical semantic map; update it from a depth camera's view.")

MAP_ARGUMENT = typer.Argument(..., metavar="MAP.xml", help="semantic map file")
IMPORT = "homemodel.model_folder.asset_import:ImportOptions"  # `map add`'s import of a raw asset
REPAIR = "homemodel.model_folder.repair:RepairOptions"


def key_values(items: list[str], option: str) -> dict[str, str]:
    pairs = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise typer.BadParameter(f"{item!r} is not key=value", param_hint=option)
        pairs[key] = value
    return pairs


def _parking_list(items: list[str]) -> list[ParkingPosition]:
    """`--parking "x y yaw"` (or "NAME=x y yaw"), robot base poses on the floor; the first is the default."""
    from homemodel.core.transforms import transform_from_xyz_rpy
    from semantic_map import ParkingPosition

    positions = []
    for index, item in enumerate(items, start=1):
        name, sep, numbers = item.rpartition("=")
        try:
            x, y, yaw = (float(v) for v in numbers.split())
        except ValueError:
            raise typer.BadParameter(f"{item!r} is not 'x y yaw' (metres, radians)", param_hint="--parking") from None
        world_from_base = transform_from_xyz_rpy((x, y, 0.0), (0.0, 0.0, yaw))
        positions.append(
            ParkingPosition(name=name if sep else f"parking_{index}", world_from_base=world_from_base, default=index == 1)
        )
    return positions


def _describe(node: Node) -> str:
    from semantic_map import (
        Apartment,
        LargeArticulatedObject,
        LargeObject,
        Room,
        SmallObject,
    )

    if isinstance(node, Apartment | Room):
        return f"{node.id} ({node.name})"
    if isinstance(node, SmallObject):
        text = f"{node.id}: {node.type}, {node.relation} {node.parent}"
    elif isinstance(node, LargeArticulatedObject):
        joints = ", ".join(f"{j.name} {j.type} at {j.position:g}" for j in node.joints)
        text = f"{node.id}: {node.type}, joints {joints}"
    elif isinstance(node, LargeObject):
        text = f"{node.id}: {node.type}"
    else:
        return f"{node.id}: {node.type} switch"
    properties = ", ".join(f"{k}={v}" for k, v in sorted(node.properties.items()))
    return f"{text} [{properties}]" if properties else text


def _parking_text(p: ParkingPosition) -> str:
    x, y, _ = p.world_from_base.xyz
    yaw = p.world_from_base.rpy[2]
    return f"{p.name}{' (default)' if p.default else ''}: x={x:.3f} m, y={y:.3f} m, yaw={yaw:.3f} rad"


@map_app.command()
def show(map_path: Path = MAP_ARGUMENT) -> None:
    """Print the map as a tree: apartment > rooms > objects."""
    from rich.console import Console
    from rich.markup import escape
    from rich.tree import Tree

    from homemodel.exchange.map_xml import load_map

    with exit_on_error():
        smap = load_map(map_path)
    root = Tree(escape(_describe(smap.apartment)))
    for room in smap.apartment.rooms:
        branch = root.add(escape(_describe(room)))
        for switch in room.switches:
            branch.add(escape(_describe(switch)))
        for large in room.objects:
            leaf = branch.add(escape(_describe(large)))
            for small in large.small_objects:
                leaf.add(escape(_describe(small)))
    Console().print(root)


def _print_walk(smap: SemanticMap, obj: MapObject) -> None:
    from semantic_map import SmallObject

    parent = smap.parent(obj.id)
    typer.echo(f"path: {' > '.join(smap.path_to(obj.id))}")
    typer.echo(f"parent: {_describe(parent)}")
    # The robot goes to a small object's parent; a large object has parking positions of its own.
    goal = parent.id if isinstance(obj, SmallObject) else obj.id
    typer.echo(f"parking positions of {goal}:")
    for index, p in enumerate(smap.parking_positions(goal), start=1):
        typer.echo(f"  {index}. {_parking_text(p)}")


@map_app.command()
def find(
    map_path: Path = MAP_ARGUMENT,
    object_type: str | None = typer.Option(None, "--type", help="object type, e.g. cup"),
    properties: list[str] = typer.Option([], "--property", help="key=value, e.g. colour=blue (repeatable)"),
) -> None:
    """Find objects by type and properties; print the path to each, its parent and where to park."""
    from homemodel.exchange.map_xml import load_map

    wanted = key_values(properties, "--property")
    with exit_on_error():
        smap = load_map(map_path)
        matches = smap.find(type=object_type, properties=wanted)
        if not matches:
            criteria = " ".join([*([f"type={object_type}"] if object_type else []), *(f"{k}={v}" for k, v in wanted.items())])
            typer.echo(f"no object in {map_path} matches {criteria or 'anything'}", err=True)
            raise typer.Exit(1)
        for index, obj in enumerate(matches):
            if index:
                typer.echo("")
            _print_walk(smap, obj)


@map_app.command()
@from_options
def add(
    map_path: Path = MAP_ARGUMENT,
    model_dir: Path = typer.Argument(..., metavar="MODEL", help="model folder (model.urdf or mobility.urdf), a .urdf file, or db:ID with --db"),
    object_id: str = typer.Option(..., "--id", help="id of the new object"),
    parent_id: str = typer.Option(..., "--parent", help="a room (large object) or a large object (small object)"),
    relation: str | None = field_option(
        "homemodel.model_folder.map_entry:MapEntry.relation", help="small objects: on, in or under (default: on)"
    ),
    xyz: tuple[float, float, float] = typer.Option((0.0, 0.0, 0.0), "--xyz", help="position in the parent's frame (m)"),
    rpy: tuple[float, float, float] = typer.Option((0.0, 0.0, 0.0), "--rpy", help="roll pitch yaw in the parent's frame (rad)"),
    parking: list[str] = typer.Option(
        [], "--parking", help="large objects: robot base 'x y yaw' or 'NAME=x y yaw' in the map frame; the first is the default"
    ),
    properties: list[str] = typer.Option([], "--property", help="key=value over the model's properties (repeatable)"),
    graspable: bool | None = typer.Option(None, "--graspable/--not-graspable", help="graspable or not (default: small objects are, large ones are not)"),
    out: Path | None = typer.Option(None, "--out", help="write the extended map here instead of over MAP.xml"),
    force: bool = typer.Option(False, "--force", help="replace an existing --out file"),
    db: Path | None = typer.Option(None, "--db", help="the model database a db:ID model refers to"),
    package_paths: list[Path] = typer.Option(
        [], "--package-path", help="where a ROS URDF's package://NAME/... meshes find package NAME (repeatable)"
    ),
    object_type: str | None = typer.Option(None, "--type", help="the object's type, e.g. cup (default: the model's category)"),
    import_first: bool = typer.Option(
        False, "--import", help="import MODEL into a model folder of its own, its gaps repaired (always for a mesh file: glb, gltf, obj, stl, ply, dae)"
    ),
    import_dir: Path | None = typer.Option(None, "--model-dir", help="with an import: the model folder to write (default: models/ID beside the map)"),
    units: str = field_option(f"{IMPORT}.units", help="with an import: a mesh file's unit (auto: metres; glTF is metres, a DAE says its own)"),
    up_axis: str = field_option(f"{IMPORT}.up_axis", help="with an import: a mesh file's up axis (auto: y for glTF, z otherwise)"),
    density_kg_m3: float = field_option(f"{REPAIR}.density_kg_m3", min=1e-3, help="with an import: the mass of a link without one, from its closed volume at this density"),
) -> None:
    """Register the model MODEL under PARENT_ID and save the map atomically.

    A raw asset (a downloaded glb or OBJ, or a ROS package's URDF with --import) is imported first, as `add_asset` says.
    The repairs made are printed."""
    from homemodel.app.database.queries import resolve_model_ref
    from homemodel.core.transforms import transform_from_xyz_rpy
    from homemodel.exchange.urdf.read import MESH_FILE_SUFFIXES
    from homemodel.model_folder.asset_import import ImportOptions
    from homemodel.model_folder.map_entry import MapEntry, add_asset, add_model_folder
    from homemodel.model_folder.repair import RepairOptions

    with exit_on_error():
        model = resolve_model_ref(model_dir, db)
        entry = MapEntry(
            map_path=map_path,
            object_id=object_id,
            parent_id=parent_id,
            relation=relation,
            parent_from_object=transform_from_xyz_rpy(xyz, rpy),
            parking_positions=_parking_list(parking),
            category=object_type or model.category,  # a db:ID brings the manifest's category and properties
            properties={**model.properties, **key_values(properties, "--property")} or None,
            graspable=graspable,
            out_path=out,
            package_paths=package_paths,
        )
        if import_first or model.folder.suffix.lower() in MESH_FILE_SUFFIXES:
            options = ImportOptions(package_paths=package_paths, units=units, up_axis=up_axis)
            registration = add_asset(
                model.folder, entry, model_dir=import_dir, options=options,
                repair_options=RepairOptions(density_kg_m3=density_kg_m3), force=force,
            )  # fmt: skip
        else:
            registration = add_model_folder(model.folder, entry, force=force)
    echo_registration(registration)
    if registration.model_dir is not None:
        typer.echo(f"imported into {registration.model_dir}:")
        for said in registration.repairs:
            typer.echo(f"  {said}")


@map_app.command()
def validate(map_path: Path = MAP_ARGUMENT) -> None:
    """Check a map against the schema and the map's own rules."""
    from homemodel.exchange.map_xml import load_map

    with exit_on_error():
        smap = load_map(map_path)
    count = sum(1 for _ in smap.objects())
    typer.echo(f"{map_path}: valid ({len(smap.apartment.rooms)} rooms, {count} objects)")


@map_app.command("export")
@from_options
def export_(
    map_path: Path = MAP_ARGUMENT,
    fmt: str = field_option("homemodel.exchange.home_scene:export_home.fmt", "--format", help="urdf (pybullet, ROS), mjcf (MuJoCo), sdf (Gazebo), usd (Isaac), glb (viewers)"),
    out: Path = typer.Option(..., "--out", help="output folder"),
    room: str | None = typer.Option(None, "--room", help="export only this room (its id), e.g. kitchen"),
    force: bool = typer.Option(False, "--force", help="replace a non-empty output folder"),
) -> None:
    """The whole home (or one room) as one simulator scene.

    Every object at its map pose and joint state, small objects free, a floor, and walls on rooms with an outline."""
    from homemodel.exchange.home_scene import export_home

    with exit_on_error():
        result = export_home(map_path, out, fmt, room_id=room, force=force)
    summary = result.summary
    free = sum(1 for o in summary.objects if o.free)
    joints = sum(len(o.joints) for o in summary.objects)
    typer.echo(
        f"{result.file}: {len(summary.objects)} objects ({free} free), {joints} joints, "
        f"{summary.walls} walls, {summary.mesh_files} mesh files, {summary.times_s['export']:.2f} s"
    )
