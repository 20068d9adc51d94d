"""The exchange package: the one strict GLB reader (and every command that opens a .glb
giving one line for a corrupt one), the joint types and the Blender document's keys agreeing
with the add-on, which may not import homemodel."""

from __future__ import annotations

import ast
import json
import struct
from pathlib import Path

import pytest
from sample_house import build_house, cupboard_model
from typer.testing import CliRunner

from articulation import joint_types
from homemodel.core.errors import InputError
from homemodel.exchange import blender_document
from homemodel.exchange.blender_glb import model_document_from_glb
from homemodel.exchange.glb import BIN_CHUNK, JSON_CHUNK, pack_glb, read_glb
from homemodel.exchange.model_files import export_model

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def model_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("glb") / "cupboard"
    export_model(cupboard_model(), folder)
    return folder


def _patched(data: bytes, offset: int, value: int) -> bytes:
    out = bytearray(data)
    struct.pack_into("<I", out, offset, value)
    return bytes(out)


def _json_length(data: bytes) -> int:
    return struct.unpack_from("<I", data, 12)[0]


# name -> (how to corrupt a good GLB's bytes, what the error says)
CORRUPTIONS = {
    "truncated": (lambda d: d[: len(d) // 2], "the header says"),
    "version 1": (lambda d: _patched(d, 4, 1), "version 1"),
    "JSON chunk past the end": (lambda d: _patched(d, 12, len(d) * 4), "the JSON chunk"),
    "BIN chunk past the end": (lambda d: _patched(d, 20 + _json_length(d), len(d) * 4), "the BIN chunk"),
    "JSON chunk's type": (lambda d: _patched(d, 16, BIN_CHUNK), "not a JSON chunk"),
    "JSON text": (lambda d: d[:20] + b"{" * 4 + d[24:], "does not parse"),
    "too short": (lambda d: d[:16], "too short"),
}


def test_pack_glb_and_read_glb_round_trip_and_match_the_exporter(model_folder: Path) -> None:
    data = (model_folder / "model.glb").read_bytes()
    glb = read_glb(data)
    assert len(glb.doc["nodes"]) == 4 and len(glb.blob) == glb.doc["buffers"][0]["byteLength"]
    assert pack_glb(glb.doc, glb.blob) == data  # the exporter writes through pack_glb
    empty = read_glb(pack_glb({"asset": {"version": "2.0"}}))
    assert empty.doc == {"asset": {"version": "2.0"}} and empty.blob == b""
    assert struct.unpack_from("<I", pack_glb({"a": 1}, b"xyz"), 8)[0] % 4 == 0


@pytest.mark.parametrize("name", CORRUPTIONS)
def test_read_glb_refuses_each_corruption_by_name(model_folder: Path, name: str) -> None:
    corrupt, message = CORRUPTIONS[name]
    with pytest.raises(InputError, match=message):
        read_glb(corrupt((model_folder / "model.glb").read_bytes()))


def test_a_json_chunk_that_is_not_an_object_and_a_second_chunk_not_bin_are_refused() -> None:
    text = b"[1, 2]  "
    data = struct.pack("<4sII", b"glTF", 2, 20 + len(text)) + struct.pack("<II", len(text), JSON_CHUNK) + text
    with pytest.raises(InputError, match="not an object"):
        read_glb(data)
    good = pack_glb({"asset": {"version": "2.0"}}, b"\0" * 8)
    with pytest.raises(InputError, match="not a BIN chunk"):
        read_glb(_patched(good, 20 + _json_length(good) + 4, 0x12345678))


def _one_line_error(result, capfd, fragment: str) -> None:
    """Exit 2 and one line on stderr, counting what C code wrote to file descriptor 2."""
    c_stderr = capfd.readouterr().err
    assert result.exit_code == 2, result.output
    lines = (result.stderr + c_stderr).splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and fragment in lines[0], lines


def _house_map(folder: Path) -> Path:
    from homemodel.exchange.map_xml import save_map

    save_map(build_house(), folder / "map.xml")
    return folder / "map.xml"


COMMANDS = {
    "addon describe": lambda glb, folder, out: ["addon", "describe", str(glb), "--out", str(out / "doc.json")],
    "eval surface-distance": lambda glb, folder, out: ["eval", "surface-distance", str(glb), str(folder)],
    "eval voxel-iou": lambda glb, folder, out: ["eval", "voxel-iou", str(folder), str(glb)],
    "turntable simulate": lambda glb, folder, out: ["turntable", "simulate", str(glb), "--out", str(out / "capture")],
    "map add": lambda glb, folder, out: ["map", "add", str(_house_map(out)), str(glb), "--id", "cup", "--parent", "table"],
    "completion train": lambda glb, folder, out: ["completion", "train", str(glb.parents[1]), "--out", str(out / "model.npz")],
}
GLB_AT = {"completion train": "library/cup/corrupt.glb"}  # a library's mesh, in its class folder


def _files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("corruption", ["truncated", "version 1", "JSON chunk past the end", "BIN chunk past the end"])
@pytest.mark.parametrize("command", COMMANDS)
def test_a_corrupt_glb_is_one_line_of_error_to_every_command_that_reads_one(
    model_folder: Path, tmp_path: Path, capfd, command: str, corruption: str
) -> None:
    from homemodel.cli import app

    glb = tmp_path / GLB_AT.get(command, "corrupt.glb")
    glb.parent.mkdir(parents=True, exist_ok=True)
    glb.write_bytes(CORRUPTIONS[corruption][0]((model_folder / "model.glb").read_bytes()))
    args = COMMANDS[command](glb, model_folder, tmp_path)
    before = _files(tmp_path)
    capfd.readouterr()
    result = CliRunner().invoke(app, args)
    _one_line_error(result, capfd, str(glb))
    assert _files(tmp_path) == before  # nothing half-written, the map as it was


def test_validate_fails_a_corrupt_glb_with_the_reason_in_its_report(model_folder: Path, tmp_path: Path) -> None:
    from homemodel.cli import app

    glb = tmp_path / "corrupt.glb"
    glb.write_bytes(CORRUPTIONS["JSON chunk past the end"][0]((model_folder / "model.glb").read_bytes()))
    result = CliRunner().invoke(app, ["validate", str(glb)])
    assert result.exit_code == 1, result.output  # the gate's verdict, as for an unparseable URDF
    assert "cannot read the GLB: the JSON chunk" in result.output and "Traceback" not in result.output


def _blender_glb(nodes: list[dict], **doc) -> bytes:
    return pack_glb({"asset": {"version": "2.0"}, "nodes": nodes, **doc})


def test_a_blender_glb_whose_nodes_do_not_fit_is_an_input_error_naming_the_file(tmp_path: Path) -> None:
    model = json.dumps({"name": "cup", "category": "cup", "affordances": [], "properties": {}})
    keys = blender_document
    cases = {
        "accessor out of range": _blender_glb(
            [{"extras": {keys.MODEL: model, keys.LINK: "base"}, "mesh": 0}],
            meshes=[{"primitives": [{"attributes": {"POSITION": 5}, "indices": 6}]}],
        ),
        "hm_model not JSON": _blender_glb([{"extras": {keys.MODEL: "{", keys.LINK: "base"}}]),
        "two models": _blender_glb([{"extras": {keys.MODEL: model, keys.LINK: "a"}}, {"extras": {keys.MODEL: model, keys.LINK: "b"}}]),
    }
    for name, data in cases.items():
        path = tmp_path / f"{name}.glb"
        path.write_bytes(data)
        with pytest.raises(InputError, match=str(path)):
            model_document_from_glb(path)
    ok = tmp_path / "ok.glb"
    ok.write_bytes(_blender_glb([{"extras": {keys.MODEL: model, keys.LINK: "base"}}]))
    doc = model_document_from_glb(ok)
    assert doc["format"] == keys.MODEL_FORMAT and [link["name"] for link in doc["links"]] == ["base"]


def _module_constants(path: Path) -> dict[str, object]:
    """The module-level NAME = literal assignments of a file, read without importing it (the
    add-on's modules import bpy)."""
    constants = {}
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Name):
            try:
                constants[node.targets[0].id] = ast.literal_eval(node.value)
            except ValueError:
                continue
    return constants


def test_the_addon_spells_the_document_keys_and_joint_types_as_the_toolkit() -> None:
    rig = _module_constants(REPO / "blender_addons" / "rig.py")
    ours = {
        name: value
        for name, value in vars(blender_document).items()
        if name.isupper() and isinstance(value, str)
    }
    assert len(ours) == 19  # the format, FROM_MESHES and 17 hm_* keys
    assert {name: rig.get(name) for name in ours} == ours
    # every hm_* key the add-on's model scheme uses is one of ours
    hm_keys = {v for v in rig.values() if isinstance(v, str) and v.startswith("hm_")}
    assert hm_keys == {v for v in ours.values() if v.startswith("hm_")}
    for name in ADDON_JOINT_TYPE_LISTS:
        assert rig[name] == getattr(joint_types, name), name


# The add-on's copies of articulation.joint_types' lists (it may not import it), checked above.
ADDON_JOINT_TYPE_LISTS = ("JOINT_TYPES", "LIMITED_JOINT_TYPES", "ROTATING_JOINT_TYPES")


def test_joint_type_lists_are_defined_once() -> None:
    """No module but articulation.joint_types spells out a tuple of joint types (the add-on
    only its checked copies of them)."""
    names = set(joint_types.URDF_JOINT_TYPES)
    copies = {node.value.lineno for node in ast.parse((REPO / "blender_addons" / "rig.py").read_text()).body
              if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", None) in ADDON_JOINT_TYPE_LISTS}
    assert len(copies) == len(ADDON_JOINT_TYPE_LISTS)
    spelled = []
    for package in ("homemodel", "articulation", "semantic_map", "modeller", "turntable", "photogrammetry", "shape_completion",
                    "tracking", "blender_addons"):  # fmt: skip
        for path in (REPO / package).rglob("*.py"):
            if path.name == "joint_types.py":
                continue
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.Tuple | ast.List | ast.Set) and len(node.elts) >= 2:
                    values = {e.value for e in node.elts if isinstance(e, ast.Constant)}
                    copy = path.name == "rig.py" and path.parent.name == "blender_addons" and node.lineno in copies
                    if len(values) == len(node.elts) and values <= names and not copy:
                        spelled.append(f"{path.relative_to(REPO)}:{node.lineno}")
    assert spelled == []


def test_the_urdf_is_opened_in_one_place_with_its_root_and_size_checked(tmp_path: Path, model_folder: Path) -> None:
    from homemodel.core.limits import URDF_LINKS
    from homemodel.exchange.urdf import joints, links, mesh_elements, read_urdf_robot

    robot = read_urdf_robot(model_folder / "model.urdf")
    assert [link.get("name") for link in links(robot)] == [link.name for link in cupboard_model().links]
    assert len(joints(robot)) == len(cupboard_model().joints)
    roles = [role for _, role, _ in mesh_elements(robot)]
    assert roles and set(roles) <= {"visual", "collision"}
    not_robot = tmp_path / "map.urdf"
    not_robot.write_text("<apartment/>")
    with pytest.raises(InputError, match="expected <robot>"):
        read_urdf_robot(not_robot)
    huge = tmp_path / "huge.urdf"
    huge.write_text("<robot name='r'>" + "<link name='l'/>" * (URDF_LINKS.value + 1) + "</robot>")
    with pytest.raises(InputError, match=str(huge)):
        read_urdf_robot(huge)


def test_no_module_but_the_urdf_reader_walks_a_robot_s_links_or_joints() -> None:
    """The URDF walk is written once: nobody else searches <robot> for link or joint."""
    found = []
    for package in ("homemodel", "articulation", "semantic_map", "modeller", "tracking"):
        for path in (REPO / package).rglob("*.py"):
            text = path.read_text()
            for pattern in ('findall("link")', 'findall("joint")', 'iter("mesh")'):
                if pattern in text and path != REPO / "homemodel" / "exchange" / "urdf" / "__init__.py":
                    found.append(f"{path.relative_to(REPO)}: {pattern}")
    assert found == []
