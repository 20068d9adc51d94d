"""glTF checks: the Khronos validator (through node) and homemodel's joint extras."""

from __future__ import annotations

import math
import shutil
from pathlib import Path
from typing import Any

from articulation.joint_types import JOINT_TYPES, LIMITED_JOINT_TYPES
from homemodel.core.errors import InputError
from homemodel.core.node_packages import find_node_package, install_hint
from homemodel.exchange.glb import read_glb
from homemodel.model_folder.gate.report import Check, check_from_problems, count
from homemodel.model_folder.gate.resident_validator import ValidatorFailed, start_resident, validate_resident
from homemodel.model_folder.gate.urdf_rules import AXIS_UNIT_TOLERANCE

VALIDATOR_TIMEOUT_S = 60.0
# Shipped with the package; it runs the npm package gltf-validator, which is installed apart.
VALIDATOR_SCRIPT = Path(__file__).resolve().with_name("validate_gltf.js")
MESSAGES_SHOWN = 5


def start_khronos_validator() -> None:
    """Start the validator's node process ahead of `khronos_check` (its start is ~0.3 s that can
    overlap the work before the gate); without node or the package, nothing: the check says so."""
    node, package = shutil.which("node"), find_node_package("gltf-validator")
    if node is not None and package is not None:
        start_resident(node, VALIDATOR_SCRIPT, node_path=package.parent)


def khronos_check(glb: Path, timeout_s: float = VALIDATOR_TIMEOUT_S) -> Check:
    name = "glTF validator"
    node = shutil.which("node")
    if node is None:
        return Check(name, False, "node not found; run `make setup` (or install Node.js)")
    package = find_node_package("gltf-validator")
    if package is None:
        return Check(name, False, install_hint("gltf-validator"))
    try:
        reply = validate_resident(node, VALIDATOR_SCRIPT, glb, timeout_s, node_path=package.parent)
    except TimeoutError:
        return Check(name, False, f"timed out after {timeout_s:g} s")
    except (OSError, ValidatorFailed) as exc:
        return Check(name, False, f"validator failed: {exc}")
    report = reply.get("report")
    if not isinstance(report, dict):
        return Check(name, False, f"validator failed: {reply.get('error', reply)}")
    issues = report.get("issues", {})
    errors = [m for m in issues.get("messages", []) if m.get("severity") == 0]
    if issues.get("numErrors", 0) > 0:
        shown = "; ".join(
            f"{m.get('code')} at {m.get('pointer', m.get('offset', '?'))}: {m.get('message')}"
            for m in errors[:MESSAGES_SHOWN]
        )
        return Check(name, False, f"{count(issues['numErrors'], 'error')}: {shown}")
    return Check(name, True, f"0 errors, {count(issues.get('numWarnings', 0), 'warning')}")


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def joint_extras_problems(where: str, joint: Any) -> list[str]:
    if not isinstance(joint, dict):
        return [f"{where}: extras.joint is not an object"]
    kind = joint.get("type")
    if kind not in JOINT_TYPES:
        return [f"{where}: joint type {kind!r} is not one of {', '.join(JOINT_TYPES)}"]
    problems = []
    if kind != "fixed":
        axis = joint.get("axis")
        if not (isinstance(axis, list) and len(axis) == 3 and all(_number(v) for v in axis)):
            problems.append(f"{where}: axis {axis!r} is not three numbers")
        elif abs(math.hypot(*axis) - 1) >= AXIS_UNIT_TOLERANCE:
            problems.append(f"{where}: axis {axis} has length {math.hypot(*axis):.6g}, not 1")
    if kind in LIMITED_JOINT_TYPES:
        lower, upper = joint.get("lower"), joint.get("upper")
        if not (_number(lower) and _number(upper)):
            problems.append(f"{where}: lower {lower!r} and upper {upper!r} must be numbers")
        elif not lower < upper:
            problems.append(f"{where}: lower {lower} is not below upper {upper}")
    return problems


def joint_extras_check(glb: Path) -> Check:
    name = "glTF joints"
    try:
        doc = read_glb(glb.read_bytes()).doc
    except (InputError, OSError) as exc:
        return Check(name, False, f"cannot read the GLB: {exc}")
    problems: list[str] = []
    joints = 0
    nodes = doc.get("nodes", [])
    for i, node in enumerate(nodes if isinstance(nodes, list) else []):
        extras = node.get("extras") if isinstance(node, dict) else None
        if isinstance(extras, dict) and "joint" in extras:
            joints += 1
            problems += joint_extras_problems(f"node {node.get('name', i)!r}", extras["joint"])
    return check_from_problems(name, problems, f"valid extras.joint on {count(joints, 'node')}")


def gltf_checks(glb: Path) -> list[Check]:
    return [khronos_check(glb), joint_extras_check(glb)]
