"""A home, or one room of it, as a simulator scene: every object of the map with its model,
at its map pose, its joints at their current states; small objects free; a floor, and
walls on the outline of each room that gives one.
"""

from __future__ import annotations

from pathlib import Path

from articulation.scene import Scene, SceneObject, walls_from_outlines
from homemodel.core.errors import InputError, MapError, ModelError
from homemodel.core.export_summary import SceneFormat
from homemodel.exchange.map_xml import load_map
from homemodel.exchange.simulator import SimulatorExport, export_scene
from semantic_map.hierarchy import SemanticMap
from semantic_map.nodes import Jointed, MapObject, Room


def model_path(map_path: Path, obj: MapObject) -> Path:
    """The model (URDF) of a map object: its `model` reference, relative to the map's folder."""
    if obj.model_ref is None:
        raise InputError(f"{map_path}: object {obj.id!r} has no model (its 'model' attribute is missing)")
    path = (map_path.parent / obj.model_ref).resolve()
    if not path.is_file():
        raise InputError(f"{map_path}: object {obj.id!r}: its model {obj.model_ref!r} does not exist")
    return path


def _scene_object(map_path: Path, smap: SemanticMap, obj: MapObject, *, free: bool) -> SceneObject:
    from homemodel.exchange.urdf.read import load_urdf

    model = load_urdf(model_path(map_path, obj))
    positions = {j.name: j.position for j in obj.joints} if isinstance(obj, Jointed) else {}
    try:
        return SceneObject(
            id=obj.id, model=model, world_from_model=smap.world_from_object(obj.id), joint_positions=positions, free=free
        )
    except ModelError as exc:
        raise InputError(f"{map_path}: object {obj.id!r}: {exc}") from None


def _rooms(map_path: Path, smap: SemanticMap, room_id: str | None) -> list[Room]:
    rooms = smap.apartment.rooms
    if room_id is None:
        return list(rooms)
    chosen = [r for r in rooms if r.id == room_id]
    if not chosen:
        raise InputError(f"{map_path}: no room {room_id!r} (rooms: {', '.join(r.id for r in rooms)})")
    return chosen


def scene_from_map(map_path: Path, *, room_id: str | None = None) -> Scene:
    """The scene of the whole apartment, or of the room `room_id`."""
    return _scene_and_sources(map_path, room_id)[0]


def export_home(
    map_path: Path, out_dir: Path, fmt: SceneFormat, *, room_id: str | None = None, force: bool = False
) -> SimulatorExport:
    """Export the home (or one room) of `map_path` in `fmt` (`SCENE_FORMATS`) to `out_dir`."""
    scene, sources = _scene_and_sources(map_path, room_id)
    return export_scene(scene, out_dir, fmt, force=force, inputs=sources)


def _scene_and_sources(map_path: Path, room_id: str | None) -> tuple[Scene, list[Path]]:
    map_path = Path(map_path)
    try:
        smap = load_map(map_path)
    except MapError as exc:
        raise InputError(str(exc)) from None
    rooms = _rooms(map_path, smap, room_id)
    objects: list[SceneObject] = []
    sources = [map_path]
    for room in rooms:
        for large in room.objects:
            for obj, free in ((large, False), *((small, True) for small in large.small_objects)):
                objects.append(_scene_object(map_path, smap, obj, free=free))
                sources.append(model_path(map_path, obj).parent)
    if not objects:
        where = f"room {room_id!r}" if room_id else "the apartment"
        raise InputError(f"{map_path}: {where} has no objects to export")
    walls = walls_from_outlines([(room.id, room.outline) for room in rooms if room.outline is not None])
    return Scene(name=room_id or smap.apartment.id, objects=objects, floor=True, walls=walls), sources
