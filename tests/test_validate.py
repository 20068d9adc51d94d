"""The validation gate: our URDF rules, the real clients (check_urdf, yourdfpy, pybullet),
the Khronos glTF validator, and `homemodel validate`'s exit codes."""

from __future__ import annotations

import json
import os
import struct
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh
import typer
from typer.testing import CliRunner

from homemodel.model_folder.gate import clients as gate_clients, gltf as gate_gltf, process as gate_process
from homemodel.model_folder.gate import resident_validator, validate as validate_module
from homemodel.model_folder.gate.clients import find_check_urdf
from homemodel.model_folder.gate.validate import validate_path

REPO = Path(__file__).resolve().parents[1]
RULE_CHECKS = ["kinematic tree", "finite numbers", "joint limits", "joint axes", "inertials", "meshes", "mesh geometry"]
URDF_CHECKS = ["safe XML", *RULE_CHECKS, "check_urdf", "yourdfpy", "pybullet", "collisions", "physics"]
GLTF_CHECKS = ["glTF validator", "glTF joints"]

# A cupboard body with a door (revolute), a drawer (prismatic), an oven-style knob
# (continuous, OBJ visual) and a massless handle frame (fixed). The <homemodel> element is
# the extension the exporter writes; its grasp point names a link that does not exist, which
# every check must ignore.
CUPBOARD = """<?xml version="1.0"?>
<robot name="cupboard">
  <homemodel category="cupboard"><affordance name="container"/><grasp_point name="door_handle" link="door_handle" kind="handle"><origin xyz="0 0 0" rpy="0 0 0"/></grasp_point><joint_state joint="knob" name="off" position="0"/></homemodel>
  <link name="body">
    <inertial><origin xyz="0 0 0.4"/><mass value="{mass}"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
    <collision><origin xyz="0 0 -0.01"/><geometry><box size="0.6 0.5 0.02"/></geometry></collision>
  </link>
  <link name="door">
    {door_inertial}
    <collision><origin xyz="0.25 0 0"/><geometry><box size="0.5 0.02 0.7"/></geometry></collision>
  </link>
  <link name="drawer">
    <inertial><mass value="1"/><inertia {drawer_inertia} ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.5 0.4 0.1"/></geometry></collision>
  </link>
  <link name="knob">
    <inertial><mass value="0.05"/><inertia ixx="1e-5" ixy="0" ixz="0" iyy="1e-5" iyz="0" izz="1e-5"/></inertial>
    <visual><geometry><mesh filename="{mesh}"/></geometry></visual>
  </link>
  <link name="handle_frame"/>
  <joint name="door_hinge" type="revolute">
    <parent link="body"/><child link="door"/>
    <origin xyz="-0.25 -0.26 0.5" rpy="0 0 0.1"/>
    <axis xyz="{axis}"/>
    <limit lower="{lower}" upper="{upper}" effort="10" velocity="1"/>
  </joint>
  <joint name="drawer_slide" type="prismatic">
    <parent link="body"/><child link="drawer"/>
    <origin xyz="0 -0.05 0.1" rpy="0 0 0"/>
    <axis xyz="0 -1 0"/>
    <limit lower="0" upper="0.4" effort="10" velocity="1"/>
  </joint>
  <joint name="knob" type="continuous">
    <parent link="body"/><child link="knob"/>
    <origin xyz="0.2 -0.26 0.75" rpy="1.5707963 0 0"/>
    <axis xyz="0 0 1"/>
  </joint>
  <joint name="handle" type="fixed">
    <parent link="door"/><child link="handle_frame"/>
    <origin xyz="0.45 -0.03 0"/>
  </joint>
</robot>
"""

DOOR_INERTIAL = (
    '<inertial><origin xyz="0.25 0 0"/><mass value="2"/>'
    '<inertia ixx="0.08" ixy="0" ixz="0" iyy="0.12" iyz="0" izz="0.04"/></inertial>'
)
GOOD = {
    "mass": "20",
    "axis": "0 0 1",
    "lower": "0",
    "upper": "1.57",
    "drawer_inertia": 'ixx="0.02" ixy="0" iyy="0.02" izz="0.03"',
    "mesh": "meshes/knob.obj",
    "door_inertial": DOOR_INERTIAL,
}


def write_cupboard(folder: Path, **changes: str) -> Path:
    """A model folder with `model.urdf` and `meshes/knob.obj`; returns the URDF."""
    (folder / "meshes").mkdir(parents=True, exist_ok=True)
    trimesh.creation.cylinder(radius=0.02, height=0.02, sections=16).export(folder / "meshes" / "knob.obj")
    urdf = folder / "model.urdf"
    urdf.write_text(CUPBOARD.format(**{**GOOD, **changes}))
    return urdf


def by_name(report) -> dict:
    return {c.name: c for c in report.checks}


def test_good_model_passes_every_check(tmp_path: Path) -> None:
    write_cupboard(tmp_path / "cupboard")
    report = validate_path(tmp_path / "cupboard")
    text = report.format()
    assert [c.name for c in report.checks] == URDF_CHECKS, text
    assert report.ok, text
    assert all(line.startswith("PASS") for line in text.splitlines()[1:-1])
    assert text.splitlines()[-1] == f"OK: all {len(URDF_CHECKS)} checks passed"
    assert "3 movable joints moved as declared" in by_name(report)["pybullet"].detail


def test_pybullet_refuses_a_missing_visual_mesh_without_building_visuals(tmp_path: Path) -> None:
    """pybullet loads without building visual shapes (`URDF_IGNORE_VISUAL_SHAPES`), yet still
    parses every visual element: a visual mesh that is not there fails its load."""
    present = gate_clients.pybullet_check(write_cupboard(tmp_path / "present"), None)
    assert present.detail.startswith("loaded")  # its joints not compared: no reading given
    urdf = write_cupboard(tmp_path / "missing")  # another path: pybullet keeps the meshes it read by path
    (tmp_path / "missing" / "meshes" / "knob.obj").unlink()
    missing = gate_clients.pybullet_check(urdf, None)
    assert not missing.passed and "Could not parse visual element for Link: knob" in missing.detail


def test_a_models_report_is_the_same_in_a_fresh_process_and_after_other_models(tmp_path: Path) -> None:
    """pybullet's client is kept per thread and emptied between uses: nothing of one model (its
    bodies, gravity, its joints' motors) reaches the next."""
    write_cupboard(tmp_path / "cupboard")
    write_cupboard(tmp_path / "tilted", axis="1 0 0", mass="0.5")  # its door swings about x, under gravity
    code = "import sys; from homemodel.model_folder.gate.validate import validate_path; print(validate_path(sys.argv[1]).format())"
    fresh = subprocess.run([sys.executable, "-c", code, str(tmp_path / "cupboard")], capture_output=True, text=True, check=True, cwd=REPO)
    validate_path(tmp_path / "tilted")
    validate_path(tmp_path / "cupboard")
    validate_path(tmp_path / "tilted")
    assert validate_path(tmp_path / "cupboard").format() == fresh.stdout.rstrip("\n")


def test_a_urdf_file_is_validated_like_its_folder(tmp_path: Path) -> None:
    urdf = write_cupboard(tmp_path)
    report = validate_path(urdf)
    assert report.ok, report.format()
    assert [c.name for c in report.checks] == URDF_CHECKS


def _corrupt_obj(folder: Path) -> str:
    (folder / "meshes").mkdir(parents=True, exist_ok=True)
    (folder / "meshes" / "corrupt.obj").write_text("v 0 0 0\nv 1 0 0\nf 1 2 9\n")
    return "meshes/corrupt.obj"


def _outside_obj(folder: Path) -> str:
    trimesh.creation.box().export(folder.parent / "outside.obj")
    return "../outside.obj"


def _absolute_obj(folder: Path) -> str:
    return str((folder.parent / _outside_obj(folder)).resolve())


def _symlink_out(folder: Path) -> str:
    (folder / "meshes").mkdir(parents=True, exist_ok=True)
    (folder / "meshes" / "link.obj").symlink_to(folder.parent / _outside_obj(folder))
    return "meshes/link.obj"


def _fifo(folder: Path) -> str:
    (folder / "meshes").mkdir(parents=True, exist_ok=True)
    os.mkfifo(folder / "meshes" / "fifo.obj")  # opening it would block pybullet for ever
    return "meshes/fifo.obj"


# Each case breaks exactly one rule: (changes, the failing check, words of its detail).
BROKEN = {
    "negative mass": ({"mass": "-5"}, "inertials", "mass -5 kg is not positive"),
    "zero axis": ({"axis": "0 0 0"}, "joint axes", "is zero"),
    "axis not unit": ({"axis": "0 0 2"}, "joint axes", "has length 2"),
    "lower above upper": ({"lower": "1", "upper": "0"}, "joint limits", "lower 1 is not below upper 0"),
    "lower equals upper": ({"lower": "0.5", "upper": "0.5"}, "joint limits", "not below"),
    "inertia not positive definite": (
        {"drawer_inertia": 'ixx="1" ixy="2" iyy="1" izz="1"'},
        "inertials",
        "not positive definite",
    ),
    "inertia breaks triangle inequality": (
        {"drawer_inertia": 'ixx="1" ixy="0" iyy="1" izz="5"'},
        "inertials",
        "triangle inequality",
    ),
    "geometry without inertial": ({"door_inertial": ""}, "inertials", "'door' has geometry but no <inertial>"),
    "missing mesh": ({"mesh": "meshes/missing.obj"}, "meshes", "no such file"),
    "mesh escaping the folder": ({"mesh": _outside_obj}, "meshes", "outside the model folder"),
    "symlink escaping the folder": ({"mesh": _symlink_out}, "meshes", "outside the model folder"),
    "absolute mesh path": ({"mesh": _absolute_obj}, "meshes", "absolute paths are not allowed"),
    "file URI": ({"mesh": "file:///etc/hostname.obj"}, "meshes", "URIs are not allowed"),
    "unresolvable package URI": ({"mesh": "package://elsewhere/knob.obj"}, "meshes", "cannot be resolved"),
    "corrupt OBJ": ({"mesh": _corrupt_obj}, "meshes", "corrupt.obj': line 3: face corner '9' names v 9"),
    "mesh is a FIFO": ({"mesh": _fifo}, "meshes", "not a regular file"),
}


@pytest.mark.parametrize("case", list(BROKEN))
def test_each_rule_is_caught_by_a_model_breaking_only_it(tmp_path: Path, case: str) -> None:
    changes, failing, words = BROKEN[case]
    folder = tmp_path / "model"
    folder.mkdir()
    values = {key: value(folder) if callable(value) else value for key, value in changes.items()}
    write_cupboard(folder, **values)
    report = validate_path(folder)
    checks = by_name(report)
    assert not report.ok
    assert not checks[failing].passed and words in checks[failing].detail, report.format()
    assert all(checks[name].passed for name in RULE_CHECKS if name != failing), report.format()


def test_package_uri_inside_the_folder_resolves(tmp_path: Path) -> None:
    write_cupboard(tmp_path / "model", mesh="package://model/meshes/knob.obj")
    assert by_name(validate_path(tmp_path / "model"))["meshes"].passed


@pytest.mark.parametrize(
    ("old", "new", "words"),
    [
        ('<link name="handle_frame"/>', '<link name="knob"/>', "duplicate link names ['knob']"),
        ('<parent link="door"/><child link="handle_frame"/>', '<parent link="nobody"/><child link="handle_frame"/>',
         "parent link 'nobody' does not exist"),
        ('<link name="handle_frame"/>', '<link name="handle_frame"/><link name="stray"/>', "exactly one root"),
        ('<joint name="knob" type', '<joint name="drawer_slide" type', "duplicate joint names ['drawer_slide']"),
        ('<parent link="door"/><child link="handle_frame"/>', '<parent link="handle_frame"/><child link="door"/>',
         "child of more than one joint"),
    ],
)
def test_kinematic_tree_faults(tmp_path: Path, old: str, new: str, words: str) -> None:
    urdf = write_cupboard(tmp_path)
    urdf.write_text(urdf.read_text().replace(old, new))
    checks = by_name(validate_path(urdf))
    assert not checks["kinematic tree"].passed and words in checks["kinematic tree"].detail
    # pybullet segfaults on several roots or duplicate names, so it is not run on these.
    assert checks["pybullet"].detail.startswith("not run: ")


@pytest.mark.parametrize(
    "changes",
    [
        {"mass": "-5"},
        {"axis": "0 0 0"},
        {"lower": "1", "upper": "0"},
        {"drawer_inertia": 'ixx="1" ixy="0" iyy="1" izz="5"'},
    ],
    ids=["negative mass", "zero axis", "lower above upper", "triangle inequality"],
)
def test_the_clients_themselves_accept_what_our_rules_reject(tmp_path: Path, changes: dict) -> None:
    """Why the rules exist: check_urdf, yourdfpy and pybullet load these broken files."""
    import pybullet
    import yourdfpy

    urdf = write_cupboard(tmp_path, **changes)
    assert subprocess.run([find_check_urdf(), str(urdf)], capture_output=True).returncode == 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # the zero axis divides by zero
        loaded = yourdfpy.URDF.load(str(urdf), build_scene_graph=True, load_meshes=False)
    # Each loads the whole tree: the cupboard's 5 links and 4 joints.
    assert (len(loaded.robot.links), len(loaded.robot.joints)) == (5, 4)
    client = pybullet.connect(pybullet.DIRECT)
    try:
        body = pybullet.loadURDF(
            str(urdf), useFixedBase=True, flags=pybullet.URDF_USE_INERTIA_FROM_FILE, physicsClientId=client
        )
        assert pybullet.getNumJoints(body, physicsClientId=client) == 4
    finally:
        pybullet.disconnect(physicsClientId=client)


def test_pybullet_pose_mismatch_is_caught(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    declared = gate_clients.declared_pose

    def off_by_a_millimetre(rest, joint, position: float) -> np.ndarray:
        pose = declared(rest, joint, position).copy()
        if joint.child == "drawer":
            pose[0, 3] += 1e-3
        return pose

    monkeypatch.setattr(gate_clients, "declared_pose", off_by_a_millimetre)
    write_cupboard(tmp_path)
    check = by_name(validate_path(tmp_path))["pybullet"]
    assert not check.passed
    assert "'drawer_slide': pybullet puts 'drawer' away from the declared pose at 3 of 3" in check.detail
    assert "0.001 m" in check.detail


def test_the_gate_prints_nothing(tmp_path: Path) -> None:
    """In a fresh process, where pybullet prints its build time on import and warnings on load."""
    write_cupboard(tmp_path, door_inertial="<inertial><mass value='1'/></inertial>")  # warns: no inertia
    code = "import sys; from homemodel.model_folder.gate.validate import validate_path; validate_path(sys.argv[1])"
    result = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path)], capture_output=True, text=True, cwd=REPO, timeout=60
    )
    assert result.returncode == 0, result.stderr
    assert (result.stdout, result.stderr) == ("", "")


def test_missing_check_urdf_fails_and_says_make_setup(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(gate_clients, "find_check_urdf", lambda: None)
    check = by_name(validate_path(write_cupboard(tmp_path)))["check_urdf"]
    assert not check.passed and "make setup" in check.detail


def test_a_hung_tool_is_killed_with_its_children() -> None:
    started = time.perf_counter()
    with pytest.raises(subprocess.TimeoutExpired), gate_process.BoundedRun(["sh", "-c", "sleep 30 & sleep 30"]) as run:
        run.result(timeout_s=0.3)
    assert time.perf_counter() - started < 5


def _live_members(group: int) -> list[int]:
    """The processes of `group` that are not zombies: a killed orphan stays a zombie, and a member
    of its group, until PID 1 reaps it, which some containers' PID 1 never does."""
    live = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            state, _, pgrp = stat.read_text().rsplit(")", 1)[1].split()[:3]
        except OSError:  # it ended meanwhile
            continue
        if int(pgrp) == group and state != "Z":
            live.append(int(stat.parent.name))
    return live


def test_a_tool_left_running_is_ended_with_its_children() -> None:
    # check_urdf runs beside the gate's own checks: a gate that stops early must not leave it.
    with gate_process.BoundedRun(["sh", "-c", "sleep 30 & sleep 30"]) as run:
        group = run.pid
    deadline = time.perf_counter() + 5
    while _live_members(group):
        if time.perf_counter() > deadline:
            pytest.fail(f"process group {group} still runs: {_live_members(group)}")
        time.sleep(0.02)


def test_a_tool_that_ended_unread_leaves_no_pipe_open() -> None:
    # The gate may stop early after check_urdf ended: its output pipes are closed all the same.
    fds = len(os.listdir("/proc/self/fd"))
    with gate_process.BoundedRun(["true"]) as run:
        deadline = time.perf_counter() + 5
        while Path(f"/proc/{run.pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z":
            assert time.perf_counter() < deadline, "`true` did not end"
            time.sleep(0.01)
    assert len(os.listdir("/proc/self/fd")) == fds


XXE = """<?xml version="1.0"?>
<!DOCTYPE robot [<!ENTITY secret SYSTEM "file:///etc/passwd">]>
<robot name="&secret;"><link name="body"/></robot>
"""
LAUGHS = (
    '<?xml version="1.0"?>\n<!DOCTYPE lolz [<!ENTITY lol "lol">'
    + "".join(f'<!ENTITY lol{i} "{("&lol" + str(i - 1) + ";") * 10 if i > 1 else "&lol;" * 10}">' for i in range(1, 10))
    + ']>\n<robot name="&lol9;"><link name="body"/></robot>\n'
)


@pytest.mark.parametrize(
    ("text", "words"),
    [(XXE, "DOCTYPE"), (LAUGHS, "DOCTYPE"), ("<robot name='x'><link name='body'></robot>", "not well-formed")],
    ids=["external entity", "billion laughs", "not well-formed"],
)
def test_unsafe_or_broken_xml_stops_at_the_first_check(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, text: str, words: str
) -> None:
    called: list[str] = []
    monkeypatch.setattr(gate_process.subprocess, "Popen", lambda *a, **k: called.append("subprocess"))
    monkeypatch.setattr(validate_module, "yourdfpy_check", lambda *a: called.append("yourdfpy"))
    monkeypatch.setattr(validate_module, "pybullet_check", lambda *a: called.append("pybullet"))
    monkeypatch.setattr(validate_module, "gltf_checks", lambda *a: called.append("gltf"))
    (tmp_path / "model.urdf").write_text(text)
    (tmp_path / "model.glb").write_bytes(b"not reached")
    started = time.perf_counter()
    report = validate_path(tmp_path)
    assert time.perf_counter() - started < 1.0
    assert [(c.name, c.passed) for c in report.checks] == [("safe XML", False)]
    assert words in report.checks[0].detail
    assert called == []


# --- glTF ---------------------------------------------------------------------------------


def minimal_glb() -> bytes:
    return trimesh.Scene(trimesh.creation.box(extents=(0.1, 0.2, 0.3))).export(file_type="glb")


def with_json(glb: bytes, edit) -> bytes:
    """`glb` with its JSON chunk changed by `edit(doc)`, repacked."""
    length, _ = struct.unpack_from("<II", glb, 12)
    doc = json.loads(glb[20 : 20 + length])
    edit(doc)
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text + glb[20 + length :]
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


def add_joints(*joints: dict):
    def edit(doc: dict) -> None:
        for joint in joints:
            doc["nodes"].append({"name": joint.get("name", "link"), "extras": {"joint": joint}})
            doc["scenes"][0]["nodes"].append(len(doc["nodes"]) - 1)

    return edit


DOOR = {"name": "door", "type": "revolute", "axis": [0.0, 0.0, 1.0], "lower": 0.0, "upper": 1.57}
HANDLE = {"name": "handle", "type": "fixed"}


def test_valid_glb_passes(tmp_path: Path) -> None:
    glb = tmp_path / "box.glb"
    glb.write_bytes(with_json(minimal_glb(), add_joints(DOOR, HANDLE)))
    report = validate_path(glb)
    assert [c.name for c in report.checks] == GLTF_CHECKS
    assert report.ok, report.format()
    assert "valid extras.joint on 2 nodes" in by_name(report)["glTF joints"].detail


def test_model_folder_with_glb_runs_every_check(tmp_path: Path) -> None:
    write_cupboard(tmp_path)
    (tmp_path / "model.glb").write_bytes(with_json(minimal_glb(), add_joints(DOOR)))
    report = validate_path(tmp_path)
    assert [c.name for c in report.checks] == URDF_CHECKS + GLTF_CHECKS
    assert report.ok, report.format()


def _bad_accessor(doc: dict) -> None:
    doc["accessors"][0]["count"] = 10_000


@pytest.mark.parametrize(
    "corrupt",
    [lambda glb: glb[: len(glb) // 2], lambda glb: with_json(glb, _bad_accessor)],
    ids=["truncated", "accessor past its buffer"],
)
def test_broken_glb_fails_the_khronos_validator(tmp_path: Path, corrupt) -> None:
    glb = tmp_path / "broken.glb"
    glb.write_bytes(corrupt(minimal_glb()))
    check = by_name(validate_path(glb))["glTF validator"]
    assert not check.passed
    assert "error" in check.detail


@pytest.mark.parametrize(
    ("joint", "words"),
    [
        ({**DOOR, "axis": [0, 0, 2]}, "has length 2"),
        ({**DOOR, "lower": 1.0, "upper": 0.0}, "lower 1.0 is not below upper 0.0"),
        ({**DOOR, "type": "hinge"}, "joint type 'hinge'"),
        ({"name": "knob", "type": "continuous"}, "axis None is not three numbers"),
    ],
)
def test_glb_joint_conventions(tmp_path: Path, joint: dict, words: str) -> None:
    glb = tmp_path / "model.glb"
    glb.write_bytes(with_json(minimal_glb(), add_joints(joint)))
    checks = by_name(validate_path(glb))
    assert checks["glTF validator"].passed
    assert not checks["glTF joints"].passed and words in checks["glTF joints"].detail


def test_one_validator_process_checks_many_models_and_a_hung_one_is_replaced(tmp_path: Path) -> None:
    """The gate keeps one node process for every GLB (starting one costs 250 ms a model); a
    validator that hangs is killed after the time bound and the next model gets a new one."""
    glb = tmp_path / "box.glb"
    glb.write_bytes(minimal_glb())
    first = gate_gltf.khronos_check(glb)
    process = resident_validator._resident.proc
    assert first.passed and gate_gltf.khronos_check(glb).passed
    assert resident_validator._resident.proc is process and process.poll() is None

    hangs = tmp_path / "hangs.sh"
    hangs.write_text("sleep 30\n")
    started = time.perf_counter()
    with pytest.raises(TimeoutError):
        resident_validator.validate_resident("sh", hangs, glb, timeout_s=0.3)
    assert time.perf_counter() - started < 5 and resident_validator._resident is None
    assert gate_gltf.khronos_check(glb).passed  # a fresh node process
    assert process.poll() is not None  # the first one was stopped when the command changed


def test_a_validator_that_dies_fails_the_check_with_what_it_said(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    dies = tmp_path / "validate_gltf.js"
    dies.write_text("process.stderr.write('out of memory'); process.exit(3);\n")
    monkeypatch.setattr(gate_gltf, "VALIDATOR_SCRIPT", dies)
    glb = tmp_path / "box.glb"
    glb.write_bytes(minimal_glb())
    check = gate_gltf.khronos_check(glb)
    assert not check.passed
    assert check.detail == "validator failed: the validator exited with status 3: out of memory"


def test_missing_node_fails_and_says_make_setup(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(gate_gltf.shutil, "which", lambda name: None)
    glb = tmp_path / "box.glb"
    glb.write_bytes(minimal_glb())
    check = by_name(validate_path(glb))["glTF validator"]
    assert not check.passed and "make setup" in check.detail


# --- command line -------------------------------------------------------------------------


@pytest.fixture
def cli() -> typer.Typer:
    from homemodel.cli.validate_command import validate

    app = typer.Typer()
    app.command()(validate)
    return app


def test_cli_exit_codes(tmp_path: Path, cli: typer.Typer) -> None:
    runner = CliRunner()
    write_cupboard(tmp_path / "good")
    write_cupboard(tmp_path / "bad", mass="-5")
    (tmp_path / "notes.txt").write_text("hello")

    good = runner.invoke(cli, [str(tmp_path / "good")])
    assert good.exit_code == 0 and "OK: all" in good.stdout
    bad = runner.invoke(cli, [str(tmp_path / "bad")])
    assert bad.exit_code == 1 and "FAIL  inertials" in bad.stdout
    for path in (tmp_path / "missing", tmp_path / "notes.txt"):
        result = runner.invoke(cli, [str(path)])
        assert result.exit_code == 2
        assert result.stdout == ""
        assert result.stderr.startswith("error: ") and len(result.stderr.splitlines()) == 1
