"""The gate's collision check: no part passes through another at any joint's limits.

pybullet loads the URDF with its collision shapes; each movable joint goes to its lower and
its upper limit and to three places between (a quarter, half and three quarters of its
range) with every other joint at rest. Joints are not moved together: two fronts that may
each open fully but not both at once (a door opened past 90 degrees beside pulled-out
drawers) are how real furniture is, not a fault of the model. At each configuration
pybullet's broadphase and narrowphase find the pairs of links in contact, among all pairs
not welded together by fixed joints (parent and child across a movable joint included: a
door swinging into its cupboard's side wall is the fault to catch), and a pair closer than
`-PENETRATION_TOLERANCE_M` (one passing more than that into the other) fails the check,
naming the joint, the position, the two links, the depth and where the deepest point lies
(in the model frame). Only the swept joint moves, so the Python work per configuration
follows the contacts, not the number of links.

A revolute joint whose child rests within `_CLOSE_AT_REST_M` of another part (a closed
front in its frame) is also tried at small angles from rest (`_NEAR_REST_DEG`): an inset
door without clearance on its free side cuts the frame with its inner corner only in the
first degrees of its swing (by t^2 / 2w, about half a millimetre), which the quarters of its
range step over. Other joints (a chain's links well apart) are not, so the sweep's cost
stays a few passes per joint.

Rubbing is not breaking. A door whose hinge line comes from a tape, or a scanned door on
a real frame, rubs the frame at its hinge-side edge by a millimetre or two as it opens: the
real hinge's linkage is not one fixed axis. A contact between a revolute joint's child and
its parent that lies within `hinge_zone_m` of the joint's axis and goes at most
`hinge_rub_tolerance_m` deep (3 mm) is reported as a warning with its depth, and the check
passes; deeper, anywhere else (a door's free edge, a drawer, a part going through the
body), or by a part that touches the body when shut (an inset door without clearance), it
fails. A door swung the wrong way goes centimetres in and still fails.

Why 0.05 mm elsewhere: parts that are meant to touch (a closed door on its frame, a drawer on
its floor) meet at distance zero, which pybullet's GJK/EPA reports to about a micrometre for
boxes and cylinders. pybullet inflates every convex mesh shape by its collision margin
(`BULLET_MESH_MARGIN_M`); that inflation is taken off before comparing, so two touching mesh
parts are not reported as overlapping; a hull's depth is only an upper bound (below), so a
pair with a mesh keeps the 1 mm the modeller promises its measurements to.

pybullet tests a collision mesh as its convex hull, which fills a concave part's cavity. A
contact involving a mesh therefore counts only when the real triangle meshes intersect as
well (`homemodel.model_folder.gate.real_meshes`, FCL); its depth is still the hulls', an upper bound.
Boxes, cylinders and spheres need no such confirmation.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from homemodel.core.c_stdio_capture import captured_c_output
from homemodel.model_folder.gate.clients import pybullet_errors
from homemodel.model_folder.gate.pybullet_world import empty_pybullet_client
from homemodel.model_folder.gate.real_meshes import RealMeshes
from homemodel.model_folder.gate.report import Check, check_from_problems, count

CHECK_NAME = "collisions"
PENETRATION_TOLERANCE_M = 5e-5
MESH_PENETRATION_TOLERANCE_M = 1e-3
HINGE_RUB_TOLERANCE_M = 3e-3
# A contact this close to a hinge's axis is at its hinge line: the hinge-side edge of a door
# up to 65 mm thick (a microwave's) with its axis inside it or a few centimetres behind.
HINGE_ZONE_M = 0.05
# pybullet's URDF importer gives every convex mesh collision shape this margin (Bullet's
# gUrdfDefaultCollisionMargin); boxes, cylinders and spheres have their margin inside.
BULLET_MESH_MARGIN_M = 1e-3
# Between its limits a joint is also tried at these fractions of its range, so a door that
# swings through a wall and out the other side is caught on the way.
_SWEEP_FRACTIONS = (0.25, 0.5, 0.75)
# A joint without limits (continuous) is tried at these positions.
_UNLIMITED_SAMPLES_RAD = (-math.pi / 2, math.pi / 2, math.pi)
# A revolute joint is also tried this far from rest (degrees), where a front without
# clearance cuts its frame, when its child rests closer than this to another part (a 2 mm
# reveal included: t^2 / 2w reaches 2 mm for a 40 mm door 0.4 m wide).
_NEAR_REST_DEG = (0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.5, 8.0, 10.0, 13.0, 16.0)
_CLOSE_AT_REST_M = 0.0025


@dataclass(kw_only=True)
class CollisionOptions:
    """How deep a contact may go before it fails the check, and what counts as rubbing."""

    penetration_tolerance_m: float = PENETRATION_TOLERANCE_M
    mesh_penetration_tolerance_m: float = MESH_PENETRATION_TOLERANCE_M
    hinge_rub_tolerance_m: float = HINGE_RUB_TOLERANCE_M
    hinge_zone_m: float = HINGE_ZONE_M

    def check(self) -> CollisionOptions:
        for name, value in vars(self).items():
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name}={value!r} but expected a finite length >= 0")
        return self


@dataclass(frozen=True)
class _Joint:
    index: int
    name: str
    lower: float
    upper: float
    revolute: bool
    parent: int
    axis: tuple[float, float, float]

    @property
    def rest(self) -> float:
        """Zero, or the nearest limit when zero is outside the joint's range."""
        return min(max(0.0, self.lower), self.upper)


@dataclass(frozen=True)
class _Configuration:
    """One joint moved to `position`, every other at rest (no joint: all at rest)."""

    label: str
    joint: _Joint | None = None
    position: float = 0.0


def _configurations(joints: list[_Joint], close_at_rest: set[int]) -> list[_Configuration]:
    """Rest, then each joint alone at its limits and on the way between them (others at rest),
    a revolute joint whose child rests close to another part also in small turns from rest."""
    configurations = [_Configuration("at rest")]
    for joint in joints:
        if joint.lower <= joint.upper:
            span = joint.upper - joint.lower
            samples = [(f"at lower ({joint.lower:.4g})", joint.lower)]
            samples += [
                (f"at {joint.lower + f * span:.4g} ({f:.0%} of its range)", joint.lower + f * span)
                for f in _SWEEP_FRACTIONS
            ]
            samples.append((f"at upper ({joint.upper:.4g})", joint.upper))
        else:  # pybullet reports a continuous joint as lower 0 > upper -1
            samples = [(f"at {q:.3g} rad", q) for q in _UNLIMITED_SAMPLES_RAD]
        if joint.revolute and joint.index in close_at_rest:
            samples += _near_rest(joint)
        for label, q in samples:
            if q != joint.rest:
                configurations.append(_Configuration(f"{joint.name} {label}", joint, q))
    return configurations


def _near_rest(joint: _Joint) -> list[tuple[str, float]]:
    """Small turns from rest, the way the joint's range goes, inside its limits."""
    if joint.lower > joint.upper:
        return []
    way = 1.0 if joint.upper - joint.rest >= joint.rest - joint.lower else -1.0
    samples = []
    for degrees in _NEAR_REST_DEG:
        q = joint.rest + way * math.radians(degrees)
        if joint.lower < q < joint.upper:
            samples.append((f"at {q:.4g} ({way * degrees:g} deg from rest)", q))
    return samples


@dataclass(frozen=True)
class _Contact:
    """The deepest point of one pair's contact: how far in, and where (model frame)."""

    depth_m: float
    where_m: tuple[float, float, float]


class _Links:
    """The body's links by pybullet index (-1 the base), their names, welded groups and shapes."""

    def __init__(self, pb: Any, client: int, body: int) -> None:
        infos = [
            pb.getJointInfo(body, i, physicsClientId=client)
            for i in range(pb.getNumJoints(body, physicsClientId=client))
        ]
        self.names = {-1: pb.getBodyInfo(body, physicsClientId=client)[0].decode()}
        self.names.update({info[0]: info[12].decode() for info in infos})
        self.joints = [
            _Joint(
                index=info[0],
                name=info[1].decode(),
                lower=float(info[8]),
                upper=float(info[9]),
                revolute=info[2] == pb.JOINT_REVOLUTE,
                parent=info[16],
                axis=tuple(float(v) for v in info[13]),
            )
            for info in infos
            if info[2] in (pb.JOINT_REVOLUTE, pb.JOINT_PRISMATIC)
        ]
        # Links joined by fixed joints move as one rigid part: union-find on their indices.
        group = {index: index for index in self.names}

        def find(index: int) -> int:
            while group[index] != index:
                index = group[index]
            return index

        for info in infos:
            if info[2] == pb.JOINT_FIXED:
                group[find(info[0])] = find(info[16])
        self.group = {index: find(index) for index in self.names}
        shapes = {index: pb.getCollisionShapeData(body, index, physicsClientId=client) for index in self.names}
        self.with_shapes = [index for index in self.names if shapes[index]]
        self.has_mesh = {index: any(s[2] == pb.GEOM_MESH for s in shapes[index]) for index in self.names}
        self.margin_m = {index: BULLET_MESH_MARGIN_M if self.has_mesh[index] else 0.0 for index in self.names}

    def pair_count(self) -> int:
        """How many pairs of links with collision shapes can move against each other."""
        sizes: dict[int, int] = {}
        for index in self.with_shapes:
            sizes[self.group[index]] = sizes.get(self.group[index], 0) + 1
        n = len(self.with_shapes)
        return n * (n - 1) // 2 - sum(k * (k - 1) // 2 for k in sizes.values())


def _contacts(pb: Any, client: int, body: int, links: _Links) -> dict[tuple[int, int], _Contact]:
    """How far each pair of links not welded together passes into each other (positive),
    and where, for the pairs that do at all.

    pybullet's broadphase finds the pairs whose boxes overlap, so the cost follows the
    contacts, not the square of the number of links.
    """
    pb.performCollisionDetection(physicsClientId=client)
    contacts: dict[tuple[int, int], _Contact] = {}
    for point in pb.getContactPoints(bodyA=body, bodyB=body, physicsClientId=client):
        a, b = sorted((point[3], point[4]))
        if links.group[a] == links.group[b]:
            continue
        depth = -point[8] - links.margin_m[a] - links.margin_m[b]
        if depth > 0 and ((a, b) not in contacts or depth > contacts[(a, b)].depth_m):
            # Midway between the two surfaces' deepest points (pybullet's base frame is the model's).
            where = tuple(float(v) for v in (np.asarray(point[5]) + np.asarray(point[6])) / 2)
            contacts[(a, b)] = _Contact(depth, where)
    return contacts


def _gaps_at_rest(pb: Any, client: int, body: int, links: _Links) -> dict[frozenset[int], float]:
    """Everything at rest, the gap between each moving part (a joint's child with the parts
    welded to it) and each part it is not welded to, where under `_CLOSE_AT_REST_M`."""
    moving = {links.group[joint.index] for joint in links.joints}
    gaps: dict[frozenset[int], float] = {}
    for index in links.with_shapes:
        if links.group[index] not in moving:
            continue
        # Contact points are only overlaps; closest points within a distance see the gaps too.
        reach = _CLOSE_AT_REST_M + 2 * BULLET_MESH_MARGIN_M
        for point in pb.getClosestPoints(body, body, reach, linkIndexA=index, physicsClientId=client):
            a, b = point[3], point[4]
            gap = point[8] - links.margin_m[a] - links.margin_m[b]
            pair = frozenset((links.group[a], links.group[b]))
            if len(pair) == 2 and gap < min(_CLOSE_AT_REST_M, gaps.get(pair, math.inf)):
                gaps[pair] = gap
    return gaps


def _world_from_link(pb: Any, client: int, body: int, index: int) -> np.ndarray:
    """The URDF link frame in the world (pybullet's base pose is its inertial frame)."""
    if index >= 0:
        state = pb.getLinkState(body, index, computeForwardKinematics=True, physicsClientId=client)
        position, orientation = state[4], state[5]
    else:
        world_com = pb.getBasePositionAndOrientation(body, physicsClientId=client)
        info = pb.getDynamicsInfo(body, -1, physicsClientId=client)
        link_com = pb.invertTransform(info[3], info[4])
        position, orientation = pb.multiplyTransforms(world_com[0], world_com[1], link_com[0], link_com[1])
    pose = np.eye(4)
    pose[:3, :3] = np.reshape(pb.getMatrixFromQuaternion(orientation), (3, 3))
    pose[:3, 3] = position
    return pose


def _real_contacts(pb: Any, client: int, body: int, links: _Links, real: RealMeshes, contacts: dict) -> dict:
    """`contacts` without those between mesh hulls whose real surfaces do not meet."""
    kept = {}
    for (a, b), contact in contacts.items():
        if links.has_mesh[a] or links.has_mesh[b]:
            world_a, world_b = (_world_from_link(pb, client, body, i) for i in (a, b))
            if not real.touch(links.names[a], world_a, links.names[b], world_b):
                continue
        kept[(a, b)] = contact
    return kept


def _from_hinge_line_m(pb: Any, client: int, body: int, joint: _Joint, where_m: tuple) -> float:
    """Distance from `where_m` to the revolute joint's axis (the child's frame is on it)."""
    world_from_child = _world_from_link(pb, client, body, joint.index)
    axis = world_from_child[:3, :3] @ np.asarray(joint.axis)
    offset = np.asarray(where_m) - world_from_child[:3, 3]
    return float(np.linalg.norm(offset - (offset @ axis) / (axis @ axis) * axis))


def _at_hinge(links: _Links, joint: _Joint | None, pair: tuple[int, int]) -> bool:
    """Whether `pair` is the moved revolute joint's child (or a part welded to it) and its parent."""
    if joint is None or not joint.revolute:
        return False
    groups = {links.group[pair[0]], links.group[pair[1]]}
    return groups == {links.group[joint.index], links.group[joint.parent]}


def _where(contact: _Contact) -> str:
    x, y, z = contact.where_m
    return f"at ({x:.3f}, {y:.3f}, {z:.3f}) m"


def collision_problems(
    pb: Any, client: int, body: int, real: RealMeshes, options: CollisionOptions | None = None
) -> tuple[list[str], list[str], str]:
    """The penetrations found, the hinge lines that rub within the tolerance (warnings),
    and a one-line account of what was checked.

    Only the swept joint is moved, and put back at rest after its samples, so each
    configuration costs pybullet one collision pass, whatever the number of joints.
    """
    options = (options or CollisionOptions()).check()
    links = _Links(pb, client, body)
    for joint in links.joints:
        pb.resetJointState(body, joint.index, joint.rest, physicsClientId=client)
    gaps_at_rest = _gaps_at_rest(pb, client, body, links)
    close_at_rest = {joint.index for joint in links.joints if any(links.group[joint.index] in pair for pair in gaps_at_rest)}
    configurations = _configurations(links.joints, close_at_rest)
    problems: list[str] = []
    rubs: dict[str, tuple[float, str]] = {}  # the deepest rub of each joint
    at_rest: dict = {}
    deepest = 0.0
    for configuration in configurations:
        moved = configuration.joint
        if moved is not None:
            pb.resetJointState(body, moved.index, configuration.position, physicsClientId=client)
        contacts = _real_contacts(pb, client, body, links, real, _contacts(pb, client, body, links))
        # A pair already overlapping at rest is reported once, then again only if a joint drives it deeper.
        baseline = at_rest if configuration is not configurations[0] else {}
        for (a, b), contact in contacts.items():
            deepest = max(deepest, contact.depth_m)
            mesh = links.has_mesh[a] or links.has_mesh[b]
            allowed = options.mesh_penetration_tolerance_m if mesh else options.penetration_tolerance_m
            before = baseline[(a, b)].depth_m if (a, b) in baseline else 0.0
            if contact.depth_m <= before + allowed:
                continue
            said = f"{links.names[a]!r} and {links.names[b]!r} pass {contact.depth_m * 1000:.1f} mm into each other"
            if _at_hinge(links, moved, (a, b)):
                off_line = _from_hinge_line_m(pb, client, body, moved, contact.where_m)
                said += f" {_where(contact)}, {off_line * 1000:.0f} mm from its hinge line"
                # A front touching the body when shut has no clearance to rub with: that fails.
                touching = gaps_at_rest.get(frozenset((links.group[a], links.group[b])), math.inf) <= allowed
                if touching:
                    said += ", touching it at rest (no clearance)"
                elif off_line <= options.hinge_zone_m and contact.depth_m <= options.hinge_rub_tolerance_m:
                    if contact.depth_m > rubs.get(moved.name, (0.0, ""))[0]:
                        rubs[moved.name] = (contact.depth_m, f"{configuration.label}: {said}")
                    continue
            else:
                said += f" {_where(contact)}"
            problems.append(f"{configuration.label}: {said}")
        if moved is not None:
            pb.resetJointState(body, moved.index, moved.rest, physicsClientId=client)
        if configuration is configurations[0]:
            at_rest = contacts
    warnings_said = [
        f"rubs within {options.hinge_rub_tolerance_m * 1000:g} mm at a hinge line: {said}" for _, said in rubs.values()
    ]
    summary = (
        f"{count(links.pair_count(), 'link pair')} at {count(len(configurations), 'joint configuration')}; "
        f"deepest contact {deepest * 1000:.2f} mm (tolerance {options.penetration_tolerance_m * 1000:g} mm, "
        f"{options.mesh_penetration_tolerance_m * 1000:g} mm with a mesh, "
        f"{options.hinge_rub_tolerance_m * 1000:g} mm rubbing at a hinge line)"
    )
    return problems, warnings_said, summary


def collisions_check(urdf: Path, options: CollisionOptions | None = None, *, meshes: RealMeshes | None = None) -> Check:
    """Load `urdf` in this thread's pybullet DIRECT client and sweep its joints for penetrations;
    `meshes` are the links' collision meshes as read from the URDF (default: from `urdf`).

    Call only on a URDF the gate found safe for pybullet (a sound tree, meshes inside the folder).
    A pass names each hinge line that rubs within the tolerance (WARNING) with its depth.
    """
    error: str | None = None
    problems: list[str] = []
    rubs: list[str] = []
    summary = ""
    with captured_c_output() as output, warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        import pybullet as pb

        client = empty_pybullet_client()
        try:
            # Self-collision with parent and child included: every pair of links goes
            # through the broadphase; welded pairs are left out after. Contacts never see the
            # visual meshes, which pybullet would parse (a completed cup's 50,000-triangle
            # visual: 0.05 of a load's 0.06 CPU-s); the pybullet check loads them.
            flags = pb.URDF_USE_SELF_COLLISION | pb.URDF_USE_SELF_COLLISION_INCLUDE_PARENT | pb.URDF_IGNORE_VISUAL_SHAPES
            body = pb.loadURDF(str(urdf), useFixedBase=True, flags=flags, physicsClientId=client)
            problems, rubs, summary = collision_problems(pb, client, body, meshes or RealMeshes(urdf), options)
        except pb.error as exc:
            error = str(exc)
    if error is not None:
        said = pybullet_errors(output)
        return Check(CHECK_NAME, False, f"{error} {said}" if said else error)
    if rubs:
        summary += "; WARNING " + "; WARNING ".join(rubs)
    return check_from_problems(CHECK_NAME, problems, summary)
