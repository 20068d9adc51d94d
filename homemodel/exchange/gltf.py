"""Write a model as a binary glTF 2.0 (`model.glb`): one node per link, in the URDF frames.

glTF is y-up; the model is z-up. A root node named after the model turns z-up into y-up
(so viewers and Blender's importer show the object standing), and under it every link is
a node whose transform is its joint origin, exactly as in the URDF. Each link node that a
joint moves carries the joint in `extras.joint`; the root carries the model's semantics.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from PIL import Image

from articulation.joint_types import LIMITED_JOINT_TYPES
from articulation.model import Joint, Link, Material, Model
from homemodel.core.atomic import write_bytes_atomic
from homemodel.core.transforms import Y_UP_FROM_Z_UP, rotation_from_rpy
from homemodel.exchange.glb import pack_glb
from homemodel.exchange.numbers import (
    canonical_transform,
    canonical_xyz_rpy,
    rounded,
    significant,
)

_FLOAT, _UINT32 = 5126, 5125
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963


def _num(value: float) -> float:
    """A JSON number that prints the same whatever its source type (no "-0.0", no ints)."""
    return float(value) + 0.0


def _translation_rotation(a_from_b: np.ndarray) -> tuple[list[float], list[float]]:
    """glTF translation and quaternion from the URDF's rounded xyz/rpy, so both files agree
    and a re-export of an imported model gives the same bytes."""
    xyz, rpy = canonical_xyz_rpy(a_from_b)
    return [_num(v) for v in xyz], [_num(round(v, 9)) for v in quaternion_xyzw(rotation_from_rpy(rpy))]


def quaternion_xyzw(rotation: np.ndarray) -> list[float]:
    """Unit quaternion (x, y, z, w) of a rotation matrix, w >= 0 (Shepperd's method)."""
    m = np.asarray(rotation, dtype=np.float64)
    trace = np.trace(m)
    if trace > 0:
        s = 2.0 * np.sqrt(trace + 1.0)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s]
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(1.0 + m[i, i] - m[j, j] - m[k, k])
        q = [0.0, 0.0, 0.0, (m[k, j] - m[j, k]) / s]
        q[i] = 0.25 * s
        q[j] = (m[j, i] + m[i, j]) / s
        q[k] = (m[k, i] + m[i, k]) / s
    q = np.asarray(q)
    q = q / np.linalg.norm(q)
    if q[3] < 0:
        q = -q
    return [_num(v) for v in q]


class _Builder:
    """Accumulates the JSON document and the binary buffer of one .glb."""

    def __init__(self) -> None:
        self.doc: dict = {
            "asset": {"version": "2.0", "generator": "homemodel"},
            "scene": 0,
            "scenes": [{"nodes": [0]}],
            "nodes": [],
            "meshes": [],
            "materials": [],
            "accessors": [],
            "bufferViews": [],
        }
        self.blob = bytearray()
        self.material_index: dict[tuple, int] = {}
        self.image_index: dict[Path, int] = {}

    def _view(self, data: bytes, target: int | None) -> int:
        self.blob.extend(b"\0" * (-len(self.blob) % 4))
        view = {"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(data)}
        if target is not None:
            view["target"] = target
        self.blob.extend(data)
        self.doc["bufferViews"].append(view)
        return len(self.doc["bufferViews"]) - 1

    def _accessor(self, array: np.ndarray, kind: str, component: int, target: int, bounds: bool) -> int:
        view = self._view(array.tobytes(), target)
        accessor = {"bufferView": view, "componentType": component, "count": len(array), "type": kind}
        if bounds:
            accessor["min"] = [_num(v) for v in array.min(axis=0)]
            accessor["max"] = [_num(v) for v in array.max(axis=0)]
        self.doc["accessors"].append(accessor)
        return len(self.doc["accessors"]) - 1

    def _image(self, path: Path) -> int:
        if path not in self.image_index:
            data = Path(path).read_bytes()
            mime = {".png": "image/png", ".jpg": "image/jpeg", ".jpeg": "image/jpeg"}.get(path.suffix.lower())
            if mime is None:  # glTF core allows only PNG and JPEG
                buffer = io.BytesIO()
                Image.open(path).save(buffer, format="PNG")
                data, mime = buffer.getvalue(), "image/png"
            view = self._view(data, None)
            self.doc.setdefault("images", []).append({"bufferView": view, "mimeType": mime})
            self.doc.setdefault("samplers", [{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}])
            self.doc.setdefault("textures", []).append({"sampler": 0, "source": len(self.doc["images"]) - 1})
            self.image_index[path] = len(self.doc["textures"]) - 1
        return self.image_index[path]

    def material(self, material: Material) -> int:
        key = (material.name, tuple(material.rgba), material.texture)
        if key not in self.material_index:
            pbr: dict = {"baseColorFactor": [rounded(c) + 0.0 for c in material.rgba], "metallicFactor": 0.0, "roughnessFactor": 0.8}
            if material.texture is not None:
                pbr["baseColorTexture"] = {"index": self._image(Path(material.texture))}
            entry = {"name": material.name, "pbrMetallicRoughness": pbr}
            if material.rgba[3] < 1.0:
                entry["alphaMode"] = "BLEND"
            self.doc["materials"].append(entry)
            self.material_index[key] = len(self.doc["materials"]) - 1
        return self.material_index[key]

    def mesh(self, link: Link) -> int:
        primitives = []
        for visual in link.visuals:
            # Visual origins are baked into the vertices: the node is the link frame.
            # Start from what the URDF and OBJ store (6 decimals) so both files hold the same shape.
            link_from_visual = canonical_transform(visual.link_from_visual)
            vertices = np.round(visual.mesh.vertices, 6) @ link_from_visual[:3, :3].T + link_from_visual[:3, 3]
            vertices = np.round(vertices, 6)
            attributes = {"POSITION": self._accessor(vertices.astype(np.float32), "VEC3", _FLOAT, _ARRAY_BUFFER, True)}
            if visual.uv is not None and visual.material.texture is not None:
                uv = np.round(visual.uv, 6)
                uv = np.column_stack([uv[:, 0], 1.0 - uv[:, 1]]).astype(np.float32)  # glTF: v down
                attributes["TEXCOORD_0"] = self._accessor(uv, "VEC2", _FLOAT, _ARRAY_BUFFER, False)
            indices = np.asarray(visual.mesh.faces, dtype=np.uint32).reshape(-1)
            primitive = {
                "attributes": attributes,
                "indices": self._accessor(indices, "SCALAR", _UINT32, _ELEMENT_ARRAY_BUFFER, False),
                "material": self.material(visual.material),
            }
            primitives.append(primitive)
        self.doc["meshes"].append({"name": link.name, "primitives": primitives})
        return len(self.doc["meshes"]) - 1

    def glb(self) -> bytes:
        for key in ("meshes", "materials", "accessors", "bufferViews"):
            if not self.doc[key]:
                del self.doc[key]
        self.blob.extend(b"\0" * (-len(self.blob) % 4))
        if self.blob:
            self.doc["buffers"] = [{"byteLength": len(self.blob)}]
        return pack_glb(self.doc, bytes(self.blob))


def _joint_extras(joint: Joint) -> dict:
    extras: dict = {"name": joint.name, "type": joint.type, "parent": joint.parent}
    if joint.type != "fixed":
        extras["axis"] = [rounded(v) + 0.0 for v in joint.axis]
    if joint.limits is not None and joint.type in LIMITED_JOINT_TYPES:
        extras.update(lower=rounded(joint.limits.lower) + 0.0, upper=rounded(joint.limits.upper) + 0.0)
    if joint.limits is not None:
        extras.update(effort=float(significant(joint.limits.effort)), velocity=float(significant(joint.limits.velocity)))
    if joint.dynamics is not None:
        extras.update(damping=float(significant(joint.dynamics.damping)), friction=float(significant(joint.dynamics.friction)))
    if joint.states:
        extras["states"] = [{"name": s.name, "position": rounded(s.position) + 0.0} for s in joint.states]
    return extras


def _model_extras(model: Model) -> dict:
    return {
        "homemodel": {
            "up_axis": "z",
            "category": model.category,
            "affordances": list(model.affordances),
            "properties": dict(sorted(model.properties.items())),
            "grasp_points": [
                {"name": g.name, "link": g.link, "kind": g.kind}
                | dict(zip(("translation", "rotation"), _translation_rotation(g.link_from_grasp)))
                for g in model.grasp_points
            ],
        }
    }


def glb_bytes(model: Model) -> bytes:
    builder = _Builder()
    nodes = builder.doc["nodes"]
    root = {"name": model.name, "rotation": quaternion_xyzw(Y_UP_FROM_Z_UP[:3, :3]), "extras": _model_extras(model)}
    nodes.append(root)
    joint_of_child = {j.child: j for j in model.joints}
    node_of_link: dict[str, int] = {}
    # Links in tree order so parents get their node first.
    order = [model.root_link]
    for name in order:
        order.extend(j.child for j in model.joints if j.parent == name)
    for name in order:
        link = model.link(name)
        node: dict = {"name": link.name}
        joint = joint_of_child.get(name)
        if joint is not None:
            translation, rotation = _translation_rotation(joint.parent_from_joint)
            if any(translation):
                node["translation"] = translation
            if rotation != [0.0, 0.0, 0.0, 1.0]:
                node["rotation"] = rotation
            node["extras"] = {"joint": _joint_extras(joint)}
        if link.visuals:
            node["mesh"] = builder.mesh(link)
        nodes.append(node)
        node_of_link[name] = len(nodes) - 1
        parent = node_of_link[joint.parent] if joint is not None else 0
        nodes[parent].setdefault("children", []).append(node_of_link[name])
    return builder.glb()


def write_glb(model: Model, folder: Path) -> Path:
    path = Path(folder) / "model.glb"
    write_bytes_atomic(path, glb_bytes(model))
    return path
