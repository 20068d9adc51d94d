"""A glb that Blender's own glTF exporter wrote from a scene laid out with the extension
(*Include › Custom Properties*), read back as a model document.

The extension's scheme (see `blender_addons.rig`) travels as node `extras`: `hm_link` on
every link's node, `hm_model` on the root link, the joint's `hm_*` fields on a moved link,
`hm_grasp` on grasp points. Blender writes y up; every transform and vertex is turned back
to z up here, so the document is in the frames the scene had.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from articulation.joint_types import ROTATING_JOINT_TYPES
from homemodel.core.errors import InputError
from homemodel.core.input_files import read_bounded
from homemodel.core.transforms import axis_angle_transform, translation_transform
from homemodel.exchange import blender_document as doc_keys
from homemodel.exchange.blender_document import FROM_MESHES, MAX_DOCUMENT_BYTES, MODEL_FORMAT, matrix_list
from homemodel.exchange.glb import read_glb

# Blender's exporter writes (x, y, z) as (x, z, -y); this undoes it.
Z_UP_FROM_Y_UP = np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])
_COMPONENTS = {5121: np.uint8, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
_WIDTH = {"SCALAR": 1, "VEC3": 3}


def _chunks(path: Path) -> tuple[dict, bytes]:
    data = read_bounded(path, MAX_DOCUMENT_BYTES)
    try:
        glb = read_glb(data)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
    return glb.doc, glb.blob


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
    axis = np.asarray(extras.get(doc_keys.AXIS, (0.0, 0.0, 1.0)), dtype=np.float64)
    axis = axis / np.linalg.norm(axis)
    q = float(extras.get(doc_keys.POSITION, 0.0))
    if extras[doc_keys.JOINT_TYPE] in ROTATING_JOINT_TYPES:
        return axis_angle_transform(axis, q)
    if extras[doc_keys.JOINT_TYPE] == "prismatic":
        return translation_transform(axis * q)
    return np.eye(4)


def model_document_from_glb(path: Path) -> dict[str, Any]:
    """The model document of the one homemodel model in a glb Blender exported; InputError
    naming the file when the container is corrupt or its nodes and accessors do not fit."""
    path = Path(path)
    doc, blob = _chunks(path)
    try:
        return _model_document(path, doc, blob)
    except (KeyError, IndexError, TypeError, ValueError, RecursionError, np.linalg.LinAlgError) as exc:
        raise InputError(f"{path}: not a model as Blender exports it ({type(exc).__name__}: {exc})") from None


def _model_document(path: Path, doc: dict, blob: bytes) -> dict[str, Any]:
    nodes = doc.get("nodes", [])
    parent = {child: i for i, node in enumerate(nodes) for child in node.get("children", [])}
    world: dict[int, np.ndarray] = {}

    def world_from(i: int) -> np.ndarray:
        if i not in world:
            world[i] = (world_from(parent[i]) if i in parent else np.eye(4)) @ _local(nodes[i])
        return world[i]

    extras = [node.get("extras", {}) for node in nodes]
    roots = [i for i, e in enumerate(extras) if doc_keys.MODEL in e]
    if len(roots) != 1:
        raise InputError(f"{path}: expected one homemodel model (a node with hm_model in its extras), found {len(roots)}")

    def owner(i: int) -> int | None:
        """The link node `i` belongs to (itself for a link)."""
        while i is not None and doc_keys.LINK not in extras[i]:
            i = parent.get(i)
        return i

    links, joints, grasps = {}, [], []
    for i, e in enumerate(extras):
        if doc_keys.LINK in e:
            links[i] = {
                "name": e[doc_keys.LINK],
                "visuals": [],
                "collisions": json.loads(e[doc_keys.COLLISIONS]) if doc_keys.COLLISIONS in e else None,
                "inertial": json.loads(e[doc_keys.INERTIAL]) if doc_keys.INERTIAL in e else FROM_MESHES,
            }
    for i, e in enumerate(extras):
        link = owner(i)
        if link is None:
            continue
        link_from_node = np.linalg.inv(_rigid(world_from(link))) @ world_from(i)
        if doc_keys.JOINT in e and i == link:
            parent_link = owner(parent[i])
            joint = {
                "name": e[doc_keys.JOINT],
                "type": e[doc_keys.JOINT_TYPE],
                "parent": links[parent_link]["name"],
                "child": e[doc_keys.LINK],
                "parent_from_joint": matrix_list(np.linalg.inv(_rigid(world_from(parent_link))) @ _rigid(world_from(i)) @ np.linalg.inv(_motion(e))),
                "axis": list(np.asarray(e[doc_keys.AXIS], dtype=float) / np.linalg.norm(e[doc_keys.AXIS])),
                "states": json.loads(e.get(doc_keys.STATES, "[]")),
            }
            if doc_keys.LOWER in e:
                joint["limits"] = {"lower": e[doc_keys.LOWER], "upper": e[doc_keys.UPPER], "effort": e.get(doc_keys.EFFORT, 10.0), "velocity": e.get(doc_keys.VELOCITY, 1.0)}
            if doc_keys.DYNAMICS in e:
                joint["dynamics"] = json.loads(e[doc_keys.DYNAMICS])
            joints.append(joint)
        if doc_keys.GRASP in e:
            grasps.append({"name": e[doc_keys.GRASP], "link": links[link]["name"], "kind": e.get(doc_keys.GRASP_KIND, "handle"), "link_from_grasp": matrix_list(_rigid(link_from_node))})
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
    info = json.loads(extras[roots[0]][doc_keys.MODEL])
    spec = extras[roots[0]].get(doc_keys.SPEC)
    return {
        "format": MODEL_FORMAT,
        **info,
        "spec": json.loads(spec) if spec else None,
        "links": list(links.values()),
        "joints": joints,
        "grasp_points": grasps,
    }
