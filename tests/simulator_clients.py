"""The simulators' own checks on an export, shared by the export tests: MuJoCo reading the
saved MJCF back from disk and stepping it, `ign sdf -k` (Gazebo's SDFormat checker), and
USD's validators."""

from __future__ import annotations

import os
import shutil
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

STEPS = 2000
DOOR_DEG = 45.0
DOOR_TOLERANCE_DEG = 2.0
DRAWER_TOLERANCE_M = 0.005
SMALL_OBJECT_TOLERANCE_M = 0.005
KNOB_TOLERANCE_DEG = 1.0


def load_mjcf(xml: Path):
    """Load the saved MJCF from another working directory, so only its own paths count."""
    import mujoco

    here = Path.cwd()
    os.chdir("/")
    try:
        return mujoco.MjModel.from_xml_path(str(xml))
    finally:
        os.chdir(here)


@dataclass
class MujocoFigures:
    door_drift_deg: dict[str, float] = field(default_factory=dict)  # revolute joints without states, set to 45°
    slide_drift_m: dict[str, float] = field(default_factory=dict)  # prismatic joints, set to mid-range
    free_drift_m: dict[str, float] = field(default_factory=dict)  # free bodies, from their initial pose
    knob_error_deg: dict[str, float] = field(default_factory=dict)  # worst over each knob's named states
    own_contacts: list[tuple[str, str]] = field(default_factory=list)  # bodies of one object touching


def _hinge_and_slide(model):
    import mujoco

    for j in range(model.njnt):
        if int(model.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            yield j, model.joint(j).name, model.jnt_qposadr[j]


def _passive_start(model, j: int) -> float:
    """45° for a door (or the middle of a narrower range), the middle for a slide."""
    import mujoco

    lower, upper = model.jnt_range[j]
    if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE:
        return float((lower + upper) / 2)
    target = np.radians(DOOR_DEG)
    return float(target if lower <= target <= upper else (lower + upper) / 2)


def mujoco_figures(xml: Path) -> MujocoFigures:
    """Step the saved scene: passive joints set mid-way must stay, free bodies must rest, and
    every actuated joint must reach each named state (its keyframes `<joint>=<state>`)."""
    import mujoco

    model = load_mjcf(xml)
    data = mujoco.MjData(model)
    figures = MujocoFigures()
    actuated = {model.actuator(a).name: a for a in range(model.nu)}
    passive = [(j, name, adr) for j, name, adr in _hinge_and_slide(model) if name not in actuated]
    mujoco.mj_resetData(model, data)
    starts = {name: _passive_start(model, j) for j, name, _ in passive}
    for j, name, adr in passive:
        data.qpos[adr] = starts[name]
    mujoco.mj_forward(model, data)
    free = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE]
    free_start = {j: data.qpos[model.jnt_qposadr[j] : model.jnt_qposadr[j] + 3].copy() for j in free}
    for contact in data.contact[: data.ncon]:
        a, b = model.body(model.geom_bodyid[contact.geom1]).name, model.body(model.geom_bodyid[contact.geom2]).name
        if a.split("__")[0] == b.split("__")[0] and "__" in a:
            figures.own_contacts.append((a, b))
    for _ in range(STEPS):
        mujoco.mj_step(model, data)
    for j, name, adr in passive:
        drift = float(data.qpos[adr] - starts[name])
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE:
            figures.slide_drift_m[name] = drift
        else:
            figures.door_drift_deg[name] = float(np.degrees(drift))
    for j in free:
        adr = model.jnt_qposadr[j]
        figures.free_drift_m[model.joint(j).name] = float(np.linalg.norm(data.qpos[adr : adr + 3] - free_start[j]))
    figures.knob_error_deg = _knob_errors(model, data, actuated)
    return figures


def _knob_errors(model, data, actuated: dict[str, int]) -> dict[str, float]:
    """Drive each actuated joint to each of its named states (from the keyframe names) from
    the initial state, all joints together, one state index at a time."""
    import mujoco

    states: dict[str, list[float]] = {}
    for k in range(model.nkey):
        joint, _, _state = model.key(k).name.partition("=")
        if joint in actuated:
            states.setdefault(joint, []).append(float(model.key_qpos[k][model.jnt_qposadr[model.joint(joint).id]]))
    worst = {joint: 0.0 for joint in states}
    for index in range(max((len(v) for v in states.values()), default=0)):
        mujoco.mj_resetDataKeyframe(model, data, model.key("initial").id)
        targets = {joint: values[index] for joint, values in states.items() if index < len(values)}
        for joint, target in targets.items():
            data.ctrl[actuated[joint]] = target
        for _ in range(STEPS // 2):
            mujoco.mj_step(model, data)
        for joint, target in targets.items():
            error = abs(float(data.qpos[model.jnt_qposadr[model.joint(joint).id]]) - target)
            worst[joint] = max(worst[joint], float(np.degrees(error)))
    return worst


def assert_mujoco_stable(figures: MujocoFigures) -> None:
    bad_doors = {k: round(v, 2) for k, v in figures.door_drift_deg.items() if abs(v) > DOOR_TOLERANCE_DEG}
    bad_slides = {k: round(v, 4) for k, v in figures.slide_drift_m.items() if abs(v) > DRAWER_TOLERANCE_M}
    bad_free = {k: round(v, 4) for k, v in figures.free_drift_m.items() if v > SMALL_OBJECT_TOLERANCE_M}
    bad_knobs = {k: round(v, 2) for k, v in figures.knob_error_deg.items() if v > KNOB_TOLERANCE_DEG}
    assert not bad_doors, f"doors moved from 45° by more than {DOOR_TOLERANCE_DEG}° (deg): {bad_doors}"
    assert not bad_slides, f"drawers moved by more than {DRAWER_TOLERANCE_M} m: {bad_slides}"
    assert not bad_free, f"small objects moved by more than {SMALL_OBJECT_TOLERANCE_M} m: {bad_free}"
    assert not bad_knobs, f"knobs missed a state by more than {KNOB_TOLERANCE_DEG}°: {bad_knobs}"
    assert not figures.own_contacts, f"parts of one object touch each other: {figures.own_contacts[:5]}"


def sdf_check(sdf: Path) -> tuple[bool, str]:
    """Gazebo's SDFormat check (`gz sdf -k`, named `ign sdf -k` in SDFormat 12 on Debian 12)."""
    tool = shutil.which("gz") or shutil.which("ign")
    assert tool is not None, "neither gz nor ign is installed; run `make setup` (ignition-tools, libsdformat-dev)"
    result = subprocess.run([tool, "sdf", "-k", str(sdf)], capture_output=True, text=True, timeout=120)
    said = (result.stdout + result.stderr).strip()
    return result.returncode == 0 and "Valid" in said, said


def sdf_check_together(sdfs: list[Path], merged: Path) -> tuple[bool, str]:
    """`sdf_check` of many exports in one run: their worlds side by side in one document at
    `merged` (each check's start and the loading of SDFormat's own spec are most of its
    0.8 CPU-s). On a failure each file is checked alone, so the message names the bad ones."""
    from lxml import etree

    documents = [etree.parse(str(sdf)).getroot() for sdf in sdfs]
    versions = {root.get("version") for root in documents}
    assert len(versions) == 1, f"the exports give SDFormat versions {versions}"
    together = etree.Element("sdf", version=versions.pop(), nsmap=documents[0].nsmap)
    for root in documents:
        together.extend(root.findall("world"))
    etree.ElementTree(together).write(str(merged), xml_declaration=True, encoding="utf-8")
    valid, said = sdf_check(merged)
    if valid:
        return True, said
    return False, "; ".join(f"{sdf}: {alone}" for sdf in sdfs for ok, alone in [sdf_check(sdf)] if not ok) or said


def usd_errors(path: Path) -> list[str]:
    """Every error USD's validators (stage metadata, physics joints, rigid bodies, colliders,
    articulations, composition) find in the stage, opened again from disk."""
    from pxr import Usd, UsdValidation

    stage = Usd.Stage.Open(str(path))
    context = UsdValidation.ValidationContext(UsdValidation.ValidationRegistry().GetOrLoadAllValidators())
    return [f"{e.GetName()}: {e.GetMessage()}" for e in context.Validate(stage)]
