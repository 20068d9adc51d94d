"""Repair an imported asset that fails the validation gate only for want of what the gate
needs, and say what was repaired and why: inertials computed from a closed volume of the
meshes at a stated density (see `articulation.inertia.link_mass`: open sheets are voxel-filled,
never taken at their meaningless "volume"); collision meshes a simulator cannot use (flat
sheets: nothing to collide with; open meshes whose hull fills a cavity a drawer slides in)
made thin boxes on the link's inner side; and the `effort` and `velocity` a `<limit>` must
have (check_urdf refuses one without them) set to stated defaults. Nothing else is changed."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh

from articulation.inertia import link_mass
from articulation.model import Box, Collision, Link, MeshGeometry, Model
from homemodel.core.checks import require_positive
from homemodel.exchange import urdf as urdf_doc
from homemodel.exchange.urdf import Element
from homemodel.geometry.mesh_ops import zero_area_faces
from homemodel.model_folder.gate.mesh_geometry import VOLUME_TOLERANCE
from homemodel.model_folder.gate.urdf_rules import AXIS_UNIT_TOLERANCE


@dataclass(kw_only=True)
class RepairOptions:
    density_kg_m3: float = 500.0  # for links without an inertial: about that of furniture board
    # Open sheets are voxel-filled at this size (smaller for small links): they count this thick.
    voxel_size_m: float = 0.01
    default_mass_kg: float = 1.0  # a link with no surface to measure: this mass,
    default_size_m: float = 0.1  # spread as a solid cube this wide
    effort: float = 10.0  # N m (revolute) or N (prismatic), for a <limit> without one
    velocity: float = 1.0  # rad/s or m/s, for a <limit> without one

    def check(self) -> None:
        require_positive("density_kg_m3", self.density_kg_m3)
        require_positive("voxel_size_m", self.voxel_size_m)
        require_positive("default_mass_kg", self.default_mass_kg)
        require_positive("default_size_m", self.default_size_m)
        require_positive("effort", self.effort)
        require_positive("velocity", self.velocity)


@dataclass(kw_only=True)
class AssetGaps:
    """What a URDF lacks that the gate needs: links with geometry but no inertial, and the
    joints whose <limit> has no effort or no velocity."""

    links_without_inertial: list[str]
    limits_without_effort: list[str]
    limits_without_velocity: list[str]
    # "link/collision" of collision meshes with no volume (PartNet's sheets): nothing to collide with
    flat_collisions: list[str] = field(default_factory=list)
    # ... and of open meshes whose hull is mostly air (a cabinet's sheets in one file): the
    # hull a simulator collides fills the cavity, and the drawers inside collide with it
    hollow_collisions: list[str] = field(default_factory=list)
    axes_not_unit: list[str] = field(default_factory=list)  # joints whose axis is not of length 1

    def __bool__(self) -> bool:
        return bool(
            self.links_without_inertial
            or self.limits_without_effort
            or self.limits_without_velocity
            or self.flat_collisions
            or self.hollow_collisions
            or self.axes_not_unit
        )

    def describe(self) -> list[str]:
        said = []
        if self.links_without_inertial:
            said.append(f"links without <inertial>: {', '.join(self.links_without_inertial)}")
        if self.limits_without_effort:
            said.append(f"<limit> without effort on joints: {', '.join(self.limits_without_effort)}")
        if self.limits_without_velocity:
            said.append(f"<limit> without velocity on joints: {', '.join(self.limits_without_velocity)}")
        if self.flat_collisions:
            said.append(f"flat collision meshes (no volume): {', '.join(self.flat_collisions)}")
        if self.hollow_collisions:
            said.append(f"open collision meshes whose hull fills a cavity: {', '.join(self.hollow_collisions)}")
        if self.axes_not_unit:
            said.append(f"joint axes not of length 1: {', '.join(self.axes_not_unit)}")
        return said


def _flat_box(mesh: trimesh.Trimesh, thickness_m: float, inside: np.ndarray | None = None) -> tuple[Box, np.ndarray] | None:
    """The smallest box on a mesh with no volume (a sheet), `thickness_m` thick on the side
    of the point `inside` (the link's centre: parts that abut, a door on a cabinet's front
    edge, stay apart), and `mesh_from_box`; None when the mesh has volume."""
    points = np.asarray(mesh.vertices, dtype=np.float64)
    centre = points.mean(axis=0)
    _, _, axes = np.linalg.svd(points - centre)  # rows: principal directions, thinnest last
    local = (points - centre) @ axes.T
    if np.ptp(local[:, 2]) > VOLUME_TOLERANCE ** (1 / 3) * float(np.linalg.norm(np.ptp(local, axis=0))):
        return None
    in_plane = axes[:2]
    middle = (local[:, :2].min(axis=0) + local[:, :2].max(axis=0)) / 2
    sides = np.ptp(local[:, :2], axis=0)
    try:
        # The plane's smallest enclosing rectangle (principal axes are not its sides in general).
        to_rectangle, sides = trimesh.bounds.oriented_bounds_2D(local[:, :2])
        in_plane = to_rectangle[:2, :2] @ axes[:2]
        middle = -to_rectangle[:2, :2].T @ to_rectangle[:2, 2]
    except Exception:  # qhull refuses a line: the principal axes do
        pass
    normal = np.cross(in_plane[0], in_plane[1])
    plane_point = centre + axes[:2].T @ middle + axes[2] * (local[:, 2].min() + local[:, 2].max()) / 2
    side = 1.0 if inside is None or float((np.asarray(inside) - plane_point) @ normal) >= 0 else -1.0
    mesh_from_box = np.eye(4)
    mesh_from_box[:3, :3] = np.vstack([in_plane, normal]).T
    mesh_from_box[:3, 3] = plane_point + (side * thickness_m / 2 if inside is not None else 0.0) * normal
    size = np.maximum([*sides, 0.0], thickness_m)
    return Box(size_m=tuple(float(v) for v in size)), mesh_from_box


# An open mesh is hollow when its hull holds this many times its sheets taken SHEET_M thick.
HOLLOW_HULL_RATIO = 3.0
SHEET_M = 0.01
# A hollow mesh is replaced by at most this many panels; beyond (a finely curved surface), its hull stays.
MAX_PANELS = 64


def _merged(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """The mesh with coincident vertices merged (an STL repeats each corner per triangle, so
    a closed STL box reads as open until they are)."""
    merged = mesh.copy()
    merged.merge_vertices()
    return merged


def _is_hollow(mesh: trimesh.Trimesh) -> bool:
    mesh = _merged(mesh)
    if mesh.is_watertight:
        return False
    try:
        hull_m3 = float(mesh.convex_hull.volume)
    except Exception:  # qhull refuses flat or collinear point sets
        return False
    return hull_m3 > HOLLOW_HULL_RATIO * float(mesh.area) * SHEET_M


def _mesh_collisions(model: Model) -> list[tuple[str, trimesh.Trimesh]]:
    return [
        (f"{link.name}/{c.name}", c.geometry.mesh)
        for link in model.links
        for c in link.collisions
        if isinstance(c.geometry, MeshGeometry)
    ]


def model_flat_collisions(model: Model) -> list[str]:
    """"link/collision" of every collision mesh of the model with no volume."""
    return [name for name, mesh in _mesh_collisions(model) if _flat_box(mesh, 1.0) is not None]


def model_hollow_collisions(model: Model) -> list[str]:
    """"link/collision" of every open collision mesh whose hull is mostly air."""
    return [name for name, mesh in _mesh_collisions(model) if _flat_box(mesh, 1.0) is None and _is_hollow(mesh)]


def _panels(mesh: trimesh.Trimesh, thickness_m: float, inside: np.ndarray) -> list[tuple[Box, np.ndarray]] | None:
    """The open mesh as thin boxes, one per planar region (trimesh's facets; a lone triangle
    is its own region), each on the side of `inside`; None when a region is not flat or there
    are more than MAX_PANELS."""
    merged = _merged(mesh)
    merged.update_faces(~zero_area_faces(merged.vertices, merged.faces))  # they bound nothing
    groups = [np.asarray(f) for f in merged.facets]
    grouped = np.zeros(len(merged.faces), dtype=bool)
    for group in groups:
        grouped[group] = True
    groups += [np.array([i]) for i in np.flatnonzero(~grouped)]
    if len(groups) > MAX_PANELS:
        return None
    panels = []
    for group in groups:
        region = trimesh.Trimesh(merged.vertices, merged.faces[group], process=False)
        region.remove_unreferenced_vertices()
        box = _flat_box(region, thickness_m, inside)
        if box is None:
            return None
        panels.append(box)
    return panels


def find_gaps(urdf: Path, model: Model | None = None) -> AssetGaps:
    """What the URDF lacks; with its `model` loaded, also its flat or hollow collision meshes
    and its joint axes not of unit length."""
    robot = urdf_doc.read_urdf_robot(Path(urdf))
    no_inertial = [
        link.get("name")
        for link in urdf_doc.links(robot)
        if link.find("inertial") is None and (link.find("visual") is not None or link.find("collision") is not None)
    ]
    limits: list[tuple[str, Element]] = [
        (j.get("name"), j.find("limit")) for j in urdf_doc.joints(robot) if j.find("limit") is not None
    ]
    return AssetGaps(
        links_without_inertial=no_inertial,
        limits_without_effort=[name for name, el in limits if el.get("effort") is None],
        limits_without_velocity=[name for name, el in limits if el.get("velocity") is None],
        flat_collisions=model_flat_collisions(model) if model is not None else [],
        hollow_collisions=model_hollow_collisions(model) if model is not None else [],
        axes_not_unit=[
            j.name for j in (model.joints if model is not None else []) if j.is_movable and abs(np.linalg.norm(j.axis) - 1) >= AXIS_UNIT_TOLERANCE
        ],
    )


def _centre(link: Link) -> np.ndarray:
    meshes = _link_meshes(link)
    return trimesh.util.concatenate(meshes).bounds.mean(axis=0) if meshes else np.zeros(3)


def _as_boxes(collision: Collision, hollow: bool, thickness_m: float, inside_link: np.ndarray) -> list[Collision] | None:
    """A flat collision mesh as one thin box, a hollow one as a box per flat panel (None
    when it cannot be: not flat panels, or too many)."""
    inside = (np.linalg.inv(collision.link_from_collision) @ np.append(inside_link, 1.0))[:3]
    mesh = collision.geometry.mesh
    boxes = _panels(mesh, thickness_m, inside) if hollow else [_flat_box(mesh, thickness_m, inside)]
    if boxes is None or None in boxes:
        return None
    return [
        Collision(
            name=collision.name if len(boxes) == 1 and not hollow else f"{collision.name}_panel{k}",
            geometry=box,
            link_from_collision=collision.link_from_collision @ mesh_from_box,
        )
        for k, (box, mesh_from_box) in enumerate(boxes)
    ]


def _collisions_repaired(link: Link, gaps: AssetGaps, thickness_m: float) -> tuple[Link, list[str]]:
    """The link with its flat and hollow collision meshes made thin boxes on its inner side
    (towards its centre of mass), and what was done."""
    kinds = {name.partition("/")[2]: "flat" for name in gaps.flat_collisions if name.startswith(f"{link.name}/")}
    kinds |= {name.partition("/")[2]: "hollow" for name in gaps.hollow_collisions if name.startswith(f"{link.name}/")}
    if not kinds:
        return link, []
    inside = link.inertial.com_m if link.inertial is not None else _centre(link)
    collisions: list[Collision] = []
    made = {"flat": 0, "hollow": 0}
    kept = []
    for collision in link.collisions:
        kind = kinds.get(collision.name) if isinstance(collision.geometry, MeshGeometry) else None
        boxes = _as_boxes(collision, kind == "hollow", thickness_m, inside) if kind else None
        if kind and boxes is None:
            kept.append(collision.name)
        elif kind:
            made[kind] += 1
        collisions += boxes or [collision]
    said = []
    thick = f"{thickness_m * 1000:g} mm thick"
    if made["hollow"]:
        said.append(
            f"link {link.name!r}: {made['hollow']} open collision mesh(es) whose hull would fill a cavity made "
            f"one box {thick} per flat panel, on the link's inner side"
        )
    if made["flat"]:
        said.append(f"link {link.name!r}: {made['flat']} flat collision mesh(es) (no volume to collide with) made boxes {thick} on the link's inner side")
    if kept:
        said.append(f"link {link.name!r}: collision mesh(es) {', '.join(kept)} left as they are (not flat panels, or over {MAX_PANELS})")
    return dataclasses.replace(link, collisions=collisions), said


def _link_meshes(link: Link) -> list[trimesh.Trimesh]:
    """The link's visual meshes in the link frame; its collision meshes when it has no visuals."""
    if link.visuals:
        return [v.mesh.copy().apply_transform(v.link_from_visual) for v in link.visuals]
    meshes = []
    for collision in link.collisions:
        if isinstance(collision.geometry, MeshGeometry):
            meshes.append(collision.geometry.mesh.copy().apply_transform(collision.link_from_collision))
    return meshes


def repair(model: Model, gaps: AssetGaps, options: RepairOptions) -> tuple[Model, list[str]]:
    """The model with the gaps filled, and one line per repair."""
    options.check()
    done: list[str] = []
    links = []
    for link in model.links:
        if link.name in gaps.links_without_inertial:
            found = link_mass(
                _link_meshes(link),
                density_kg_m3=options.density_kg_m3,
                voxel_size_m=options.voxel_size_m,
                default_mass_kg=options.default_mass_kg,
                default_size_m=options.default_size_m,
            )
            link = dataclasses.replace(link, inertial=found.inertial)
            done.append(
                f"link {link.name!r}: no <inertial>; {found.inertial.mass_kg:.3g} kg from {found.method} "
                f"at {options.density_kg_m3:g} kg/m^3"
            )
        link, said = _collisions_repaired(link, gaps, options.voxel_size_m)
        done += said
        links.append(link)
    joints = []
    for joint in model.joints:
        changes = {}
        if joint.name in gaps.limits_without_effort and joint.limits is not None:
            changes["effort"] = options.effort
        if joint.name in gaps.limits_without_velocity and joint.limits is not None:
            changes["velocity"] = options.velocity
        if joint.name in gaps.axes_not_unit:
            length = float(np.linalg.norm(joint.axis))
            joint = dataclasses.replace(joint, axis=joint.axis / length)
            done.append(f"joint {joint.name!r}: axis of length {length:.6g} made of length 1 (its direction kept)")
        if changes:
            joint = dataclasses.replace(joint, limits=dataclasses.replace(joint.limits, **changes))
            done.append(f"joint {joint.name!r}: " + ", ".join(f"{k} set to {v:g}" for k, v in changes.items()))
        joints.append(joint)
    return dataclasses.replace(model, links=links, joints=joints), done
