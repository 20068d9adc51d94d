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


# --- A folder with the traits of PartNet-Mobility's real models (none can be downloaded here) ---
# Normalised size (1.4 m tall), y up, open sheets in many OBJs per link
# (`textured_objs/original-N.obj`, one `new-N.obj`), several visuals of one link sharing a name,
# <collision>s naming the same sheets, MTLs whose textures lie in `../images/`, the root turned
# by a fixed joint's rpy, no inertials and <limit>s without effort or velocity.
REAL_W, REAL_H, REAL_D = 0.9, 1.4, 0.5  # the body's width (mesh z), height (mesh y), depth (mesh x)
REAL_DRAWER_TRAVEL_M = 0.35
REAL_HINGE = (-0.25, 0.0, 0.0)  # the door's hinge line: mesh y through this point (its left edge)


def _sheet(corner, u, v) -> trimesh.Trimesh:
    """A rectangle (two triangles, open): `corner`, `corner + u`, `corner + u + v`, `corner + v`."""
    import numpy as np

    c, u, v = (np.asarray(a, dtype=float) for a in (corner, u, v))
    return trimesh.Trimesh([c, c + u, c + u + v, c + v], [[0, 1, 2], [0, 2, 3]], process=False)


def _open_box(low, high, open_side: str | None) -> list[trimesh.Trimesh]:
    """The six (or five, one side left open) sheets of an axis-aligned box."""
    (x0, y0, z0), (x1, y1, z1) = low, high
    dx, dy, dz = x1 - x0, y1 - y0, z1 - z0
    sides = {
        "-x": _sheet((x0, y0, z0), (0, dy, 0), (0, 0, dz)),
        "+x": _sheet((x1, y0, z0), (0, 0, dz), (0, dy, 0)),
        "-y": _sheet((x0, y0, z0), (0, 0, dz), (dx, 0, 0)),
        "+y": _sheet((x0, y1, z0), (dx, 0, 0), (0, 0, dz)),
        "-z": _sheet((x0, y0, z0), (dx, 0, 0), (0, dy, 0)),
        "+z": _sheet((x0, y0, z1), (0, dy, 0), (dx, 0, 0)),
    }
    return [sheet for side, sheet in sides.items() if side != open_side]


def _write_obj(path: Path, mesh: trimesh.Trimesh, texture: str | None) -> None:
    """An OBJ as PartNet's: `mtllib`, `usemtl`, `v`, `vt`, `f a/a b/b c/c`."""
    lines = [f"mtllib {path.stem}.mtl", "usemtl material_0"]
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in mesh.vertices]
    lines += [f"vt {u:.3f} {v:.3f}" for u, v in ((0, 0), (1, 0), (1, 1), (0, 1))[: len(mesh.vertices)]]
    lines += ["f " + " ".join(f"{i + 1}/{i % 4 + 1}" for i in face) for face in mesh.faces]
    lines.append("f 1/1 2/2 2/2")  # a zero-area triangle, as real scans and CAD exports hold
    path.write_text("\n".join(lines) + "\n")
    material = ["newmtl material_0", "Kd 0.70 0.55 0.40"] + ([f"map_Kd ../images/{texture}"] if texture else [])
    path.with_suffix(".mtl").write_text("\n".join(material) + "\n")


def write_partnet_real_traits(folder: Path) -> dict[str, list[trimesh.Trimesh]]:
    """Write the folder; returns link name -> its sheets (mesh frame), for the tests' figures."""
    import numpy as np
    from PIL import Image

    folder = Path(folder)
    (folder / "textured_objs").mkdir(parents=True, exist_ok=True)
    (folder / "images").mkdir(exist_ok=True)
    Image.fromarray(np.full((8, 8, 3), (150, 110, 70), np.uint8)).save(folder / "images" / "texture_1.png")
    hw, hh, hd = REAL_W / 2, REAL_H / 2, REAL_D / 2
    # The body: open at the front (-x), a shelf inside; the drawer below, the door above it.
    # The body's five outer sheets in one file (its hull would fill the cavity), a shelf in another.
    body = [trimesh.util.concatenate(_open_box((-hd, -hh, -hw), (hd, hh, hw), "-x"))]
    body.append(_sheet((-hd, 0.0, -hw), (0, 0, REAL_W), (REAL_D, 0, 0)))
    drawer = _open_box((-hd, -hh + 0.02, -hw + 0.02), (hd - 0.02, -0.02, hw - 0.02), "+y")  # open at the top
    handle = trimesh.creation.box(extents=(0.03, 0.03, 0.2))
    handle.apply_translation((-hd - 0.015, -hh / 2, 0.0))
    door = _open_box((-hd - 0.02, 0.0, -hw), (-hd, hh, hw), None)  # a closed panel of six sheets
    links = {"link_2": body, "link_0": drawer + [handle], "link_1": door}
    names = {"link_2": "shelf-1", "link_0": "drawer-2", "link_1": "door-3"}
    visuals: dict[str, list[str]] = {}
    count = 0
    for link, meshes in links.items():
        for mesh in meshes:
            stem = f"original-{count + 1}" if count else "new-0"
            count += 1
            # The door's parts are given in its link frame, at the hinge (PartNet's <origin>s undo it).
            _write_obj(folder / "textured_objs" / f"{stem}.obj", mesh, "texture_1.png" if link == "link_1" else None)
            visuals.setdefault(link, []).append(stem)
    hx, hy, hz = REAL_HINGE

    def parts(link: str, origin: tuple[float, float, float] = (0, 0, 0)) -> str:
        xyz = " ".join(str(v) for v in origin)
        return "".join(
            f'<visual name="{names[link]}"><origin xyz="{xyz}"/><geometry><mesh filename="textured_objs/{stem}.obj"/></geometry></visual>'
            f'<collision><origin xyz="{xyz}"/><geometry><mesh filename="textured_objs/{stem}.obj"/></geometry></collision>'
            for stem in visuals[link]
        )

    urdf = f"""<?xml version="1.0" ?>
<robot name="partnet_real_traits">
	<link name="base"/>
	<link name="link_0">{parts("link_0")}</link>
	<joint name="joint_0" type="prismatic">
		<origin xyz="0 0 0"/>
		<axis xyz="-1 0 0"/>
		<child link="link_0"/>
		<parent link="link_2"/>
		<limit lower="0" upper="{REAL_DRAWER_TRAVEL_M}"/>
	</joint>
	<link name="link_1">{parts("link_1", (-hx, -hy, hw))}</link>
	<joint name="joint_1" type="revolute">
		<origin xyz="{hx} {hy} {-hw}"/>
		<axis xyz="0 -1 0"/>
		<child link="link_1"/>
		<parent link="link_2"/>
		<limit lower="-0.0" upper="1.5707963267948966"/>
	</joint>
	<link name="link_2">{parts("link_2")}</link>
	<joint name="joint_2" type="fixed">
		<origin rpy="1.570796326794897 0 -1.570796326794897" xyz="0 0 0"/>
		<child link="link_2"/>
		<parent link="base"/>
	</joint>
</robot>
"""
    (folder / "mobility.urdf").write_text(urdf)
    (folder / "meta.json").write_text(json.dumps({"model_cat": "StorageFurniture", "model_id": "real_traits"}))
    entries = [
        {"id": 0, "parent": 2, "joint": "slider", "name": "drawer", "parts": [{"id": 2, "name": "drawer"}]},
        {"id": 1, "parent": 2, "joint": "hinge", "name": "door", "parts": [{"id": 3, "name": "door"}]},
        {"id": 2, "parent": -1, "joint": "heavy", "name": "furniture_body", "parts": [{"id": 1, "name": "shelf"}]},
    ]
    (folder / "mobility_v2.json").write_text(json.dumps(entries))
    return links
