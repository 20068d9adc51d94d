"""The files the Blender extension and the toolkit trade: a model as one JSON document.

The extension never imports the toolkit (it runs in Blender's Python, with Blender's numpy);
it calls `homemodel addon ...` and reads or writes these documents. A model document holds
everything an `articulation.Model` holds: links with their visual meshes (vertices in the
visual's frame, triangles, an RGBA colour and, for a photo-textured visual, the image's
absolute path and one UV per vertex), collisions, inertials, joints with origin, axis,
limits, dynamics and named states, and grasp points. Transforms are 4x4 row-major lists,
lengths in metres, angles in radians.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from articulation.inertia import inertial_from_meshes
from articulation.model import (
    Box,
    Collision,
    Cylinder,
    GraspPoint,
    Inertial,
    Joint,
    JointDynamics,
    JointLimits,
    JointState,
    Link,
    Material,
    MeshGeometry,
    Model,
    Sphere,
    Visual,
)
from homemodel.core.errors import InputError
from homemodel.core.images import read_image_size
from homemodel.exchange.blender_document import FROM_MESHES, MODEL_FORMAT, matrix_list, read_document

# A link made by hand in Blender (inertial FROM_MESHES) gets this density.
HAND_MADE_DENSITY_KG_M3 = 500.0
TEXTURE_SUFFIXES = (".png", ".jpg", ".jpeg")


def _mesh(mesh: trimesh.Trimesh) -> dict[str, list]:
    return {"vertices": mesh.vertices.tolist(), "faces": mesh.faces.tolist()}


def _collision_document(collision: Collision) -> dict[str, Any]:
    geometry = collision.geometry
    doc: dict[str, Any] = {"name": collision.name, "link_from_collision": matrix_list(collision.link_from_collision)}
    if isinstance(geometry, Box):
        doc.update(type="box", size_m=list(geometry.size_m))
    elif isinstance(geometry, Cylinder):
        doc.update(type="cylinder", radius_m=geometry.radius_m, length_m=geometry.length_m)
    elif isinstance(geometry, Sphere):
        doc.update(type="sphere", radius_m=geometry.radius_m)
    else:
        doc.update(type="mesh", **_mesh(geometry.mesh))
    return doc


def _joint_document(joint: Joint) -> dict[str, Any]:
    doc: dict[str, Any] = {
        "name": joint.name,
        "type": joint.type,
        "parent": joint.parent,
        "child": joint.child,
        "parent_from_joint": matrix_list(joint.parent_from_joint),
        "axis": [float(v) for v in joint.axis],
        "states": [{"name": s.name, "position": s.position} for s in joint.states],
    }
    if joint.limits is not None:
        doc["limits"] = vars(joint.limits).copy()
    if joint.dynamics is not None:
        doc["dynamics"] = vars(joint.dynamics).copy()
    return doc


def _visual_document(visual: Visual) -> dict[str, Any]:
    doc: dict[str, Any] = {
        "name": visual.name,
        "material": visual.material.name,
        "rgba": list(visual.material.rgba),
        "link_from_visual": matrix_list(visual.link_from_visual),
        **_mesh(visual.mesh),
    }
    if visual.material.texture is not None and visual.uv is not None:
        doc.update(texture=str(Path(visual.material.texture).resolve()), uv=visual.uv.tolist())
    return doc


def model_document(model: Model, *, spec: dict | None = None) -> dict[str, Any]:
    """The JSON-ready document of `model`; `spec` is the measurement spec it was built from."""
    links = []
    for link in model.links:
        links.append(
            {
                "name": link.name,
                "visuals": [_visual_document(v) for v in link.visuals],
                "collisions": [_collision_document(c) for c in link.collisions],
                "inertial": None
                if link.inertial is None
                else {
                    "mass_kg": link.inertial.mass_kg,
                    "com_m": link.inertial.com_m.tolist(),
                    "inertia_kgm2": link.inertial.inertia_kgm2.tolist(),
                },
            }
        )
    return {
        "format": MODEL_FORMAT,
        "name": model.name,
        "category": model.category,
        "affordances": list(model.affordances),
        "properties": dict(model.properties),
        "spec": spec,
        "links": links,
        "joints": [_joint_document(j) for j in model.joints],
        "grasp_points": [
            {"name": g.name, "link": g.link, "kind": g.kind, "link_from_grasp": matrix_list(g.link_from_grasp)}
            for g in model.grasp_points
        ],
    }


def _hull(visuals: list[Visual]) -> trimesh.Trimesh:
    points = np.vstack([trimesh.transform_points(v.mesh.vertices, v.link_from_visual) for v in visuals])
    return trimesh.Trimesh(vertices=points).convex_hull


class _Reader:
    """Turns a document into a Model, naming the file and the field on any fault."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, where: str, problem: str) -> InputError:
        return InputError(f"{self.source}: {where}: {problem}")

    def field(self, doc: dict, key: str, where: str) -> Any:
        if not isinstance(doc, dict) or key not in doc:
            raise self.fail(where, f"missing {key!r}")
        return doc[key]

    def array(self, value: Any, shape: tuple[int, ...], where: str, dtype: type = np.float64) -> np.ndarray:
        try:
            result = np.asarray(value, dtype=dtype)
        except (TypeError, ValueError):
            raise self.fail(where, "not an array of numbers") from None
        if shape and result.shape != shape or (not shape and result.ndim != 2):
            raise self.fail(where, f"shape {result.shape}, expected {shape or '(N, 3)'}")
        if dtype is np.float64 and not np.all(np.isfinite(result)):
            raise self.fail(where, "holds a value that is not a finite number")
        return result

    def mesh(self, doc: dict, where: str) -> trimesh.Trimesh:
        vertices = self.array(self.field(doc, "vertices", where), (), f"{where}.vertices")
        faces = self.array(self.field(doc, "faces", where), (), f"{where}.faces", dtype=np.int64)
        if vertices.shape[1:] != (3,) or faces.shape[1:] != (3,):
            raise self.fail(where, f"vertices {vertices.shape} and faces {faces.shape} must both be (N, 3)")
        if len(faces) == 0:
            raise self.fail(where, "a mesh without triangles")
        if faces.min() < 0 or faces.max() >= len(vertices):
            raise self.fail(f"{where}.faces", f"an index outside the {len(vertices)} vertices")
        return trimesh.Trimesh(vertices=vertices, faces=faces, process=False)

    def collision(self, doc: dict, where: str) -> Collision:
        kind = self.field(doc, "type", where)
        link_from = self.array(doc.get("link_from_collision", np.eye(4)), (4, 4), f"{where}.link_from_collision")
        geometry: Box | Cylinder | Sphere | MeshGeometry
        if kind == "box":
            geometry = Box(size_m=tuple(self.array(self.field(doc, "size_m", where), (3,), f"{where}.size_m")))
        elif kind == "cylinder":
            geometry = Cylinder(radius_m=float(doc["radius_m"]), length_m=float(doc["length_m"]))
        elif kind == "sphere":
            geometry = Sphere(radius_m=float(doc["radius_m"]))
        elif kind == "mesh":
            geometry = MeshGeometry(mesh=self.mesh(doc, where))
        else:
            raise self.fail(f"{where}.type", f"{kind!r} is not box, cylinder, sphere or mesh")
        return Collision(name=str(doc.get("name", "collision")), geometry=geometry, link_from_collision=link_from)

    def texture(self, doc: dict, vertex_count: int, where: str) -> tuple[Path | None, np.ndarray | None]:
        """The visual's texture image and per-vertex UVs, or (None, None) for a plain colour."""
        if doc.get("texture") is None:
            return None, None
        image = Path(str(doc["texture"]))
        if image.suffix.lower() not in TEXTURE_SUFFIXES:
            raise self.fail(f"{where}.texture", f"{image} is not a PNG or JPEG image")
        try:
            read_image_size(image)  # a readable image of a bounded size, before it is copied
        except InputError as error:  # missing, unreadable, not an image, too many pixels
            raise self.fail(f"{where}.texture", str(error)) from None
        uv = self.array(self.field(doc, "uv", where), (vertex_count, 2), f"{where}.uv")
        return image, uv

    def link(self, doc: dict, where: str) -> Link:
        visuals = []
        for i, v in enumerate(doc.get("visuals", [])):
            at = f"{where}.visuals.{i}"
            rgba = tuple(float(c) for c in self.array(v.get("rgba", (0.8, 0.8, 0.8, 1.0)), (4,), f"{at}.rgba"))
            mesh = self.mesh(v, at)
            texture, uv = self.texture(v, len(mesh.vertices), at)
            visuals.append(
                Visual(
                    name=str(self.field(v, "name", at)),
                    mesh=mesh,
                    material=Material(name=str(v.get("material") or v["name"]), rgba=rgba, texture=texture),
                    link_from_visual=self.array(v.get("link_from_visual", np.eye(4)), (4, 4), f"{at}.link_from_visual"),
                    uv=uv,
                )
            )
        inertial = doc.get("inertial")
        if inertial == FROM_MESHES:  # a link made by hand in Blender
            inertial = None
            if visuals:
                meshes = [v.mesh.copy().apply_transform(v.link_from_visual) for v in visuals]
                derived = inertial_from_meshes(meshes, density_kg_m3=HAND_MADE_DENSITY_KG_M3)
                inertial = {"mass_kg": derived.mass_kg, "com_m": derived.com_m, "inertia_kgm2": derived.inertia_kgm2}
        if doc.get("collisions") is None:  # a link made by hand in Blender: its visuals' convex hull
            collisions = [Collision(name="hull", geometry=MeshGeometry(mesh=_hull(visuals)))] if visuals else []
        else:
            collisions = [self.collision(c, f"{where}.collisions.{i}") for i, c in enumerate(doc["collisions"])]
        return Link(
            name=str(self.field(doc, "name", where)),
            visuals=visuals,
            collisions=collisions,
            inertial=None
            if inertial is None
            else Inertial(
                mass_kg=float(self.field(inertial, "mass_kg", f"{where}.inertial")),
                com_m=self.array(inertial.get("com_m", [0, 0, 0]), (3,), f"{where}.inertial.com_m"),
                inertia_kgm2=self.array(inertial.get("inertia_kgm2", np.eye(3) * 1e-6), (3, 3), f"{where}.inertial.inertia_kgm2"),
            ),
        )

    def joint(self, doc: dict, where: str) -> Joint:
        limits, dynamics = doc.get("limits"), doc.get("dynamics")
        try:
            return Joint(
                name=str(self.field(doc, "name", where)),
                type=self.field(doc, "type", where),
                parent=str(self.field(doc, "parent", where)),
                child=str(self.field(doc, "child", where)),
                parent_from_joint=self.array(doc.get("parent_from_joint", np.eye(4)), (4, 4), f"{where}.parent_from_joint"),
                axis=self.array(doc.get("axis", [0, 0, 1]), (3,), f"{where}.axis"),
                limits=None if limits is None else JointLimits(**{k: float(v) for k, v in limits.items()}),
                dynamics=None if dynamics is None else JointDynamics(**{k: float(v) for k, v in dynamics.items()}),
                states=[JointState(name=str(s["name"]), position=float(s["position"])) for s in doc.get("states", [])],
            )
        except (TypeError, ValueError, KeyError) as exc:
            raise self.fail(where, str(exc)) from None


def model_from_document(doc: dict, source: str) -> Model:
    """The Model a document describes; InputError naming `source` and the field on a fault."""
    from homemodel.core.errors import ModelError

    reader = _Reader(source)
    if not isinstance(doc, dict) or doc.get("format") != MODEL_FORMAT:
        raise reader.fail("format", f"expected {MODEL_FORMAT!r}")
    links = [reader.link(link, f"links.{i}") for i, link in enumerate(reader.field(doc, "links", "model"))]
    joints = [reader.joint(joint, f"joints.{i}") for i, joint in enumerate(doc.get("joints", []))]
    grasps = []
    for i, g in enumerate(doc.get("grasp_points", [])):
        at = f"grasp_points.{i}"
        grasps.append(
            GraspPoint(
                name=str(reader.field(g, "name", at)),
                link=str(reader.field(g, "link", at)),
                kind=g.get("kind", "handle"),
                link_from_grasp=reader.array(reader.field(g, "link_from_grasp", at), (4, 4), f"{at}.link_from_grasp"),
            )
        )
    try:
        return Model(
            name=str(reader.field(doc, "name", "model")),
            links=links,
            joints=joints,
            grasp_points=grasps,
            category=str(doc.get("category", "object")),
            affordances=[str(a) for a in doc.get("affordances", [])],
            properties={str(k): str(v) for k, v in doc.get("properties", {}).items()},
        )
    except (ModelError, ValueError) as exc:
        raise reader.fail("model", str(exc)) from None


def spec_of_model_folder(folder: Path) -> dict | None:
    """The measurement spec a model folder was built from, when its summary.json names a
    spec file that is still there (so "Edit measurements" works on models built before)."""
    from homemodel.core.yaml_specs import read_yaml_mapping

    summary_path = Path(folder) / "summary.json"
    if not summary_path.is_file():
        return None
    summary = read_document(summary_path)
    # The spec is an input of the summary's schema; folders from before it name it at the top.
    specs = [i.get("path") for i in summary.get("inputs") or [] if isinstance(i, dict) and i.get("role") == "spec"]
    spec = specs[0] if specs else summary.get("spec")
    return read_yaml_mapping(Path(spec)) if isinstance(spec, str) and Path(spec).is_file() else None
