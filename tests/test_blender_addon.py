"""The installer's Blender extension, run headless in the bpy 5.0 module: every operator on
real inputs, checked against the model type, the validation gate and the map tools.

The extension calls the toolkit as a child process; HOMEMODEL_COMMAND points it at this
checkout's toolkit. Most tests start it through tests/toolkit_forkserver.py (a child process
running the same command line, forked from one that has imported it: 1.5-2 CPU-s less a
child); the tests asking for `real_toolkit`, the packaging test and the real-window tests start
`python -m homemodel` itself, so every command the extension calls runs as its own process too.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import zipfile
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest
import trimesh
from PIL import Image
from scipy.spatial import cKDTree

from articulation.model import Model
from homemodel.exchange.urdf.read import load_urdf
from turntable.reconstruct import STAGES as TURNTABLE_STAGES

pytestmark = pytest.mark.bpy

REPO = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}


def homemodel(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "homemodel", *args], capture_output=True, text=True, env=ENV)


def cli(*args: str) -> subprocess.CompletedProcess:
    """`homemodel ARGS` in this process, for the checks of what the extension wrote (the
    extension's own calls cross the process boundary); not for builds, whose Blender scene
    would land in this process's bpy."""
    from typer.testing import CliRunner

    from homemodel.cli import app

    result = CliRunner().invoke(app, list(args))
    return subprocess.CompletedProcess(list(args), result.exit_code, result.stdout, result.stderr)


REAL_TOOLKIT = f"{sys.executable} -m homemodel"


@pytest.fixture(scope="module")
def forked_toolkit(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """The HOMEMODEL_COMMAND of tests/toolkit_forkserver.py's server, for this module."""
    from toolkit_forkserver import started

    with started(tmp_path_factory.mktemp("toolkit") / "socket") as command:
        yield command


@pytest.fixture(scope="module")
def addon(forked_toolkit: str):
    """The extension registered in this process's bpy, the toolkit found through HOMEMODEL_COMMAND."""

    saved = {key: os.environ.get(key) for key in ("HOMEMODEL_COMMAND", "PYTHONPATH")}
    os.environ["HOMEMODEL_COMMAND"] = forked_toolkit
    os.environ["PYTHONPATH"] = ENV["PYTHONPATH"]
    import blender_addons

    blender_addons.register()
    yield blender_addons
    blender_addons.unregister()
    for key, value in saved.items():
        if value is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = value


@pytest.fixture
def real_toolkit(addon, monkeypatch: pytest.MonkeyPatch) -> None:
    """The extension's toolkit children are `python -m homemodel` itself in this test."""
    monkeypatch.setenv("HOMEMODEL_COMMAND", REAL_TOOLKIT)


@pytest.fixture
def scene(addon):
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene


@pytest.fixture(scope="module")
def kitchen(built_kitchen: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The Figure 47 kitchen built by `homemodel build` (the suite's shared build): map.xml and
    models/, copied, as a test writes a map beside them."""
    out = tmp_path_factory.mktemp("addon_kitchen") / "out"
    shutil.copytree(built_kitchen, out)
    return out


def _active():
    import bpy

    return bpy.context.active_object


def _same_model(a: Model, b: Model, *, mesh_tolerance_m: float = 1e-4) -> None:
    """Same links, joints, limits, states and grasp points; meshes within `mesh_tolerance_m`."""
    assert sorted(link.name for link in a.links) == sorted(link.name for link in b.links)
    joints_b = {j.name: j for j in b.joints}
    assert set(joints_b) == {j.name for j in a.joints}
    for ja in a.joints:
        jb = joints_b[ja.name]
        assert (ja.type, ja.parent, ja.child) == (jb.type, jb.parent, jb.child)
        np.testing.assert_allclose(ja.parent_from_joint, jb.parent_from_joint, atol=1e-6)
        np.testing.assert_allclose(ja.axis, jb.axis, atol=1e-6)
        if ja.limits is not None:
            assert jb.limits.lower == pytest.approx(ja.limits.lower, abs=1e-6)
            assert jb.limits.upper == pytest.approx(ja.limits.upper, abs=1e-6)
        assert [(s.name, pytest.approx(s.position, abs=1e-6)) for s in ja.states] == [(s.name, s.position) for s in jb.states]
    grasps_b = {g.name: g for g in b.grasp_points}
    assert set(grasps_b) == {g.name for g in a.grasp_points}
    for ga in a.grasp_points:
        assert ga.link == grasps_b[ga.name].link
        np.testing.assert_allclose(ga.link_from_grasp, grasps_b[ga.name].link_from_grasp, atol=1e-6)
    for link in a.links:
        other = b.link(link.name)
        assert len(link.visuals) == len(other.visuals), link.name
        if link.visuals:
            pa = np.vstack([trimesh.transform_points(v.mesh.vertices, v.link_from_visual) for v in link.visuals])
            pb = np.vstack([trimesh.transform_points(v.mesh.vertices, v.link_from_visual) for v in other.visuals])
            gap = max(cKDTree(pb).query(pa)[0].max(), cKDTree(pa).query(pb)[0].max())
            assert gap < mesh_tolerance_m, f"{link.name}: meshes {gap * 1000:.3f} mm apart"


# Packaging


def test_the_zip_builds_validates_and_installs_into_a_fresh_profile(tmp_path: Path) -> None:
    # What `make addon` runs: Blender's extension tool from the bpy wheel.
    import glob
    import sysconfig

    (tool,) = glob.glob(sysconfig.get_paths()["purelib"] + "/bpy/*/scripts/addons_core/bl_pkg/cli/blender_ext.py")
    zip_path = str(tmp_path / "homemodel.zip")
    built = subprocess.run([sys.executable, tool, "build", "--source-dir", str(REPO / "blender_addons"), "--output-filepath", zip_path], capture_output=True, text=True)
    assert built.returncode == 0, built.stdout + built.stderr
    validated = subprocess.run([sys.executable, tool, "validate", zip_path], capture_output=True, text=True)
    assert validated.returncode == 0 and "Success" in validated.stdout, validated.stdout + validated.stderr
    names = zipfile.ZipFile(tmp_path / "homemodel.zip").namelist()
    assert "blender_manifest.toml" in names and "__init__.py" in names and not any("__pycache__" in n for n in names)
    script = (
        "import sys, bpy\n"
        "print(bpy.ops.extensions.package_install_files(filepath=sys.argv[-1], repo='user_default', enable_on_install=True))\n"
        "print('enabled', 'bl_ext.user_default.homemodel' in bpy.context.preferences.addons)\n"
        "print('operators', bpy.ops.homemodel.build.idname(), bpy.ops.homemodel.export_home.idname())\n"
    )
    # A private profile: nothing is written to the user's Blender configuration.
    env = {**ENV, "BLENDER_USER_RESOURCES": str(tmp_path / "profile")}
    installed = subprocess.run([sys.executable, "-c", script, str(tmp_path / "homemodel.zip")], capture_output=True, text=True, env=env)
    assert "enabled True" in installed.stdout, installed.stdout + installed.stderr
    assert "HOMEMODEL_OT_build HOMEMODEL_OT_export_home" in installed.stdout
    assert (tmp_path / "profile" / "extensions" / "user_default" / "homemodel" / "rig.py").is_file()


def test_a_missing_toolkit_is_one_line_saying_what_to_do(scene, monkeypatch) -> None:
    import bpy

    from blender_addons import properties

    monkeypatch.setenv("HOMEMODEL_COMMAND", "/nonexistent/homemodel")
    monkeypatch.setattr(properties, "_KINDS", {})
    with pytest.raises(RuntimeError, match="homemodel toolkit was not found.*Preferences"):
        bpy.ops.homemodel.form_kind()


# Build from measurements


def test_every_catalogue_kind_has_a_form_that_gives_back_its_spec(addon) -> None:
    from blender_addons import spec_form
    from homemodel.app.blender.spec_forms import spec_kinds
    from modeller.kinds import SPEC_TYPES

    kinds = spec_kinds()
    assert set(kinds) == set(SPEC_TYPES)
    assert all((REPO / "examples" / "catalogue" / f"{kind}.yaml").is_file() for kind in kinds)
    for kind, entry in kinds.items():
        rows = spec_form.rows_for(entry["schema"], entry["example"])
        spec = spec_form.spec_from_rows(kind, rows)
        assert SPEC_TYPES[kind].model_validate(spec) == SPEC_TYPES[kind].model_validate(entry["example"]), kind
        for row in rows:
            assert row["kind"] in ("number", "integer", "bool", "enum", "text", "group", "list", "item")
            if row["path"].endswith("_m"):
                assert row["unit"] == "m"
    cupboard = {row["path"]: row for row in spec_form.rows_for(kinds["cupboard"]["schema"], kinds["cupboard"]["example"])}
    assert cupboard["depth_m"]["help"] == "depth of the body, without doors and handles"
    assert cupboard["doors"]["kind"] == "list" and cupboard["doors.1.hinge"]["value"] == "right"
    assert {"left", "right", "top"} <= set(cupboard["doors.1.hinge"]["options"])


def test_list_fields_get_add_and_remove(scene) -> None:
    import bpy

    form = scene.homemodel_form
    form.kind = "cupboard"
    bpy.ops.homemodel.form_kind()
    paths = {row.path for row in form.rows}
    assert "doors.1.width_m" in paths and "doors.2.width_m" not in paths
    bpy.ops.homemodel.form_add_item(path="doors")
    assert "doors.2.width_m" in {row.path for row in form.rows}
    bpy.ops.homemodel.form_remove_item(path="doors.0")
    bpy.ops.homemodel.form_remove_item(path="doors.0")
    doors = [row for row in form.rows if row.path.startswith("doors.") and row.path.endswith(".hinge")]
    assert [row.path for row in doors] == ["doors.0.hinge"] and doors[0].choice == "right"


def test_an_impossible_measurement_is_shown_at_its_field_and_adds_nothing(real_toolkit, scene) -> None:
    import bpy

    form = scene.homemodel_form
    form.kind = "table"
    bpy.ops.homemodel.form_kind()
    height = next(row for row in form.rows if row.path == "height_m")
    height.number = -0.2
    with pytest.raises(RuntimeError, match="height_m"):
        bpy.ops.homemodel.build()
    assert len(bpy.data.objects) == 0
    assert "greater than 0" in height.error and form.message.startswith("height_m")
    assert [row.path for row in form.rows if row.error] == ["height_m"]


@pytest.mark.slow
def test_build_a_cupboard_at_the_cursor_then_edit_and_rebuild_it_in_place(cupboard_dir: Path, scene) -> None:
    import bpy
    from mathutils import Matrix

    from blender_addons import home, rig

    form = scene.homemodel_form
    form.kind = "cupboard"
    bpy.ops.homemodel.form_kind()
    scene.cursor.location = (1.0, 2.0, 0.0)
    assert bpy.ops.homemodel.build() == {"FINISHED"}
    root = _active()
    assert tuple(root.matrix_world.translation) == pytest.approx((1.0, 2.0, 0.0))
    expected = load_urdf(cupboard_dir / "model.urdf")
    assert {j[rig.JOINT] for j in rig.joints_of(root)} == {j.name for j in expected.joints}
    assert json.loads(root[rig.SPEC])["width_m"] == 1.2
    # Placed in a room and turned, then re-measured: 0.56 m becomes 0.6 m deep.
    bpy.ops.homemodel.add_room(name="Kitchen")
    bpy.ops.homemodel.place(small=False)
    root.matrix_world = Matrix.Translation((3.0, 1.0, 0.0)) @ Matrix.Rotation(math.pi / 2, 4, "Z")
    home.add_parking(root, "front", Matrix.Translation((3.0, 2.0, 0.0)), True)
    assert bpy.ops.homemodel.edit_measurements() == {"FINISHED"}
    rows = {row.path: row for row in form.rows}
    rows["depth_m"].number = 0.6
    assert bpy.ops.homemodel.rebuild() == {"FINISHED"}
    new = _active()
    assert json.loads(new[rig.SPEC])["depth_m"] == 0.6
    np.testing.assert_allclose(np.array(new.matrix_world), np.array(Matrix.Translation((3.0, 1.0, 0.0)) @ Matrix.Rotation(math.pi / 2, 4, "Z")), atol=1e-6)
    assert home.room_of(new)[home.ROOM] == "kitchen" and [p[home.PARKING] for p in home.parking_of(new)] == ["front"]
    assert len(home.model_roots(scene)) == 1


# Joints


@pytest.fixture(scope="module")
def cupboard_dir(catalogue) -> Path:
    catalogue["cupboard"]  # builds and exports it
    return catalogue._out_dir / "cupboard"


CUPBOARD_AT_M = (0.5, -1.0, 0.0)


@pytest.fixture(scope="module")
def imported_cupboard(addon, cupboard_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The catalogue cupboard imported by the extension at the 3D cursor, saved: the tests that
    start from it open the file rather than each running the toolkit's `addon describe` on the
    same folder (1.8 CPU-s a child)."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.context.scene.cursor.location = CUPBOARD_AT_M
    assert bpy.ops.homemodel.import_model(filepath=str(cupboard_dir / "model.urdf")) == {"FINISHED"}
    blend = tmp_path_factory.mktemp("imported_cupboard") / "cupboard.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    return blend


def _open_cupboard(blend: Path):
    """The saved import opened; its model root, made the active object as after the import."""
    import bpy

    from blender_addons import rig

    bpy.ops.wm.open_mainfile(filepath=str(blend))
    root = next(o for o in bpy.data.objects if rig.MODEL in o)
    bpy.context.view_layer.objects.active = root
    return root


def test_a_slider_at_30_degrees_puts_the_door_where_the_model_says(imported_cupboard: Path, cupboard_dir: Path) -> None:
    import bpy

    from blender_addons import rig

    root = _open_cupboard(imported_cupboard)
    np.testing.assert_allclose(np.array(root.matrix_world)[:3, 3], CUPBOARD_AT_M, atol=1e-6)  # placed at the cursor
    model = load_urdf(cupboard_dir / "model.urdf")
    joints = {j[rig.JOINT]: j for j in rig.joints_of(root)}
    positions = {"door_0_hinge": math.radians(30), "drawer_1_slide": 0.2}
    for name, q in positions.items():
        rig.set_position(joints[name], q)
    bpy.context.view_layer.update()
    world_from_root = np.array(root.matrix_world)
    expected = model.world_from_links(positions)
    for link in rig.links_of(root):
        np.testing.assert_allclose(np.array(link.matrix_world), world_from_root @ expected[link[rig.LINK]], atol=1e-5)
    # The slider is limited to the joint's range, in degrees or millimetres.
    door = joints["door_0_hinge"]
    ui = door.id_properties_ui(rig.POSITION).as_dict()
    assert (ui["min"], ui["max"], ui["subtype"]) == (0.0, pytest.approx(math.radians(100)), "ANGLE")
    assert joints["drawer_1_slide"].id_properties_ui(rig.POSITION).as_dict()["subtype"] == "DISTANCE"
    from blender_addons.model_operators import joint_display

    assert joint_display(door) == "30°" and joint_display(joints["drawer_1_slide"]) == "200 mm"
    bpy.context.view_layer.objects.active = root
    assert bpy.ops.homemodel.rest() == {"FINISHED"}
    assert all(j[rig.POSITION] == 0.0 for j in joints.values())


@pytest.fixture(scope="module")
def oven_dir(catalogue) -> Path:
    catalogue["oven"]  # builds and exports it
    return catalogue._out_dir / "oven"


def test_named_states_set_a_knob(oven_dir: Path, scene) -> None:
    import bpy

    from blender_addons import rig

    assert bpy.ops.homemodel.import_model(filepath=str(oven_dir / "model.urdf")) == {"FINISHED"}
    knob = next(j for j in rig.joints_of(_active()) if json.loads(j[rig.STATES]))
    states = json.loads(knob[rig.STATES])
    assert bpy.ops.homemodel.set_joint_state(joint_object=knob.name, position=states[2]["position"]) == {"FINISHED"}
    assert knob[rig.POSITION] == pytest.approx(states[2]["position"])


# Import and export


@pytest.mark.slow
def test_import_then_export_with_no_edits_gives_the_same_model(real_toolkit, imported_cupboard: Path, cupboard_dir: Path, tmp_path: Path) -> None:
    import bpy

    from blender_addons import rig
    from blender_addons.model_operators import GATE_REPORT

    _open_cupboard(imported_cupboard)
    rig.set_position(rig.joints_of(_active())[0], 0.5)  # a joint left open does not change the model
    assert bpy.ops.homemodel.export_model(directory=str(tmp_path / "out")) == {"FINISHED"}
    assert GATE_REPORT[-1].startswith("OK: all")
    _same_model(load_urdf(cupboard_dir / "model.urdf"), load_urdf(tmp_path / "out" / "model.urdf"))
    assert cli("validate", str(tmp_path / "out")).returncode == 0


def _colour_per_triangle(model: Model) -> tuple[np.ndarray, np.ndarray]:
    """Each textured triangle's centre (in its link) and the texture colour at its centre's UV."""
    centres, colours = [], []
    for link in model.links:
        for visual in link.visuals:
            if visual.material.texture is None:
                continue
            image = np.asarray(Image.open(visual.material.texture).convert("RGB"), dtype=np.float64)
            uv = visual.uv[visual.mesh.faces].mean(axis=1)
            rows = np.clip(((1 - uv[:, 1]) * image.shape[0]).astype(int), 0, image.shape[0] - 1)
            cols = np.clip((uv[:, 0] * image.shape[1]).astype(int), 0, image.shape[1] - 1)
            centres.append(trimesh.transform_points(visual.mesh.triangles_center, visual.link_from_visual))
            colours.append(image[rows, cols])
    return np.vstack(centres), np.vstack(colours)


@pytest.mark.slow
def test_photo_textures_survive_import_and_export(scene, tmp_path: Path) -> None:
    """The photo-textured packet, imported and exported with no edits: the same colour shows on
    every triangle, read through the exported UVs from the exported image."""
    import bpy

    from blender_addons.model_operators import GATE_REPORT

    packet = tmp_path / "packet"
    built = homemodel("addon", "build", str(REPO / "examples" / "textured" / "packet.yaml"), "--out", str(packet))
    assert built.returncode == 0, built.stderr
    source = load_urdf(packet / "model.urdf")
    photos = {v.material.texture.name for link in source.links for v in link.visuals if v.material.texture}
    bpy.ops.homemodel.import_model(filepath=str(packet / "model.urdf"))
    images = [i for i in bpy.data.images if i.source == "FILE"]
    assert sorted(i.name for i in images) == sorted(photos) and len(photos) == 3  # front, side, top
    assert all(i.size[0] > 0 for i in images)  # loaded in Blender
    assert bpy.ops.homemodel.export_model(directory=str(tmp_path / "out")) == {"FINISHED"}
    assert GATE_REPORT[-1].startswith("OK: all")
    centres, colours = _colour_per_triangle(source)
    centres_out, colours_out = _colour_per_triangle(load_urdf(tmp_path / "out" / "model.urdf"))
    assert len(centres_out) == len(centres) > 0
    gap, match = cKDTree(centres_out).query(centres)
    assert gap.max() < 1e-5
    assert np.abs(colours_out[match] - colours).max() <= 2.0  # the same pixel, not merely a similar one
    assert np.ptp(colours, axis=0).max() > 50  # the texture is a photo, not a flat colour


def _partnet_folder(folder: Path) -> Path:
    """A PartNet-Mobility-style object: mobility.urdf, OBJ parts in textured_objs/, a base
    link without inertial, a lid on a revolute hinge, a slider and a wheel that turns for ever."""
    (folder / "textured_objs").mkdir(parents=True)
    trimesh.creation.box((0.4, 0.3, 0.2)).export(folder / "textured_objs" / "original-1.obj")
    trimesh.creation.box((0.4, 0.3, 0.02)).export(folder / "textured_objs" / "original-2.obj")
    trimesh.creation.box((0.1, 0.1, 0.02)).export(folder / "textured_objs" / "original-3.obj")
    (folder / "mobility.urdf").write_text(
        """<?xml version="1.0"?>
<robot name="partnet_12345">
  <link name="base"/>
  <link name="link_0">
    <visual name="body"><origin xyz="0 0 0"/><geometry><mesh filename="textured_objs/original-1.obj"/></geometry></visual>
    <collision><origin xyz="0 0 0"/><geometry><mesh filename="textured_objs/original-1.obj"/></geometry></collision>
  </link>
  <link name="link_1">
    <visual name="lid"><origin xyz="0.2 0 0.011"/><geometry><mesh filename="textured_objs/original-2.obj"/></geometry></visual>
    <collision><origin xyz="0.2 0 0.011"/><geometry><mesh filename="textured_objs/original-2.obj"/></geometry></collision>
  </link>
  <link name="link_2">
    <visual name="tab"><origin xyz="0 0 0"/><geometry><mesh filename="textured_objs/original-3.obj"/></geometry></visual>
  </link>
  <link name="link_3">
    <visual name="wheel"><origin xyz="0 0 0.02"/><geometry><cylinder radius="0.03" length="0.02"/></geometry></visual>
  </link>
  <joint name="joint_0" type="fixed"><origin rpy="1.570796326794897 0 -1.570796326794897" xyz="0 0 0"/>
    <child link="link_0"/><parent link="base"/></joint>
  <joint name="joint_1" type="revolute"><origin xyz="-0.2 0 0.1"/><axis xyz="0 -1 0"/>
    <child link="link_1"/><parent link="link_0"/><limit lower="0" upper="1.9"/></joint>
  <joint name="joint_2" type="prismatic"><origin xyz="0 0 0.3"/><axis xyz="1 0 0"/>
    <child link="link_2"/><parent link="link_0"/><limit lower="0" upper="0.1"/></joint>
  <joint name="joint_3" type="continuous"><origin xyz="0.15 0.1 0.11"/><axis xyz="0 0 1"/>
    <child link="link_3"/><parent link="link_0"/></joint>
</robot>
"""
    )
    return folder


@pytest.mark.slow
def test_a_partnet_mobility_urdf_imports_rigged_and_exports_through_the_gate(scene, tmp_path: Path) -> None:
    import bpy

    from blender_addons import rig

    folder = _partnet_folder(tmp_path / "12345")
    assert bpy.ops.homemodel.import_model(filepath=str(folder / "mobility.urdf")) == {"FINISHED"}
    root = _active()
    joints = {j[rig.JOINT]: j for j in rig.joints_of(root)}
    assert set(joints) == {"joint_0", "joint_1", "joint_2", "joint_3"}
    assert joints["joint_3"].id_properties_ui(rig.POSITION).as_dict()["max"] == pytest.approx(2 * math.pi)
    rig.set_position(joints["joint_1"], 1.0)
    bpy.context.view_layer.update()
    model = load_urdf(folder / "mobility.urdf")
    expected = np.array(root.matrix_world) @ model.world_from_links({"joint_1": 1.0})["link_1"]
    np.testing.assert_allclose(np.array(next(link for link in rig.links_of(root) if link[rig.LINK] == "link_1").matrix_world), expected, atol=1e-5)
    rig.set_position(joints["joint_1"], 0.0)
    assert bpy.ops.homemodel.export_model(directory=str(tmp_path / "out")) == {"FINISHED"}
    from blender_addons.model_operators import GATE_REPORT
    from homemodel.model_folder.gate.validate import validate_path

    # PartNet gives no inertials, nor a limit's effort and velocity (check_urdf wants them):
    # the export still lacks the inertials the original lacks, and gains the limits' defaults.
    original = [c.name for c in validate_path(folder).checks if not c.passed]
    assert original == ["inertials", "check_urdf"]
    assert [line.split()[1] for line in GATE_REPORT if line.startswith("FAIL ")] == ["inertials"]
    _same_model(model, load_urdf(tmp_path / "out" / "model.urdf"))


@pytest.mark.slow
def test_edits_by_hand_survive_the_export(imported_cupboard: Path, cupboard_dir: Path, tmp_path: Path) -> None:
    import bpy

    from blender_addons import rig

    root = _open_cupboard(imported_cupboard)
    links = {link[rig.LINK]: link for link in rig.links_of(root)}
    # Move a handle 2 cm up, add a shelf to the body, change a door's limit.
    handle = next(o for o in rig.owned(links["drawer_0_handle"]) if o.type == "MESH")
    handle.location.z += 0.02
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, -0.2, 0.65))
    shelf = _active()
    shelf.scale = (0.4, 0.3, 0.009)
    shelf.parent = links["body"]
    shelf.matrix_parent_inverse = links["body"].matrix_world.inverted()
    bpy.context.view_layer.objects.active = links["door_0"]
    assert bpy.ops.homemodel.edit_joint(joint_type="revolute", axis=(0, 0, -1), lower=0.0, upper=1.2) == {"FINISHED"}
    bpy.context.view_layer.objects.active = root
    assert bpy.ops.homemodel.export_model(directory=str(tmp_path / "out")) == {"FINISHED"}
    before, after = load_urdf(cupboard_dir / "model.urdf"), load_urdf(tmp_path / "out" / "model.urdf")
    assert after.joint("door_0_hinge").limits.upper == pytest.approx(1.2)
    assert len(after.link("body").visuals) == len(before.link("body").visuals) + 1
    (shelf_mesh,) = [v for v in after.link("body").visuals if v.name == "Cube"]
    bounds = trimesh.transform_points(shelf_mesh.mesh.vertices, shelf_mesh.link_from_visual)
    np.testing.assert_allclose(bounds.max(axis=0) - bounds.min(axis=0), (0.4, 0.3, 0.009), atol=1e-6)
    moved = after.link("drawer_0_handle").visuals[0]
    original = before.link("drawer_0_handle").visuals[0]
    dz = moved.link_from_visual[2, 3] - original.link_from_visual[2, 3]
    assert dz == pytest.approx(0.02, abs=1e-6)


@pytest.mark.slow
def test_a_failed_gate_is_reported_and_the_colliding_links_selected(imported_cupboard: Path, tmp_path: Path) -> None:
    import bpy

    from blender_addons import rig
    from blender_addons.model_operators import GATE_REPORT

    root = _open_cupboard(imported_cupboard)
    # The left door turned to swing inward, through the shelf and the body.
    door = next(link for link in rig.links_of(root) if link[rig.LINK] == "door_0")
    bpy.context.view_layer.objects.active = door
    bpy.ops.homemodel.edit_joint(joint_type="revolute", axis=(0, 0, 1), lower=0.0, upper=1.7)
    bpy.context.view_layer.objects.active = root
    assert bpy.ops.homemodel.export_model(directory=str(tmp_path / "out")) == {"FINISHED"}
    failed = [line for line in GATE_REPORT if line.startswith("FAIL ")]
    assert any("collisions" in line and "'door_0'" in line for line in failed), GATE_REPORT
    assert door.select_get()
    assert not next(link for link in rig.links_of(root) if link[rig.LINK] == "drawer_2").select_get()


def test_a_model_made_by_hand_gets_a_joint_and_passes_the_gate(scene, tmp_path: Path) -> None:
    import bpy

    from blender_addons.model_operators import GATE_REPORT

    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, 0.0, 0.4))
    body = _active()
    body.scale = (0.5, 0.5, 0.8)
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.26, 0.0, 0.4))
    door = _active()
    door.scale = (0.02, 0.48, 0.76)
    body.select_set(True)
    scene.cursor.location = (0.0, 0.0, 0.0)
    assert bpy.ops.homemodel.make_model(name="box_cabinet", category="cupboard") == {"FINISHED"}
    root = _active()
    for obj in bpy.data.objects:
        obj.select_set(obj is door)
    bpy.context.view_layer.objects.active = door
    scene.cursor.location = (0.26, -0.245, 0.4)
    assert bpy.ops.homemodel.add_joint(name="door", joint_type="revolute", axis=(0, 0, -1), lower=0.0, upper=1.5) == {"FINISHED"}
    bpy.context.view_layer.objects.active = root
    assert bpy.ops.homemodel.export_model(directory=str(tmp_path / "out")) == {"FINISHED"}
    assert GATE_REPORT[-1].startswith("OK: all"), GATE_REPORT
    model = load_urdf(tmp_path / "out" / "model.urdf")
    (joint,) = model.movable_joints
    np.testing.assert_allclose(joint.parent_from_joint[:3, 3], (0.26, -0.245, 0.4), atol=1e-6)
    np.testing.assert_allclose(joint.axis, (0, 0, -1), atol=1e-6)
    assert model.link("door").inertial.mass_kg == pytest.approx(500.0 * 0.02 * 0.48 * 0.76, rel=1e-3)


def test_the_scheme_survives_save_reopen_and_the_gltf_exporter(imported_cupboard: Path, cupboard_dir: Path, tmp_path: Path) -> None:
    import bpy

    from blender_addons import rig

    root = _open_cupboard(imported_cupboard)  # the import, saved and opened again
    door = next(j for j in rig.joints_of(root) if j[rig.JOINT] == "door_1_hinge")
    rig.set_position(door, 0.5)
    bpy.context.view_layer.update()
    assert door.rotation_axis_angle[0] == pytest.approx(0.5)  # the drivers came back with the file
    bpy.ops.export_scene.gltf(filepath=str(tmp_path / "scene.glb"), export_extras=True)
    blob = (tmp_path / "scene.glb").read_bytes()
    length = int.from_bytes(blob[12:16], "little")
    nodes = {n["name"]: n.get("extras", {}) for n in json.loads(blob[20 : 20 + length])["nodes"]}
    extras = nodes[door.name]
    assert extras[rig.JOINT] == "door_1_hinge" and extras[rig.JOINT_TYPE] == "revolute"
    assert extras[rig.POSITION] == pytest.approx(0.5) and len(extras[rig.AXIS]) == 3
    assert json.loads(nodes[root.name][rig.MODEL])["category"] == "cupboard"
    # The toolkit reads that glb back as the same model (the open door is not a change).
    assert cli("addon", "describe", str(tmp_path / "scene.glb"), "--out", str(tmp_path / "glb.json")).returncode == 0
    assert cli("addon", "export", str(tmp_path / "glb.json"), "--out", str(tmp_path / "toolkit_glb")).returncode == 0
    _same_model(load_urdf(cupboard_dir / "model.urdf"), load_urdf(tmp_path / "toolkit_glb" / "model.urdf"))
    # That glb comes back as the same model, rigged.
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert bpy.ops.homemodel.import_model(filepath=str(tmp_path / "scene.glb")) == {"FINISHED"}
    door = next(j for j in rig.joints_of(_active()) if j[rig.JOINT] == "door_1_hinge")
    assert door[rig.POSITION] == pytest.approx(0.5)
    rig.set_position(door, 0.0)
    assert bpy.ops.homemodel.export_model(directory=str(tmp_path / "from_glb")) == {"FINISHED"}
    _same_model(load_urdf(cupboard_dir / "model.urdf"), load_urdf(tmp_path / "from_glb" / "model.urdf"))


# The home


@pytest.mark.slow
def test_import_a_map_export_the_home_and_walk_to_the_blue_cup(real_toolkit, scene, kitchen: Path, tmp_path: Path) -> None:
    import bpy

    from blender_addons import home, rig
    from homemodel.core.transforms import transform_from_xyz_rpy
    from homemodel.exchange.map_xml import load_map, save_map

    original = load_map(kitchen / "map.xml")
    original.node("fridge_1").properties["brand"] = "Bosch"  # the map's own, not the model's
    original.add_switch(room_id="kitchen", switch_id="kitchen_light", type="rotational",
                        world_from_switch=transform_from_xyz_rpy((0.0, 0.1, 1.2), (0.0, 0.0, 0.5)))
    save_map(original, kitchen / "map_with_switch.xml")  # beside the models it refers to
    assert bpy.ops.homemodel.import_map(filepath=str(kitchen / "map_with_switch.xml")) == {"FINISHED"}
    assert [r[home.ROOM] for r in home.rooms(scene)] == ["kitchen", "bathroom"]
    roots = {home.object_id(r): r for r in home.model_roots(scene)}
    assert set(roots) == {o.id for o in original.objects()}
    for obj in original.objects():
        np.testing.assert_allclose(np.array(roots[obj.id].matrix_world), original.world_from_object(obj.id), atol=1e-5)
    parking = {p[home.PARKING]: p for p in home.parking_of(roots["table_1"])}
    assert set(parking) == {"south", "east", "north"} and parking["south"][home.PARKING_DEFAULT]
    assert json.loads(roots["table_1"][rig.SPEC])["kind"] == "table"  # so Edit measurements works
    grasps = [o for o in rig.owned(roots["blue_cup"]) if rig.GRASP in o]
    assert grasps and all(g.show_name for g in grasps)
    # Open the fridge a little, then export the home.
    fridge_door = next(j for j in rig.joints_of(roots["fridge_1"]) if j[rig.JOINT_TYPE] == "revolute")
    rig.set_position(fridge_door, 0.4)
    assert bpy.ops.homemodel.export_home(directory=str(tmp_path / "home")) == {"FINISHED"}
    assert cli("map", "validate", str(tmp_path / "home" / "map.xml")).returncode == 0
    walk = cli("map", "find", str(tmp_path / "home" / "map.xml"), "--type", "cup", "--property", "colour=blue")
    assert walk.returncode == 0, walk.stderr
    assert "demo_house > kitchen > table_1 > blue_cup" in walk.stdout and "1. south (default)" in walk.stdout
    exported = load_map(tmp_path / "home" / "map.xml")
    for node_id in [o.id for o in original.objects()] + ["kitchen_light"]:
        np.testing.assert_allclose(exported.world_from_object(node_id), original.world_from_object(node_id), atol=1e-5)
    assert exported.node("kitchen_light").type == "rotational"
    assert {o.id: o.properties for o in exported.objects()} == {o.id: o.properties for o in original.objects()}
    assert exported.node("fridge_1").joint(fridge_door[rig.JOINT]).position == pytest.approx(0.4)
    assert all(json.loads((tmp_path / "home" / "models" / o.id / "summary.json").read_text())["gate"]["valid"] for o in original.objects())
    rows = json.loads((tmp_path / "home" / "home_summary.json").read_text())["objects"]  # as `homemodel build` writes it
    assert sorted(r["id"] for r in rows) == sorted(o.id for o in original.objects()) and all(r["valid"] and r["links"] >= 1 for r in rows)


@pytest.mark.slow
def test_a_home_laid_out_by_hand_answers_the_blue_cup_walk(scene, tmp_path: Path) -> None:
    import bpy

    from blender_addons import home

    form = scene.homemodel_form
    bpy.ops.homemodel.add_room(name="Kitchen")
    form.kind = "table"
    bpy.ops.homemodel.form_kind()
    scene.cursor.location = (2.0, 1.5, 0.0)
    bpy.ops.homemodel.build()
    table = _active()
    table.homemodel_object_id = "table 1"  # made into a map id
    bpy.ops.homemodel.place(small=False)
    scene.cursor.location = (2.0, 0.6, 0.0)
    bpy.ops.homemodel.add_parking(name="south")
    top = max((table.matrix_world @ v.co).z for o in bpy.data.objects if o.type == "MESH" for v in o.data.vertices)
    form.kind = "cup"
    bpy.ops.homemodel.form_kind()
    next(row for row in form.rows if row.path == "colour").text = "blue"
    scene.cursor.location = (2.1, 1.4, top)
    bpy.ops.homemodel.build()
    cup = _active()
    cup.homemodel_object_id = "blue_cup"
    assert bpy.ops.homemodel.place(small=True) == {"FINISHED"}
    assert (cup[home.PARENT], cup[home.RELATION]) == ("table_1", "on")
    assert bpy.ops.homemodel.export_home(directory=str(tmp_path / "home")) == {"FINISHED"}
    walk = cli("map", "find", str(tmp_path / "home" / "map.xml"), "--type", "cup", "--property", "colour=blue")
    assert walk.returncode == 0, walk.stderr
    assert "home > kitchen > table_1 > blue_cup" in walk.stdout and "1. south (default): x=2.000 m, y=0.600 m, yaw=1.571 rad" in walk.stdout


def test_a_small_object_without_its_parent_in_the_home_is_refused_and_nothing_written(scene, tmp_path: Path) -> None:
    import bpy

    from blender_addons import home, rig

    collection = home.add_room(scene, "kitchen", "Kitchen")
    doc = {
        "format": rig.MODEL_FORMAT, "name": "cup", "category": "cup", "affordances": [], "properties": {},
        "links": [{"name": "body", "visuals": [{"name": "v", "rgba": [0, 0, 1, 1], "link_from_visual": np.eye(4).tolist(),
                    **{k: v.tolist() for k, v in (("vertices", trimesh.creation.box().vertices), ("faces", trimesh.creation.box().faces))}}]}],
    }
    cup = rig.add_model(doc, collection)
    cup[home.PARENT] = "table_9"
    with pytest.raises(RuntimeError, match="table_9"):
        bpy.ops.homemodel.export_home(directory=str(tmp_path / "home"))
    assert not (tmp_path / "home").exists()


# Scans and photos


def test_a_photo_job_reports_progress_and_cancels(scene, shared_data: Path) -> None:
    import time

    from blender_addons import home, jobs, toolkit

    job = jobs.Job("photos", shared_data / "photogrammetry" / "kermit", "")
    job.start()
    deadline = time.monotonic() + 300
    while job.stage == "starting" and not job.poll() and time.monotonic() < deadline:
        time.sleep(0.5)
    assert job.process.poll() is None, job.log.read_text()
    assert job.stage != "starting"  # a stage the toolkit reported
    assert 0.0 <= job.fraction <= 1.0
    job.cancel()
    assert job.poll() and job.process.returncode != 0
    with pytest.raises(toolkit.ToolkitError, match="the job was cancelled"):
        job.document()
    assert not home.model_roots(scene) and not job.work.exists()  # nothing of it is left


def test_render_the_selected_model_to_a_picture(scene, kitchen: Path, tmp_path: Path) -> None:
    import bpy

    from homemodel.core.images import read_image

    bpy.ops.homemodel.import_model(filepath=str(kitchen / "models" / "blue_cup" / "model.urdf"))
    assert bpy.ops.homemodel.render(directory=str(tmp_path), resolution_px=160, samples=4) == {"FINISHED"}
    image = read_image(tmp_path / "render_blue_cup.png").astype(float)
    assert image.shape[:2] == (120, 160)
    blue, green, red = image[40:80, 55:105].reshape(-1, 3).mean(axis=0)  # OpenCV's BGR
    assert blue > 1.5 * red and blue > 1.3 * green, (blue, green, red)  # the cup is blue and fills the frame
    assert [o.name for o in bpy.data.objects if o.type in ("CAMERA", "LIGHT")] == []  # the scene is left as it was


# A real Blender window


needs_a_window = pytest.mark.skipif(
    not (shutil.which("blender") and shutil.which("xvfb-run")),
    reason="needs Debian's blender and xvfb (make addon-screenshots installs them)",
)


@pytest.fixture(scope="module")
def empty_blend(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An empty scene saved by Debian's Blender, for the window tests to open."""
    empty = tmp_path_factory.mktemp("window") / "empty.blend"
    subprocess.run(["blender", "-b", "--factory-startup", "--python-expr",
                    f"import bpy; bpy.ops.wm.read_factory_settings(use_empty=True); bpy.ops.wm.save_as_mainfile(filepath={str(empty)!r})"], capture_output=True, check=True)
    return empty


def _in_a_blender_window(empty: Path, script: Path, *args: str, screen: str) -> subprocess.CompletedProcess:
    """Run `script` in Debian's Blender with a window on xvfb, on the `empty` scene. Blender draws
    in software (llvmpipe), at a cost that grows with the screen (start and quit 5.9 CPU-s at
    1600x1000, 3.8 at 800x600), and its idle event loop wakes every 5 ms (0.25 CPU-s a second),
    which the scripts sleep through while they wait."""
    env = {**ENV, "HOMEMODEL_COMMAND": REAL_TOOLKIT}
    return subprocess.run(
        ["xvfb-run", "-a", "-s", f"-screen 0 {screen}x24", "blender", "--factory-startup", "--enable-event-simulate",
         str(empty), "--python", str(script), "--", str(REPO), *args],
        capture_output=True, text=True, env=env, timeout=600,
    )


class WindowSession(NamedTuple):
    """What one Blender window showed: the panels' screenshots, then the background jobs."""

    output: str  # Blender's stdout and stderr
    shots: Path  # the screenshots and screenshots.json
    seen: dict  # what tests/blender_window_job.py saw
    kept: list[Path]  # the turntable work folders left behind (the landed job's)
    left: str  # pgrep of the cancelled job's toolkit command after Blender quit


@pytest.fixture(scope="module")
def window_session(kitchen: Path, empty_blend: Path, tmp_path_factory: pytest.TempPathFactory) -> Iterator[WindowSession]:
    """One Blender start for both window tests (2.9-3.4 CPU-s and 20-30 s of a loaded machine
    each): tools/addon_screenshots.py shoots the panels with the kitchen loaded, then runs
    tests/blender_window_job.py in the same window. The docs' screenshots are 1600x1000; the
    smallest usual screen shows the same panels, and every redraw of the job's is cheaper
    (the two tests 28.6 -> 22.7 CPU-s against two windows at 1024x640 and 800x600)."""
    from turntable_l_block import l_block_capture

    root = tmp_path_factory.mktemp("window_session")
    capture = root / "capture"  # a path of this session's own, for pgrep below
    shutil.copytree(l_block_capture(), capture)
    work_folders = set(Path(tempfile.gettempdir()).glob("homemodel-turntable-*"))
    run = _in_a_blender_window(empty_blend, REPO / "tools" / "addon_screenshots.py", str(kitchen / "map.xml"), str(root / "shots"),
                               str(REPO / "tests" / "blender_window_job.py"), str(capture), str(root / "seen.json"), screen="800x600")
    kept = sorted(set(Path(tempfile.gettempdir()).glob("homemodel-turntable-*")) - work_folders)
    left = subprocess.run(["pgrep", "-f", f"turntable reconstruct {capture}"], capture_output=True, text=True).stdout
    seen_file = root / "seen.json"
    seen = json.loads(seen_file.read_text()) if seen_file.is_file() else {"error": "the job script wrote nothing"}
    yield WindowSession(run.stdout + run.stderr, root / "shots", seen, kept, left)
    for folder in kept:
        shutil.rmtree(folder, ignore_errors=True)


@pytest.mark.slow
@needs_a_window
def test_the_panels_draw_in_a_real_blender_window(window_session: WindowSession) -> None:
    from homemodel.core.images import read_image

    output = window_session.output
    assert "Traceback" not in output and "Error" not in output and "FAILED" not in output, output
    drew = json.loads((window_session.shots / "screenshots.json").read_text())
    assert drew == {
        "addon_build.png": ["HOMEMODEL_PT_build"],
        "addon_joints.png": ["HOMEMODEL_PT_model"],
        "addon_home.png": ["HOMEMODEL_PT_home", "HOMEMODEL_PT_jobs"],
    }
    for name in drew:
        image = read_image(window_session.shots / name)
        sidebar = image[:, -260:-40].astype(float)
        viewport = image[:, : image.shape[1] // 2].astype(float)
        # The sidebar holds text and widgets (many tones), the viewport the kitchen.
        assert len(np.unique(sidebar.reshape(-1, sidebar.shape[-1]), axis=0)) > 50, name
        assert sidebar.std() > 10 and viewport.std() > 10, name


@pytest.mark.slow
@needs_a_window
def test_a_background_job_in_a_real_window_lands_its_model_and_esc_cancels_the_next(window_session: WindowSession) -> None:
    """The modal path an installer uses: the job's timer polls the child, the panel's status and
    progress move, the model lands at the 3D cursor; Esc stops a second job and its child."""
    [kept] = window_session.kept  # the cancelled one is gone
    assert (kept / "model" / "model.urdf").exists()  # the landed model's, whose textures Blender reads
    seen = window_session.seen
    assert seen["error"] is None, seen["error"] + window_session.output[-2000:]
    assert seen["modal_results"] == [["RUNNING_MODAL"], ["RUNNING_MODAL"]]
    first = [status.removeprefix("Reconstruct turntable capture: ") for status in seen["first_statuses"]]
    assert first[0] == "starting" and first[-1] == "done", first
    # The timer polls every 0.25 s, so a short stage (export) may come and go between two polls:
    # what the panel showed is the toolkit's stages in their order, and the long ones were seen.
    order = ["starting", *TURNTABLE_STAGES, "validate", "done"]
    assert [order.index(status) for status in first] == sorted(order.index(status) for status in first), first
    assert len(set(first) & set(TURNTABLE_STAGES)) >= 2, first
    [landed] = seen["landed"]
    assert landed["name"] == "turntable_object" and landed["meshes"] >= 1
    assert landed["location"] == pytest.approx(seen["cursor"])
    assert seen["statuses"][-1] == "Reconstruct turntable capture: cancelled"
    assert window_session.left == "", "the cancelled job's toolkit process is still running"


def test_a_bad_model_document_is_one_line_naming_the_field_and_nothing_is_written(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from homemodel.cli import app

    box = trimesh.creation.box()
    faces = box.faces.copy()
    faces[3, 1] = 99  # a triangle pointing past the 8 vertices
    doc = {"format": "homemodel.blender-model/1", "name": "box", "links": [
        {"name": "body", "visuals": [{"name": "v", "vertices": box.vertices.tolist(), "faces": faces.tolist()}]}]}
    (tmp_path / "model.json").write_text(json.dumps(doc))
    result = CliRunner().invoke(app, ["addon", "export", str(tmp_path / "model.json"), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    assert result.output.strip() == f"error: {tmp_path / 'model.json'}: links.0.visuals.0.faces: an index outside the 8 vertices"
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("texture", "problem"),
    [
        ("missing.png", "missing.png: no such file"),
        ("notes.txt", "notes.txt is not a PNG or JPEG image"),
        ("fake.png", "fake.png: not a readable image"),
    ],
)
def test_a_document_with_a_bad_texture_is_one_line_naming_it(tmp_path: Path, texture: str, problem: str) -> None:
    from typer.testing import CliRunner

    from homemodel.cli import app

    (tmp_path / "notes.txt").write_text("not an image")
    (tmp_path / "fake.png").write_text("not an image either")
    box = trimesh.creation.box()
    doc = {"format": "homemodel.blender-model/1", "name": "box", "links": [{"name": "body", "visuals": [{
        "name": "v", "vertices": box.vertices.tolist(), "faces": box.faces.tolist(),
        "texture": str(tmp_path / texture), "uv": [[0.0, 0.0]] * len(box.vertices)}]}]}
    (tmp_path / "model.json").write_text(json.dumps(doc))
    result = CliRunner().invoke(app, ["addon", "export", str(tmp_path / "model.json"), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1, result.output
    assert result.output.startswith(f"error: {tmp_path / 'model.json'}: links.0.visuals.0.texture: ")
    assert problem in result.output, result.output
    assert not (tmp_path / "out").exists()
