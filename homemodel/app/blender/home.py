"""A whole home traded with the Blender extension: a map as a home document plus one model
document per object, and back.

Home document (`home.json`):
    format: homemodel.blender-home/1
    apartment: {id, name}
    rooms: [{id, name, point_cloud}]
    switches: [{id, room, type, world_from_switch}]
    objects: [{id, room, parent, relation, parent_from_object, model, parking, joint_positions,
               properties}]  # large objects first, each before the small ones it holds
`model` is the model document's path relative to home.json; `parent` is the room for a large
object; `parking` entries are {name, world_from_base, default}.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from homemodel.app.blender.model_document import model_document, model_from_document, spec_of_model_folder
from homemodel.core.atomic import atomic_dir, write_json
from homemodel.core.errors import InputError
from homemodel.core.home_summary import object_row, write_home_summary
from homemodel.exchange.blender_document import matrix_list, read_document

HOME_FORMAT = "homemodel.blender-home/1"


def describe_map(map_path: Path, out_dir: Path, *, force: bool = False) -> Path:
    """Write `out_dir/home.json` and `out_dir/models/<id>.json` for the map at `map_path`."""
    from homemodel.exchange.map_xml import load_map
    from homemodel.exchange.urdf.read import load_urdf
    from semantic_map import LargeObject

    map_path = Path(map_path)
    smap = load_map(map_path)
    objects: list[dict[str, Any]] = []
    with atomic_dir(Path(out_dir), force=force, inputs=[map_path]) as tmp:
        for room in smap.apartment.rooms:
            for large in room.objects:
                for obj in [large, *large.small_objects]:
                    if obj.model_ref is None:
                        raise InputError(f"{map_path}: object {obj.id!r} has no model to import (no model_ref)")
                    urdf = map_path.parent / obj.model_ref
                    write_json(tmp / "models" / f"{obj.id}.json", model_document(load_urdf(urdf), spec=spec_of_model_folder(urdf.parent)))
                    is_large = isinstance(obj, LargeObject)
                    objects.append(
                        {
                            "id": obj.id,
                            "room": room.id,
                            "parent": room.id if is_large else obj.parent,
                            "relation": None if is_large else obj.relation,
                            "parent_from_object": matrix_list(
                                obj.world_from_object.matrix() if is_large else obj.parent_from_object.matrix()
                            ),
                            "model": f"models/{obj.id}.json",
                            "parking": [
                                {"name": p.name, "world_from_base": matrix_list(p.world_from_base.matrix()), "default": p.default}
                                for p in (obj.parking_positions if is_large else [])
                            ],
                            "joint_positions": {j.name: j.position for j in getattr(obj, "joints", [])},
                            "properties": dict(obj.properties),
                        }
                    )
        write_json(
            tmp / "home.json",
            {
                "format": HOME_FORMAT,
                "apartment": {"id": smap.apartment.id, "name": smap.apartment.name},
                "rooms": [{"id": r.id, "name": r.name, "point_cloud": r.point_cloud} for r in smap.apartment.rooms],
                "switches": [
                    {"id": sw.id, "room": r.id, "type": sw.type, "world_from_switch": matrix_list(sw.world_from_switch.matrix())}
                    for r in smap.apartment.rooms
                    for sw in r.switches
                ],
                "objects": objects,
            },
        )
    return Path(out_dir) / "home.json"


@dataclass(kw_only=True)
class HomeExport:
    map_path: Path
    failed: dict[str, list[str]]  # object id -> the gate's failed checks

    @property
    def ok(self) -> bool:
        return not self.failed


def _field(doc: dict, key: str, where: str, source: Path) -> Any:
    if not isinstance(doc, dict) or key not in doc:
        raise InputError(f"{source}: {where}: missing {key!r}")
    return doc[key]


def export_home(home_path: Path, out_dir: Path, *, force: bool = False) -> HomeExport:
    """Write `out_dir/map.xml` (checked against the XSD on save), `out_dir/models/<id>/`
    (URDF, glb, meshes, summary.json with the gate's report) for every object of the home
    document, and `out_dir/home_summary.json` (as `homemodel build` writes it). Atomic: on any
    error `out_dir` is left as it was."""
    from homemodel.exchange.map_xml import save_map
    from homemodel.model_folder.write import PipelineSummary, write_model_folder
    from semantic_map import ParkingPosition, SemanticMap

    home_path = Path(home_path)
    home = read_document(home_path)
    if not isinstance(home, dict) or home.get("format") != HOME_FORMAT:
        raise InputError(f"{home_path}: format: expected {HOME_FORMAT!r}")
    apartment = _field(home, "apartment", "home", home_path)
    smap = SemanticMap.new(apartment_id=_field(apartment, "id", "apartment", home_path), name=apartment.get("name") or apartment["id"])
    for i, room in enumerate(_field(home, "rooms", "home", home_path)):
        smap.add_room(room_id=_field(room, "id", f"rooms.{i}", home_path), name=room.get("name") or room["id"], point_cloud=room.get("point_cloud"))
    for i, switch in enumerate(home.get("switches", [])):
        smap.add_switch(
            room_id=_field(switch, "room", f"switches.{i}", home_path),
            switch_id=_field(switch, "id", f"switches.{i}", home_path),
            type=_field(switch, "type", f"switches.{i}", home_path),
            world_from_switch=np.asarray(_field(switch, "world_from_switch", f"switches.{i}", home_path), dtype=float),
        )
    failed: dict[str, list[str]] = {}
    rows = []
    with atomic_dir(Path(out_dir), force=force, inputs=[home_path]) as tmp:
        for i, obj in enumerate(_field(home, "objects", "home", home_path)):
            where = f"objects.{i}"
            object_id = _field(obj, "id", where, home_path)
            document = _field(obj, "model", where, home_path)
            parent = _field(obj, "parent", where, home_path)
            model_file = home_path.parent / document
            model = model_from_document(read_document(model_file), str(model_file))
            model.name = object_id
            written = write_model_folder(
                model, tmp / "models" / object_id, PipelineSummary(source="blender", inputs={"document": model_file})
            )
            bad = written.summary.gate.failed_checks
            if bad:
                failed[object_id] = bad
            parking = [
                ParkingPosition(name=p["name"], world_from_base=np.asarray(p["world_from_base"], dtype=float), default=bool(p.get("default")))
                for p in obj.get("parking", [])
            ]
            if parking and not any(p.default for p in parking):
                parking[0].default = True
            smap.register_model(
                model,
                object_id=object_id,
                parent_id=parent,
                relation=obj.get("relation"),
                parent_from_object=np.asarray(obj.get("parent_from_object", np.eye(4)), dtype=float),
                model_ref=f"models/{object_id}/model.urdf",
                parking_positions=parking,
                properties=obj.get("properties") or None,
                joint_positions=obj.get("joint_positions") or None,
            )
            rows.append(object_row(written.summary, id=object_id, spec=document, parent=parent, grasp_points=len(model.grasp_points)))
        save_map(smap, tmp / "map.xml")
        write_home_summary(tmp, rows)
    return HomeExport(map_path=Path(out_dir) / "map.xml", failed=failed)
