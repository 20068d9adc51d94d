"""A glb that Blender's own glTF exporter wrote from a scene laid out with the extension
(*Include › Custom Properties*), read back as a model document.

The extension's scheme (see `blender_addons.rig`) travels as node `extras`: `hm_link` on
every link's node, `hm_model` on the root link, the joint's `hm_*` fields on a moved link,
`hm_grasp` on grasp points. Blender writes y up; every transform and vertex is turned back
to z up here, so the document is in the frames the scene had.
"""

from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import Any

import numpy as np

from homemodel.app.blender_exchange import FROM_MESHES, MAX_DOCUMENT_BYTES, MODEL_FORMAT, matrix_list
from homemodel.core.errors import InputError
from homemodel.core.input_files import read_bounded
from homemodel.core.transforms import axis_angle_transform, translation_transform

# Blender's exporter writes (x, y, z) as (x, z, -y); this undoes it.
Z_UP_FROM_Y_UP = np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])
_COMPONENTS = {5121: np.uint8, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
_WIDTH = {"SCALAR": 1, "VEC3": 3}


def _chunks(path: Path) -> tuple[dict, bytes]:
    data = read_bounded(path, MAX_DOCUMENT_BYTES)
    if len(data) < 20 or data[:4] != b"glTF":
        raise InputError(f"{path}: not a binary glTF (.glb) file")
    length, kind = struct.unpack_from("<II", data, 12)
    if kind != 0x4E4F534A:
        raise InputError(f"{path}: the first chunk is not JSON")
    doc = json.loads(data[20 : 20 + length])
    blob = b""
    rest = 20 + length
    if rest + 8 <= len(data):
        blob_length, _ = struct.unpack_from("<II", data, rest)
        blob = data[rest + 8 : rest + 8 + blob_length]
    return doc, blob


def _accessor(doc: dict, blob: bytes, index: int) -> np.ndarray:
    accessor = doc["accessors"][index]
    view = doc["bufferViews"][accessor["bufferView"]]
    dtype = np.dtype(_COMPONENTS[accessor["componentType"]])
    width = _WIDTH[accessor["type"]]
    start = view.get("byteOffset", 0) + accessor.get("byteOffset", 0)
    stride = view.get("byteStride") or dtype.itemsize * width
    count = accessor["count"]
    raw = np.frombuffer(blob, dtype=np.uint8, count=stride * (count - 1) + dtype.itemsize * width, offset=start)
    rows = np.lib.stride_tricks.as_strided(raw, shape=(count, dtype.itemsize * width), strides=(stride, 1))
    return rows.copy().view(dtype).reshape(count, width)


def _local(node: dict) -> np.ndarray:
    if "matrix" in node:
        local = np.asarray(node["matrix"], dtype=np.float64).reshape(4, 4).T  # column-major
    else:
        x, y, z, w = node.get("rotation", (0.0, 0.0, 0.0, 1.0))
        rotation = np.array(
            [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
             [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
             [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
        )
        local = np.eye(4)
        local[:3, :3] = rotation * np.asarray(node.get("scale", (1.0, 1.0, 1.0)))
        local[:3, 3] = node.get("translation", (0.0, 0.0, 0.0))
    return Z_UP_FROM_Y_UP @ local @ Z_UP_FROM_Y_UP.T


def _rigid(a_from_b: np.ndarray) -> np.ndarray:
    """`a_from_b` without scale (the rotation's polar factor)."""
    u, _, vt = np.linalg.svd(a_from_b[:3, :3])
    rigid = np.eye(4)
    rigid[:3, :3] = u @ vt
    rigid[:3, 3] = a_from_b[:3, 3]
    return rigid


def _motion(extras: dict) -> np.ndarray:
    axis = np.asarray(extras.get("hm_axis", (0.0, 0.0, 1.0)), dtype=np.float64)
    axis = axis / np.linalg.norm(axis)
    q = float(extras.get("hm_q", 0.0))
    if extras["hm_joint_type"] in ("revolute", "continuous"):
        return axis_angle_transform(axis, q)
    if extras["hm_joint_type"] == "prismatic":
        return translation_transform(axis * q)
    return np.eye(4)


def model_document_from_glb(path: Path) -> dict[str, Any]:
    """The model document of the one homemodel model in a glb Blender exported."""
    path = Path(path)
    doc, blob = _chunks(path)
    nodes = doc.get("nodes", [])
    parent = {child: i for i, node in enumerate(nodes) for child in node.get("children", [])}
    world: dict[int, np.ndarray] = {}

    def world_from(i: int) -> np.ndarray:
        if i not in world:
            world[i] = (world_from(parent[i]) if i in parent else np.eye(4)) @ _local(nodes[i])
        return world[i]

    extras = [node.get("extras", {}) for node in nodes]
    roots = [i for i, e in enumerate(extras) if "hm_model" in e]
    if len(roots) != 1:
        raise InputError(f"{path}: expected one homemodel model (a node with hm_model in its extras), found {len(roots)}")

    def owner(i: int) -> int | None:
        """The link node `i` belongs to (itself for a link)."""
        while i is not None and "hm_link" not in extras[i]:
            i = parent.get(i)
        return i

    links, joints, grasps = {}, [], []
    for i, e in enumerate(extras):
        if "hm_link" in e:
            links[i] = {
                "name": e["hm_link"],
                "visuals": [],
                "collisions": json.loads(e["hm_collisions"]) if "hm_collisions" in e else None,
                "inertial": json.loads(e["hm_inertial"]) if "hm_inertial" in e else FROM_MESHES,
            }
    for i, e in enumerate(extras):
        link = owner(i)
        if link is None:
            continue
        link_from_node = np.linalg.inv(_rigid(world_from(link))) @ world_from(i)
        if "hm_joint" in e and i == link:
            parent_link = owner(parent[i])
            joint = {
                "name": e["hm_joint"],
                "type": e["hm_joint_type"],
                "parent": links[parent_link]["name"],
                "child": e["hm_link"],
                "parent_from_joint": matrix_list(np.linalg.inv(_rigid(world_from(parent_link))) @ _rigid(world_from(i)) @ np.linalg.inv(_motion(e))),
                "axis": list(np.asarray(e["hm_axis"], dtype=float) / np.linalg.norm(e["hm_axis"])),
                "states": json.loads(e.get("hm_states", "[]")),
            }
            if "hm_lower" in e:
                joint["limits"] = {"lower": e["hm_lower"], "upper": e["hm_upper"], "effort": e.get("hm_effort", 10.0), "velocity": e.get("hm_velocity", 1.0)}
            if "hm_dynamics" in e:
                joint["dynamics"] = json.loads(e["hm_dynamics"])
            joints.append(joint)
        if "hm_grasp" in e:
            grasps.append({"name": e["hm_grasp"], "link": links[link]["name"], "kind": e.get("hm_grasp_kind", "handle"), "link_from_grasp": matrix_list(_rigid(link_from_node))})
        if "mesh" in nodes[i]:
            link_from_visual = _rigid(link_from_node)
            visual_from_node = np.linalg.inv(link_from_visual) @ link_from_node
            mesh = doc["meshes"][nodes[i]["mesh"]]
            for k, primitive in enumerate(mesh["primitives"]):
                vertices = _accessor(doc, blob, primitive["attributes"]["POSITION"]).astype(np.float64) @ Z_UP_FROM_Y_UP[:3, :3].T
                vertices = vertices @ visual_from_node[:3, :3].T + visual_from_node[:3, 3]
                faces = _accessor(doc, blob, primitive["indices"]).reshape(-1, 3).astype(np.int64)
                material = doc.get("materials", [])[primitive["material"]] if "material" in primitive else {}
                links[link]["visuals"].append(
                    {
                        "name": nodes[i].get("name", "visual").split(":")[-1] + (f"_{k}" if len(mesh["primitives"]) > 1 else ""),
                        "material": material.get("name", "default"),
                        "rgba": material.get("pbrMetallicRoughness", {}).get("baseColorFactor", [0.8, 0.8, 0.8, 1.0]),
                        "link_from_visual": matrix_list(link_from_visual),
                        "vertices": vertices.tolist(),
                        "faces": faces.tolist(),
                    }
                )
    info = json.loads(extras[roots[0]]["hm_model"])
    spec = extras[roots[0]].get("hm_spec")
    return {
        "format": MODEL_FORMAT,
        **info,
        "spec": json.loads(spec) if spec else None,
        "links": list(links.values()),
        "joints": joints,
        "grasp_points": grasps,
    }
