"""A PartNet-Mobility-style folder made here (none can be downloaded): a cabinet with one
hinged door and its handle, y-up meshes, its front facing mesh -x (PartNet's front varies),
no inertials and limits without effort or velocity, as PartNet ships them.

Run as a script to (re)write examples/database/partnet_cabinet.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import trimesh

# Mesh frame (y up): depth along x (front at x = -0.2), height along y, width along z.
BODY = ((-0.2, -0.4, -0.3), (0.2, 0.4, 0.3))
DOOR = ((-0.22, -0.38, -0.28), (-0.2, 0.38, 0.28))
HANDLE = ((-0.25, -0.05, 0.2), (-0.22, 0.05, 0.24))
HINGE = (-0.21, 0.0, -0.28)  # the door turns about mesh y through this point
HEIGHT_M, WIDTH_M = 0.8, 0.6


def _box(bounds) -> trimesh.Trimesh:
    (x0, y0, z0), (x1, y1, z1) = bounds
    box = trimesh.creation.box(extents=(x1 - x0, y1 - y0, z1 - z0))
    box.apply_translation(((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2))
    return box


def _visual(name: str, obj: str, xyz: tuple[float, float, float] = (0, 0, 0)) -> str:
    return (
        f'<visual name="{name}"><origin xyz="{xyz[0]} {xyz[1]} {xyz[2]}"/>'
        f'<geometry><mesh filename="textured_objs/{obj}.obj"/></geometry></visual>'
    )


def write_partnet_cabinet(folder: Path, *, model_cat: str = "StorageFurniture") -> Path:
    folder = Path(folder)
    (folder / "textured_objs").mkdir(parents=True, exist_ok=True)
    for name, bounds in (("original-1", BODY), ("original-2", DOOR), ("original-3", HANDLE)):
        _box(bounds).export(folder / "textured_objs" / f"{name}.obj")
    back = tuple(-v for v in HINGE)  # the door's visuals, in its link frame at the hinge
    urdf = f"""<?xml version="1.0"?>
<robot name="partnet_cabinet">
  <link name="base"/>
  <link name="link_1">{_visual("frame-1", "original-1")}</link>
  <joint name="joint_1" type="fixed"><parent link="base"/><child link="link_1"/></joint>
  <link name="link_0">{_visual("door_surface-2", "original-2", back)}{_visual("handle-3", "original-3", back)}</link>
  <joint name="joint_0" type="revolute">
    <origin xyz="{HINGE[0]} {HINGE[1]} {HINGE[2]}"/>
    <axis xyz="0 -1 0"/>
    <parent link="link_1"/><child link="link_0"/>
    <limit lower="0" upper="1.5707963"/>
  </joint>
</robot>
"""
    (folder / "mobility.urdf").write_text(urdf)
    (folder / "meta.json").write_text(json.dumps({"model_cat": model_cat, "model_id": "sample"}))
    parts = [
        {"id": 0, "parent": 1, "joint": "hinge", "name": "door", "parts": [{"id": 2, "name": "door_surface"}, {"id": 3, "name": "handle"}]},
        {"id": 1, "parent": -1, "joint": "heavy", "name": "cabinet_body", "parts": [{"id": 1, "name": "frame"}]},
    ]
    (folder / "mobility_v2.json").write_text(json.dumps(parts, indent=1))
    return folder


if __name__ == "__main__":
    write_partnet_cabinet(Path(sys.argv[1]) if len(sys.argv) > 1 else Path("examples/database/partnet_cabinet"))
