"""The gate's physics check, after the collision sweep: a model left alone stays put.

In a pybullet DIRECT client with gravity, the model's base fixed and its frame
upright (+z up): every movable joint is set at once to the middle of its range (a slide
along gravity, such as a jar's lid, to the end gravity pushes it to), held only by the
URDF's `<dynamics>` (pybullet applies the damping itself; the Coulomb friction is the usual
velocity motor with target 0 and the friction as its maximum force), and after
`SIMULATED_S` each must have moved less than `MAX_DRIFT_RAD` or `MAX_DRIFT_M`. The fronts of
a fixed base do not touch each other in this simulation (pybullet leaves self-collision
off), so setting them together tests each alone, in one simulation: the cost grows
linearly with the number of joints.

A small object (at most `SMALL_MAX_KG` and `SMALL_MAX_EXTENT_M` across) that stands in its
frame as homemodel's models do (its lowest point on z = 0, within `STANDING_TOLERANCE_M`) is
also set free on a floor there, its joints at rest, and must stay within `MAX_DRIFT_M`. A
model in another frame (a completed shape in its camera's) is not set down.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from articulation.joint_loads import STANDARD_GRAVITY_M_S2
from homemodel.core.c_stdio_capture import captured_c_output
from homemodel.model_folder.gate.clients import pybullet_errors
from homemodel.model_folder.gate.pybullet_world import declared_inertia_no_visuals, empty_pybullet_client
from homemodel.model_folder.gate.report import Check, check_from_problems, count

CHECK_NAME = "physics"
SIMULATED_S = 1.0
STEP_S = 1 / 240
MAX_DRIFT_RAD = math.radians(5.0)
MAX_DRIFT_M = 0.005
SMALL_MAX_KG = 5.0
SMALL_MAX_EXTENT_M = 0.5
STANDING_TOLERANCE_M = 0.005
_FLOOR_PROBE_M = 0.1
# A slide whose axis is within this angle of the vertical is one gravity drives to an end.
_VERTICAL_SLIDE_DEG = 45.0


@dataclass(frozen=True)
class JointDrift:
    name: str
    prismatic: bool
    start: float
    drift: float  # rad or m

    @property
    def passed(self) -> bool:
        # A NaN drift (a simulation that blew up) fails: NaN < bound is false.
        return self.drift < (MAX_DRIFT_M if self.prismatic else MAX_DRIFT_RAD)

    def format(self) -> str:
        if self.prismatic:
            return f"{self.name} moved {self.drift * 1000:.2f} mm from {self.start:.4g} m"
        return f"{self.name} moved {math.degrees(self.drift):.2f} deg from {math.degrees(self.start):.1f} deg"


def _movable(pb: Any, client: int, body: int) -> list[tuple]:
    infos = [pb.getJointInfo(body, i, physicsClientId=client) for i in range(pb.getNumJoints(body, physicsClientId=client))]
    return [info for info in infos if info[2] in (pb.JOINT_REVOLUTE, pb.JOINT_PRISMATIC)]


def _hold_with_friction(pb: Any, client: int, body: int, joints: list[tuple]) -> None:
    for info in joints:
        pb.setJointMotorControl2(
            body, info[0], pb.VELOCITY_CONTROL, targetVelocity=0.0, force=float(info[7]), physicsClientId=client
        )


def _world_axis(pb: Any, client: int, body: int, info: tuple) -> np.ndarray:
    state = pb.getLinkState(body, info[0], computeForwardKinematics=True, physicsClientId=client)
    rotation = np.reshape(pb.getMatrixFromQuaternion(state[5]), (3, 3))
    return rotation @ np.asarray(info[13], dtype=np.float64)


def _start_position(pb: Any, client: int, body: int, info: tuple) -> float:
    lower, upper = float(info[8]), float(info[9])
    if lower > upper:  # a continuous joint, which pybullet reports as 0 > -1
        return 0.0
    if info[2] == pb.JOINT_PRISMATIC:
        axis = _world_axis(pb, client, body, info)
        if abs(axis[2]) >= math.cos(math.radians(_VERTICAL_SLIDE_DEG)):
            return upper if axis[2] < 0 else lower
    return (lower + upper) / 2


def _simulate(pb: Any, client: int) -> None:
    pb.setGravity(0, 0, -STANDARD_GRAVITY_M_S2, physicsClientId=client)
    pb.setTimeStep(STEP_S, physicsClientId=client)
    for _ in range(round(SIMULATED_S / STEP_S)):
        pb.stepSimulation(physicsClientId=client)


def joint_drifts(pb: Any, client: int, urdf: Path) -> list[JointDrift]:
    """Each movable joint's drift in `SIMULATED_S`, all started together, the base fixed."""
    body = pb.loadURDF(str(urdf), useFixedBase=True, flags=declared_inertia_no_visuals(pb), physicsClientId=client)
    joints = _movable(pb, client, body)
    if not joints:
        return []
    starts = {}
    for info in joints:
        pb.resetJointState(body, info[0], 0.0, physicsClientId=client)
    for info in joints:
        starts[info[0]] = _start_position(pb, client, body, info)
    for info in joints:
        pb.resetJointState(body, info[0], starts[info[0]], physicsClientId=client)
    _hold_with_friction(pb, client, body, joints)
    _simulate(pb, client)
    return [
        JointDrift(
            name=info[1].decode(),
            prismatic=info[2] == pb.JOINT_PRISMATIC,
            start=starts[info[0]],
            drift=abs(pb.getJointState(body, info[0], physicsClientId=client)[0] - starts[info[0]]),
        )
        for info in joints
    ]


def _bounds(pb: Any, client: int, body: int) -> np.ndarray:
    boxes = [pb.getAABB(body, i, physicsClientId=client) for i in range(-1, pb.getNumJoints(body, physicsClientId=client))]
    corners = np.array([corner for box in boxes for corner in box], dtype=np.float64)
    return np.array([corners.min(axis=0), corners.max(axis=0)])


def _mass_kg(pb: Any, client: int, body: int) -> float:
    links = range(-1, pb.getNumJoints(body, physicsClientId=client))
    return sum(pb.getDynamicsInfo(body, i, physicsClientId=client)[0] for i in links)


def resting_drift_m(pb: Any, client: int, urdf: Path) -> float | None:
    """How far a small object set free on a floor under it moves in `SIMULATED_S`; None
    when the model is not a small object standing on z = 0."""
    body = pb.loadURDF(str(urdf), useFixedBase=False, flags=declared_inertia_no_visuals(pb), physicsClientId=client)
    bounds = _bounds(pb, client, body)
    if _mass_kg(pb, client, body) > SMALL_MAX_KG or (bounds[1] - bounds[0]).max() > SMALL_MAX_EXTENT_M:
        pb.removeBody(body, physicsClientId=client)
        return None
    # getAABB pads every box by the contact margin, so the floor is put a way below and
    # raised by the closest distance to it: it then touches the object's lowest point.
    below = float(bounds[0, 2]) - _FLOOR_PROBE_M
    shape = pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=client)
    floor = pb.createMultiBody(0.0, shape, basePosition=(0.0, 0.0, below), physicsClientId=client)
    closest = pb.getClosestPoints(body, floor, 2 * _FLOOR_PROBE_M, physicsClientId=client)
    if not closest:  # no collision geometry: nothing can rest on the floor
        return None
    lowest = below + min(p[8] for p in closest)
    if abs(lowest) > STANDING_TOLERANCE_M:
        return None
    pb.resetBasePositionAndOrientation(floor, (0.0, 0.0, lowest), (0, 0, 0, 1), physicsClientId=client)
    _hold_with_friction(pb, client, body, _movable(pb, client, body))
    start = np.array(pb.getBasePositionAndOrientation(body, physicsClientId=client)[0])
    _simulate(pb, client)
    end = np.array(pb.getBasePositionAndOrientation(body, physicsClientId=client)[0])
    return float(np.linalg.norm(end - start))


def physics_problems(urdf: Path) -> tuple[list[str], str, list[JointDrift], float | None]:
    """(problems, summary, every joint's drift, the small object's drift or None)."""
    import pybullet as pb

    drifts = joint_drifts(pb, empty_pybullet_client(), urdf)
    resting = resting_drift_m(pb, empty_pybullet_client(), urdf)
    problems = [f"{d.format()} in {SIMULATED_S:g} s, left alone" for d in drifts if not d.passed]
    if resting is not None and not resting < MAX_DRIFT_M:
        problems.append(f"set free on a floor, it moved {resting * 1000:.2f} mm in {SIMULATED_S:g} s")
    worst = max(drifts, key=lambda d: d.drift / (MAX_DRIFT_M if d.prismatic else MAX_DRIFT_RAD), default=None)
    summary = f"{count(len(drifts), 'joint')} left alone for {SIMULATED_S:g} s"
    summary += f"; most drift: {worst.format()}" if worst is not None else ""
    summary += f"; set free on a floor, moved {resting * 1000:.2f} mm" if resting is not None else ""
    return problems, summary, drifts, resting


def physics_check(urdf: Path) -> Check:
    """Call only on a URDF the gate found safe for pybullet."""
    with captured_c_output() as output, warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        import pybullet as pb

        try:
            problems, summary, _, _ = physics_problems(urdf)
        except pb.error as exc:
            said = pybullet_errors(output)
            return Check(CHECK_NAME, False, f"{exc} {said}" if said else str(exc))
    return check_from_problems(CHECK_NAME, problems, summary)
