"""Import a PartNet-Mobility model folder (`mobility.urdf`, `meta.json`, `mobility_v2.json`)
into homemodel's conventions: its category, its handles as grasp points, and its frame
turned so that the model stands on the floor (z up, lowest point at z = 0) facing +x.

PartNet-Mobility's meshes are y-up; the joints from the root (`base`) usually carry the
rotation that stands them up, but not always, and the side an object's front faces varies
from model to model. So the up axis is taken as mesh +y seen through the root joints'
rotation, and the front as the horizontal direction from the body's centre to its handles
(the side of the bounding box the handles lie on; else the drawers' opening direction; else
mesh +z).
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from articulation.model import GraspPoint, Model
from articulation.reframe import reframed
from homemodel.core.errors import InputError
from homemodel.core.input_files import read_bounded
from homemodel.exchange.urdf.read import load_urdf

META_FILE = "meta.json"
PARTS_FILE = "mobility_v2.json"
MAX_JSON_BYTES = 16 * 1024 * 1024
# PartNet-Mobility's `model_cat` names -> homemodel's categories (the modeller's kinds).
CATEGORIES = {
    "StorageFurniture": "cupboard",
    "Refrigerator": "fridge",
    "Microwave": "microwave",
    "Oven": "oven",
    "Dishwasher": "dishwasher",
    "WashingMachine": "washing_machine",
    "Table": "table",
    "Chair": "chair",
    "Bottle": "bottle",
    "Box": "box",
    "Bucket": "bucket",
    "Door": "door",
    "Window": "window",
    "Mug": "mug",
    "Cup": "cup",
}
_HANDLE = re.compile(r"handle|knob", re.IGNORECASE)


@dataclass(kw_only=True)
class PartNetImport:
    model: Model
    category_source: str  # meta.json's model_cat
    front_from: str  # "handles", "drawers" or "default": what decided the front


def is_partnet_folder(folder: Path) -> bool:
    folder = Path(folder)
    return (folder / "mobility.urdf").is_file() and (folder / META_FILE).is_file()


def _read_json(path: Path) -> object:
    try:
        return json.loads(read_bounded(path, MAX_JSON_BYTES))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not valid JSON: {exc}") from None


def category_from_meta(folder: Path) -> tuple[str, str]:
    """(homemodel category, PartNet's model_cat) from meta.json."""
    meta = _read_json(Path(folder) / META_FILE)
    model_cat = meta.get("model_cat") if isinstance(meta, dict) else None
    if not isinstance(model_cat, str) or not model_cat:
        raise InputError(f"{Path(folder) / META_FILE}: no 'model_cat' string")
    snake = re.sub(r"(?<!^)(?=[A-Z])", "_", model_cat).lower()
    return CATEGORIES.get(model_cat, snake), model_cat


def handle_parts(folder: Path) -> dict[str, set[str]]:
    """Link name -> names of its visuals that are handles, from mobility_v2.json's parts
    (`link_<id>` holds the parts of entry `id`; PartNet names a part's visual `<name>-<id>`)."""
    path = Path(folder) / PARTS_FILE
    if not path.is_file():
        return {}
    entries = _read_json(path)
    if not isinstance(entries, list):
        raise InputError(f"{path}: expected a list of parts")
    handles: dict[str, set[str]] = {}
    for entry in entries:
        if not isinstance(entry, dict) or "id" not in entry:
            raise InputError(f"{path}: every entry needs an 'id'")
        for part in entry.get("parts") or []:
            if isinstance(part, dict) and _HANDLE.search(str(part.get("name", ""))):
                handles.setdefault(f"link_{entry['id']}", set()).add(f"{part['name']}-{part.get('id')}")
    return handles


def _handle_meshes(model: Model, parts: dict[str, set[str]]) -> dict[str, list[np.ndarray]]:
    """Link -> vertex arrays (link frame) of its handles: the visuals mobility_v2.json names,
    or every visual of a link whose own name says it is a handle."""
    found: dict[str, list[np.ndarray]] = {}
    for link in model.links:
        named = parts.get(link.name, set())
        whole_link = bool(_HANDLE.search(link.name))
        for visual in link.visuals:
            # A visual named `handle-3` may have been split per material into `handle-3_<part>`.
            if whole_link or any(visual.name == n or visual.name.startswith(f"{n}_") for n in named):
                points = visual.mesh.vertices @ visual.link_from_visual[:3, :3].T + visual.link_from_visual[:3, 3]
                found.setdefault(link.name, []).append(points)
    return found


def _up_axis(model: Model) -> np.ndarray:
    """Mesh +y (PartNet's up) in the root frame: through the rotation of the root's joints."""
    root = model.root_link
    rotations = [j.parent_from_joint[:3, :3] for j in model.joints if j.parent == root]
    up = rotations[0] @ [0.0, 1.0, 0.0] if rotations else np.array([0.0, 1.0, 0.0])
    return _snapped(up)


def _snapped(direction: np.ndarray) -> np.ndarray:
    """The coordinate axis (with sign) nearest `direction`."""
    axis = np.zeros(3)
    i = int(np.argmax(np.abs(direction)))
    axis[i] = np.sign(direction[i])
    return axis


def _horizontal(direction: np.ndarray, up: np.ndarray) -> np.ndarray | None:
    flat = direction - (direction @ up) * up
    return None if np.linalg.norm(flat) < 1e-9 else _snapped(flat)


def _front_axis(model: Model, up: np.ndarray, handles_world: list[np.ndarray]) -> tuple[np.ndarray, str]:
    if handles_world:
        # Handles stand out of the front: the side of the bounding box their centre lies nearest.
        low, high = model.world_mesh().bounds
        centre = np.mean(np.vstack(handles_world), axis=0)
        sides = [(abs(face[i] - centre[i]), sign * np.eye(3)[i]) for i in range(3) if abs(up[i]) < 0.5
                 for face, sign in ((high, 1.0), (low, -1.0))]  # fmt: skip
        return min(sides, key=lambda side: side[0])[1], "handles"
    world_from_links = model.world_from_links()
    for joint in model.joints:
        if joint.type == "prismatic" and joint.limits is not None and joint.limits.upper > 0:
            axis_world = world_from_links[joint.parent] @ joint.parent_from_joint
            front = _horizontal(axis_world[:3, :3] @ joint.axis, up)
            if front is not None:
                return front, "drawers"
    root = model.root_link
    rotations = [j.parent_from_joint[:3, :3] for j in model.joints if j.parent == root]
    mesh_z = rotations[0] @ [0.0, 0.0, 1.0] if rotations else np.array([0.0, 0.0, 1.0])
    return _snapped(mesh_z), "default"


def import_partnet(folder: Path) -> PartNetImport:
    """The PartNet-Mobility model in `folder`, in homemodel's frame, with its category and
    a grasp point (kind "handle", x pointing out of the front) at the centre of each handle."""
    folder = Path(folder)
    model = load_urdf(folder / "mobility.urdf")
    model.category, model_cat = category_from_meta(folder)
    model.properties = {**model.properties, "partnet_category": model_cat}
    handles = _handle_meshes(model, handle_parts(folder))
    world_from_links = model.world_from_links()
    handles_world = [
        pts @ world_from_links[link][:3, :3].T + world_from_links[link][:3, 3] for link, parts in handles.items() for pts in parts
    ]
    up = _up_axis(model)
    front, front_from = _front_axis(model, up, handles_world)
    # new_from_old: front -> +x, up -> +z (a proper rotation: the third axis is their cross product).
    rotation = np.vstack([front, np.cross(up, front), up])
    turned = np.eye(4)
    turned[:3, :3] = rotation
    bounds = model.world_mesh().copy().apply_transform(turned).bounds
    turned[:3, 3] = -np.array([(bounds[0][0] + bounds[1][0]) / 2, (bounds[0][1] + bounds[1][1]) / 2, bounds[0][2]])
    grasp_points = []
    for link, parts in handles.items():
        for index, points in enumerate(parts):
            # The grasp frame's x points out of the front (+x of the new frame) at rest.
            link_from_grasp = np.eye(4)
            link_from_grasp[:3, :3] = world_from_links[link][:3, :3].T @ rotation.T
            link_from_grasp[:3, 3] = points.mean(axis=0)
            grasp_points.append(GraspPoint(name=f"{link}_handle{index}", link=link, link_from_grasp=link_from_grasp))
    model.grasp_points = model.grasp_points + grasp_points
    return PartNetImport(model=reframed(model, turned), category_source=model_cat, front_from=front_from)
