"""The URDF clients a model must satisfy: check_urdf, yourdfpy and pybullet.

pybullet must also move every joint the way the URDF declares it, which we compare with
the forward kinematics of yourdfpy's reading of the URDF (its joints' origins and axes) at
the lower, middle and upper joint positions.
"""

from __future__ import annotations

import importlib.util
import math
import os
import re
import shutil
import subprocess
import sys
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from articulation.joint_types import MOVABLE_JOINT_TYPES
from homemodel.core.c_stdio_capture import captured_c_output
from homemodel.core.transforms import axis_angle_transform, translation_transform
from homemodel.model_folder.gate.process import BoundedRun, last_lines
from homemodel.model_folder.gate.pybullet_world import declared_inertia_no_visuals, empty_pybullet_client
from homemodel.model_folder.gate.report import Check, check_from_problems, count

CHECK_URDF_TIMEOUT_S = 30.0
POSITION_TOLERANCE_M = 1e-4
ROTATION_TOLERANCE_RAD = 1e-3
# Below this the child is taken not to move at all (pybullet works in about 1e-8).
STILL_TOLERANCE = 1e-7


def find_check_urdf() -> str | None:
    # The venv's bin folder first: cmeel-urdfdom installs check_urdf there, and a venv
    # used without activation is not on PATH.
    beside = Path(sys.executable).parent / "check_urdf"
    if beside.is_file() and os.access(beside, os.X_OK):
        return str(beside)
    return shutil.which("check_urdf")


def _check_urdf_command() -> tuple[str, dict[str, str] | None] | None:
    """The check_urdf executable to run and its environment (None: this process's).

    cmeel's `check_urdf` is a Python script that starts an interpreter to set the library
    path and run the binary in cmeel's prefix: 130 ms a model, against 4 ms for the binary.
    """
    script = find_check_urdf()
    if script is None:
        return None
    spec = importlib.util.find_spec("cmeel")
    if spec is not None and spec.origin is not None:
        prefix = Path(spec.origin).parent.parent / "cmeel.prefix"
        binary = prefix / "bin" / "check_urdf"
        if binary.is_file() and os.access(binary, os.X_OK):
            libraries = os.pathsep.join(filter(None, [str(prefix / "lib"), os.environ.get("LD_LIBRARY_PATH")]))
            return str(binary), {**os.environ, "LD_LIBRARY_PATH": libraries}
    return script, None


@contextmanager
def check_urdf_beside(urdf: Path, timeout_s: float = CHECK_URDF_TIMEOUT_S) -> Iterator[Callable[[], Check]]:
    """check_urdf started at once on `urdf` (a file the gate parsed safely), running in its own
    process while the block goes on; the block calls the function it is given for the check.
    Its 4-11 ms of waiting then pass beside the gate's own checks."""
    command = _check_urdf_command()
    if command is None:
        yield lambda: Check("check_urdf", False, "check_urdf not found (Python package cmeel-urdfdom); run `make setup`")
        return
    exe, env = command
    try:
        run = BoundedRun([exe, str(urdf)], env=env)
    except OSError as exc:
        yield lambda: Check("check_urdf", False, f"cannot run {exe}: {exc}")
        return
    with run:
        yield lambda: _check_urdf_result(run, timeout_s)


def _check_urdf_result(run: BoundedRun, timeout_s: float) -> Check:
    try:
        result = run.result(timeout_s)
    except subprocess.TimeoutExpired:
        return Check("check_urdf", False, f"timed out after {timeout_s:g} s")
    if result.returncode != 0:
        said = last_lines(result.stderr + "\n" + result.stdout)
        return Check("check_urdf", False, f"exit status {result.returncode}: {said}")
    return Check("check_urdf", True, "exit status 0")


def yourdfpy_check(urdf: Path) -> tuple[Check, Any]:
    """The check and the loaded `yourdfpy.URDF` (None when it did not load)."""
    import yourdfpy

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            model = yourdfpy.URDF.load(
                str(urdf), build_scene_graph=True, load_meshes=False, build_collision_scene_graph=False
            )
        except Exception as exc:  # yourdfpy raises whatever its parser or scene graph hits
            return Check("yourdfpy", False, f"{type(exc).__name__}: {exc}"), None
    detail = f"loaded {count(len(model.link_map), 'link')}, {count(len(model.joint_map), 'joint')}"
    if caught:
        detail += f"; {count(len(caught), 'warning')}, first: {caught[0].message}"
    return Check("yourdfpy", True, detail), model


def pybullet_errors(lines: list[str]) -> str:
    """pybullet's b3Error messages, which it prints as `b3Error[file,line]:\nmessage`."""
    text = "\n".join(lines)
    messages = re.findall(r"b3Error\[[^\]]*\]:\s*(.*?)(?=b3(?:Error|Warning)\[|\Z)", text, re.S)
    return " ".join(" ".join(m.split()) for m in messages if m.strip())


def declared_rest_poses(declared: Any) -> dict[str, np.ndarray]:
    """`root_from_link` of every link with every joint at zero, from yourdfpy's parsed joints.

    Walked once down the tree: asking yourdfpy's scene graph per link multiplies the whole
    path each time, which grows with the square of a long chain's length.
    """
    by_parent: dict[str, list[Any]] = {}
    for joint in declared.robot.joints:
        by_parent.setdefault(joint.parent, []).append(joint)
    poses = {declared.base_link: np.eye(4)}
    stack = [declared.base_link]
    while stack:
        parent = stack.pop()
        for joint in by_parent.get(parent, []):
            if joint.child not in poses:
                origin = np.eye(4) if joint.origin is None else joint.origin
                poses[joint.child] = poses[parent] @ origin
                stack.append(joint.child)
    return poses


def declared_pose(rest: dict[str, np.ndarray], joint: Any, position: float) -> np.ndarray:
    """`root_from_child` as the URDF declares it, `joint` at `position` and the others at zero."""
    origin = np.eye(4) if joint.origin is None else joint.origin
    axis = np.asarray(joint.axis, dtype=np.float64)
    if joint.type == "prismatic":
        motion = translation_transform(position * axis)
    else:
        motion = axis_angle_transform(axis, position)
    return rest[joint.parent] @ origin @ motion


def pose_error(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """Position (m) and rotation angle (rad) between two 4x4 poses; NaN propagates."""
    position = float(np.linalg.norm(a[:3, 3] - b[:3, 3]))
    cos = (np.trace(a[:3, :3].T @ b[:3, :3]) - 1) / 2
    rotation = float(np.arccos(np.clip(cos, -1.0, 1.0))) if np.isfinite(cos) else math.nan
    return position, rotation


def _samples(joint: Any) -> list[float]:
    if joint.type == "continuous":
        return [-math.pi, 0.0, math.pi]
    limit = joint.limit
    lower = float(limit.lower) if limit is not None and limit.lower is not None else 0.0
    upper = float(limit.upper) if limit is not None and limit.upper is not None else 0.0
    return [lower, (lower + upper) / 2, upper]


def _pybullet_pose(pb: Any, client: int, body: int, link_index: int) -> np.ndarray:
    state = pb.getLinkState(body, link_index, computeForwardKinematics=True, physicsClientId=client)
    pose = np.eye(4)
    pose[:3, :3] = np.reshape(pb.getMatrixFromQuaternion(state[5]), (3, 3))
    pose[:3, 3] = state[4]
    return pose


def kinematics_problems(pb: Any, client: int, body: int, declared: Any) -> list[str]:
    """Move each movable joint alone and compare pybullet's child pose with the declared one."""
    joint_count = pb.getNumJoints(body, physicsClientId=client)
    infos = [pb.getJointInfo(body, i, physicsClientId=client) for i in range(joint_count)]
    index_of = {info[1].decode(): info[0] for info in infos}
    pb_movable = [info[0] for info in infos if info[2] in (pb.JOINT_REVOLUTE, pb.JOINT_PRISMATIC)]
    actuated = set(declared.actuated_joint_names)
    rest = declared_rest_poses(declared)
    problems: list[str] = []
    # Every joint at zero, then only the joint under test moves and is put back, so each
    # sample costs the same whatever the number of joints.
    for i in pb_movable:
        pb.resetJointState(body, i, 0.0, physicsClientId=client)
    for joint in declared.robot.joints:
        if joint.type not in MOVABLE_JOINT_TYPES or joint.name not in actuated:
            continue
        if joint.name not in index_of:
            problems.append(f"joint {joint.name!r} is missing in pybullet")
            continue
        samples = _samples(joint)
        poses, off = [], []
        for q in samples:
            pb.resetJointState(body, index_of[joint.name], q, physicsClientId=client)
            simulated = _pybullet_pose(pb, client, body, index_of[joint.name])
            position_error, rotation_error = pose_error(simulated, declared_pose(rest, joint, q))
            # Written as `not (error < tolerance)` so a NaN pose fails.
            if not (position_error < POSITION_TOLERANCE_M and rotation_error < ROTATION_TOLERANCE_RAD):
                off.append(f"at {q:.4g}: {position_error:.3g} m, {rotation_error:.3g} rad")
            poses.append(simulated)
        pb.resetJointState(body, index_of[joint.name], 0.0, physicsClientId=client)
        if off:
            problems.append(
                f"joint {joint.name!r}: pybullet puts {joint.child!r} away from the declared pose "
                f"at {len(off)} of {len(samples)} positions ({off[0]})"
            )
        movement = max(max(pose_error(poses[0], p)) for p in poses[1:])
        if not movement > STILL_TOLERANCE:
            problems.append(f"joint {joint.name!r}: pybullet does not move {joint.child!r} over {samples}")
    return problems


def pybullet_check(urdf: Path, declared: Any) -> Check:
    """Load in this thread's DIRECT client with a fixed base and the file's inertias, its visual
    shapes not built (as the physics check loads it); move every joint."""
    error: str | None = None
    problems: list[str] = []
    # A zero axis makes yourdfpy's kinematics divide by zero; the NaN pose fails below.
    with captured_c_output() as output, warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        import pybullet as pb

        client = empty_pybullet_client()
        try:
            body = pb.loadURDF(
                str(urdf), useFixedBase=True, flags=declared_inertia_no_visuals(pb), physicsClientId=client
            )
            if declared is not None:
                problems = kinematics_problems(pb, client, body, declared)
        except pb.error as exc:
            error = str(exc)
        except Exception as exc:  # yourdfpy's kinematics on a broken model raise anything
            error = f"comparing joints failed: {type(exc).__name__}: {exc}"
    if error is not None:
        said = pybullet_errors(output)
        return Check("pybullet", False, f"{error} {said}" if said else error)
    if declared is None:
        return Check("pybullet", False, "loaded, but joints not compared: yourdfpy could not load the URDF")
    joints = sum(j.type in MOVABLE_JOINT_TYPES for j in declared.robot.joints)
    return check_from_problems("pybullet", problems, f"loaded; {count(joints, 'movable joint')} moved as declared")
