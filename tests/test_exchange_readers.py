"""The MJCF, SDF and USD readers: the kitchen's models written by our writers and read back
(joints, limits, axes, origins, dynamics, states, masses, inertias, collision shapes, mesh
bounds, placements, floor and walls), files the real clients wrote (MuJoCo's mj_saveLastXML,
`ign sdf -p`, a usd-core binary crate and a stage authored with pxr alone), files written by
hand in the other conventions each format allows, checked against MuJoCo's own kinematics or
by hand, and hostile or corrupt files refused with one line."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scene_compare import TOLERANCE, assert_same_model, assert_same_scene, near
from test_fuzz_loaders import EXAMPLES, FUZZ, SPECIAL_XML, XML_NOISE, mutated

from articulation.model import Box, Cylinder, Link, Material, Model, Sphere, Visual
from articulation.scene import Scene, single_model_scene
from homemodel.core.errors import InputError
from homemodel.exchange.home_scene import scene_from_map
from homemodel.exchange.simulator_read import read_model, read_scene
from homemodel.exchange.simulator import export_scene

FORMATS = {"mjcf": "scene.xml", "sdf": "scene.sdf", "usd": "scene.usda"}
# Joints moved off zero in the exported scene: the readers must put them back.
# Each reading opens the meshes too: fewer examples than the other loaders' fuzz.
FUZZ_READERS = settings(FUZZ, max_examples=min(EXAMPLES, 60))
MOVED = {"fridge_1": {"door_0_hinge": 0.6}, "oven_1": {"drawer_0_slide": 0.1, "knob_1_turn": 1.2}}


@pytest.fixture(scope="module")
def kitchen_scene(built_kitchen: Path) -> Scene:
    scene = scene_from_map(built_kitchen / "map.xml")
    for obj in scene.objects:
        obj.joint_positions = MOVED.get(obj.id, {})
    return scene


@pytest.fixture(scope="module")
def kitchen_files(kitchen_scene: Scene, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The kitchen scene exported once in each format (and shared by every test here)."""
    root = tmp_path_factory.mktemp("kitchen_scene")
    return {fmt: export_scene(kitchen_scene, root / fmt, fmt).file for fmt in FORMATS}


@pytest.mark.parametrize("fmt", FORMATS)
def test_the_kitchen_written_and_read_back_is_the_same_scene(kitchen_scene: Scene, kitchen_files: dict[str, Path], fmt: str) -> None:
    assert_same_scene(kitchen_scene, read_scene(kitchen_files[fmt]), fmt, TOLERANCE[fmt])


def test_mujocos_own_save_of_our_mjcf_reads_the_same(kitchen_scene: Scene, kitchen_files: dict[str, Path]) -> None:
    import mujoco

    xml = kitchen_files["mjcf"]
    saved = xml.with_name("saved_by_mujoco.xml")
    mujoco.mj_saveLastXML(str(saved), mujoco.MjModel.from_xml_path(str(xml)))
    text = saved.read_text()
    assert "diaginertia" in text and "fullinertia" not in text  # MuJoCo's own spelling, not ours
    assert_same_scene(kitchen_scene, read_scene(saved), "mjcf", TOLERANCE["saved"])


def test_gazebos_printout_of_our_sdf_reads_the_same(kitchen_scene: Scene, kitchen_files: dict[str, Path]) -> None:
    tool = shutil.which("gz") or shutil.which("ign")
    if tool is None:
        pytest.skip("neither gz nor ign is installed (make setup)")
    sdf = kitchen_files["sdf"]
    printed = subprocess.run([tool, "sdf", "-p", str(sdf)], capture_output=True, text=True, check=True).stdout
    assert "<sdf version='1.9'" in printed
    path = sdf.with_name("printed_by_gazebo.sdf")
    path.write_text(printed)
    assert_same_scene(kitchen_scene, read_scene(path), "sdf", TOLERANCE["sdf"])


def test_usd_cores_binary_crate_of_our_stage_reads_the_same(kitchen_scene: Scene, kitchen_files: dict[str, Path]) -> None:
    from pxr import Usd

    crate = kitchen_files["usd"].with_name("scene.usdc")
    assert Usd.Stage.Open(str(kitchen_files["usd"])).Export(str(crate))
    assert crate.read_bytes()[:8] == b"PXR-USDC"
    assert_same_scene(kitchen_scene, read_scene(crate), "usd", TOLERANCE["usd"])


# Files in the conventions we do not write


def _door(tmp_path: Path) -> Path:
    """An OBJ door leaf 0.6 x 0.02 x 0.8 m, centred on its frame."""
    import trimesh

    path = tmp_path / "door.obj"
    path.write_text(trimesh.exchange.obj.export_obj(trimesh.creation.box((0.6, 0.02, 0.8))))
    return path


HAND_MJCF = """<mujoco model="hand">
  <compiler angle="degree" eulerseq="zyx"/>
  <default>
    <joint damping="0.5"/>
    <default class="leaf"><geom type="mesh" rgba="0.2 0.4 0.6 1" contype="0" conaffinity="0"/></default>
  </default>
  <asset><mesh name="leaf" file="door.obj"/></asset>
  <worldbody>
    <body name="cabinet" pos="1 2 0" euler="90 0 0">
      <geom name="carcass" type="box" size="0.3 0.3 0.4" pos="0 0 0.4" group="3"/>
      <body name="door" pos="0.62 0.3 0.4" euler="10 20 5" childclass="leaf">
        <inertial pos="0 0 0" mass="2" diaginertia="0.1 0.06 0.05"/>
        <joint name="hinge" type="hinge" pos="-0.3 0 0" axis="0 0 1" range="-5 110" ref="30"/>
        <geom mesh="leaf" pos="0 0.01 0" axisangle="0 0 1 15"/>
        <body name="latch" pos="0.25 0.02 0">
          <joint name="slide" type="slide" axis="0 1 0" pos="0.1 0 0" range="0 0.03"/>
          <geom type="capsule" fromto="0 0 -0.05 0 0 0.05" size="0.01" contype="1" group="0"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_a_hand_written_mjcf_is_placed_as_mujoco_places_it(tmp_path: Path) -> None:
    """Degrees, another Euler order, default classes, a joint off its body's origin and a
    `ref`: every geom where MuJoCo's own kinematics puts it, at several joint positions."""
    import mujoco

    _door(tmp_path)
    path = tmp_path / "hand.xml"
    path.write_text(HAND_MJCF)
    scene = read_scene(path)
    obj = scene.objects[0]
    hinge, slide = obj.model.joint("hinge"), obj.model.joint("slide")
    assert (hinge.type, slide.type) == ("revolute", "prismatic")
    near([hinge.limits.lower, hinge.limits.upper], np.radians([-5, 110]), 1e-12, "degrees")
    assert hinge.dynamics.damping == 0.5  # from the default class
    assert obj.position("hinge") == pytest.approx(np.radians(30))
    door = obj.model.link("door")
    assert [v.material.rgba for v in door.visuals] == [(0.2, 0.4, 0.6, 1.0)] and not door.collisions
    assert len(obj.model.link("latch").visuals) == 1 and len(obj.model.link("latch").collisions) == 1
    mj = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(mj)
    for q in ([np.radians(30), 0.0], [0.0, 0.0], [1.4, 0.02], [-0.05, 0.03]):
        data.qpos[:] = q
        mujoco.mj_kinematics(mj, data)
        links = obj.model.world_from_links({"hinge": q[0], "slide": q[1]})
        for name, link_name, placed in (("carcass", "cabinet", None), (None, "door", 0), (None, "latch", 0)):
            g = mj.geom(name).id if name else next(i for i in range(mj.ngeom) if mj.body(mj.geom_bodyid[i]).name == link_name)
            part = obj.model.link(link_name).collisions[0].link_from_collision if name else obj.model.link(link_name).visuals[0].link_from_visual
            world = obj.world_from_model @ links[link_name] @ part
            near(world[:3, 3], data.geom_xpos[g], 1e-9, f"{link_name} at {q}")
            if link_name != "door":  # MuJoCo turns a mesh geom to the mesh's principal axes
                near(world[:3, :3], data.geom_xmat[g].reshape(3, 3), 1e-9, f"{link_name} turn at {q}")
    inertia = obj.model.link("door").inertial
    assert inertia.mass_kg == 2 and np.linalg.eigvalsh(inertia.inertia_kgm2) == pytest.approx([0.05, 0.06, 0.1])


HAND_SDF = """<?xml version="1.0"?>
<sdf version="1.9"><world name="w">
  <model name="cabinet">
    <pose degrees="true">1 2 0 0 0 90</pose>
    <link name="carcass">
      <pose>0 0 0.4 0 0 0</pose>
      <collision name="shell"><geometry><box><size>0.6 0.6 0.8</size></box></geometry></collision>
    </link>
    <link name="door">
      <pose relative_to="carcass">0.62 0 0 0 0 0</pose>
      <visual name="leaf"><geometry><mesh><uri>door.obj</uri></mesh></geometry></visual>
    </link>
    <joint name="hinge" type="revolute">
      <parent>carcass</parent><child>door</child>
      <pose>-0.3 0 0 1.5707963267948966 0 0</pose>
      <axis><xyz expressed_in="door">0 0 1</xyz><limit><lower>0</lower><upper>2</upper></limit></axis>
    </joint>
    <joint name="fixed_to_world" type="fixed"><parent>world</parent><child>carcass</child></joint>
  </model>
  <model name="ground_plane"><static>true</static>
    <link name="link"><collision name="c"><geometry><plane><normal>0 0 1</normal></plane></geometry></collision></link>
  </model>
</world></sdf>
"""


def test_a_hand_written_sdf_turns_about_its_joint_pose(tmp_path: Path) -> None:
    """A link posed relative to another, a turned joint frame off the child's origin, an axis in
    the child's axes, degrees, a ground plane: the door turns about its left edge (world x = 1,
    y = 2 + 0.32), worked out by hand."""
    _door(tmp_path)
    path = tmp_path / "hand.sdf"
    path.write_text(HAND_SDF)
    if shutil.which("gz") or shutil.which("ign"):  # the hand-written file is valid SDFormat
        from simulator_clients import sdf_check

        valid, said = sdf_check(path)
        assert valid, said
    scene = read_scene(path)
    assert scene.floor and len(scene.objects) == 1
    obj = scene.objects[0]
    assert not obj.free and obj.model.root_link == "carcass"
    for angle in (0.0, 0.5, 1.5):
        world_from_door = obj.world_from_model @ obj.model.world_from_links({"hinge": angle})["door"]
        centre = (world_from_door @ obj.model.link("door").visuals[0].link_from_visual)[:3, 3]
        # The model turned 90 degrees: its x is the world's y. The hinge line is at model
        # (0.32, 0), so world (1, 2.32); the leaf's centre is 0.3 m from it, along model x at 0.
        expected = np.array([1.0, 2.32, 0.4]) + 0.3 * np.array([-np.sin(angle), np.cos(angle), 0.0])
        near(centre, expected, 1e-9, f"door centre at {angle}")


def test_a_stage_authored_with_usd_core_alone_reads_in_metres_and_z_up(tmp_path: Path) -> None:
    """Centimetres, y up, a body with a scaled cube and a sphere, a revolute joint about its Z
    token whose frame in the child is off the child's origin, and limits in degrees."""
    from pxr import Gf, Usd, UsdGeom, UsdPhysics

    path = tmp_path / "authored.usda"
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 0.01)
    root = UsdGeom.Xform.Define(stage, "/Root")
    stage.SetDefaultPrim(root.GetPrim())
    base = UsdGeom.Xform.Define(stage, "/Root/lamp/base")
    arm = UsdGeom.Xform.Define(stage, "/Root/lamp/arm")
    arm.AddTranslateOp().Set(Gf.Vec3d(0, 50, 0))  # 0.5 m up (y)
    for prim in (base, arm):
        UsdPhysics.RigidBodyAPI.Apply(prim.GetPrim())
    cube = UsdGeom.Cube.Define(stage, "/Root/lamp/base/plinth")
    cube.AddScaleOp().Set(Gf.Vec3f(20, 5, 10))  # size 2: a 0.4 x 0.1 x 0.2 m box
    UsdPhysics.CollisionAPI.Apply(cube.GetPrim())
    UsdGeom.Sphere.Define(stage, "/Root/lamp/arm/bulb").CreateRadiusAttr(5.0)
    panel = UsdGeom.Mesh.Define(stage, "/Root/lamp/base/panel")  # one quad, 20 cm square
    panel.CreatePointsAttr([(0, 0, 0), (20, 0, 0), (20, 20, 0), (0, 20, 0)])
    panel.CreateFaceVertexCountsAttr([4])
    panel.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    mass = UsdPhysics.MassAPI.Apply(arm.GetPrim())
    mass.CreateMassAttr(0.3)
    joint = UsdPhysics.RevoluteJoint.Define(stage, "/Root/lamp/joints/tilt")
    joint.CreateBody0Rel().SetTargets(["/Root/lamp/base"])
    joint.CreateBody1Rel().SetTargets(["/Root/lamp/arm"])
    joint.CreateAxisAttr("Z")
    joint.CreateLocalPos0Attr(Gf.Vec3f(10, 50, 0))
    joint.CreateLocalPos1Attr(Gf.Vec3f(10, 0, 0))
    joint.CreateLowerLimitAttr(-45.0)
    joint.CreateUpperLimitAttr(90.0)
    stage.GetRootLayer().Save()

    scene = read_scene(path)
    obj = scene.objects[0]
    assert obj.id == "lamp" and obj.free
    tilt = obj.model.joint("tilt")
    assert tilt.type == "revolute" and obj.position("tilt") == pytest.approx(0.0, abs=1e-9)
    near([tilt.limits.lower, tilt.limits.upper], np.radians([-45, 90]), 1e-6, "limits")
    plinth = obj.model.link("base").collisions[0].geometry
    near(plinth.size_m, (0.4, 0.1, 0.2), 1e-6, "plinth in metres")
    quad = next(v.mesh for v in obj.model.link("base").visuals if v.name == "panel")
    assert len(quad.faces) == 2 and quad.area == pytest.approx(0.04)
    bulb = obj.model.link("arm").visuals[0].mesh
    near(bulb.extents, [0.1, 0.1, 0.1], 2e-3, "bulb in metres")
    assert obj.model.link("arm").inertial.mass_kg == pytest.approx(0.3)
    # Stage (x, y, z) is world (x, -z, y): the hinge turns about the world's -y, through stage
    # (0.1, 0.5, 0), world (0.1, 0, 0.5). The bulb, 0.1 m towards -x of it, swings down.
    for angle in (0.0, 0.7):
        world = obj.world_from_model @ obj.model.world_from_links({"tilt": angle})["arm"]
        centre = (world @ obj.model.link("arm").visuals[0].link_from_visual)[:3, 3]
        offset = np.array([-0.1 * np.cos(angle), 0.0, -0.1 * np.sin(angle)])
        near(centre, np.array([0.1, 0.0, 0.5]) + offset, 1e-6, f"bulb at {angle}")


def test_a_photo_texture_and_its_coordinates_survive_every_format(tmp_path: Path) -> None:
    import trimesh
    from PIL import Image

    image = tmp_path / "photo.png"
    Image.fromarray(np.random.default_rng(0).integers(0, 255, (16, 16, 3), dtype=np.uint8)).save(image)
    mesh = trimesh.creation.box((0.2, 0.1, 0.3))
    uv = np.random.default_rng(1).random((len(mesh.vertices), 2))
    visual = Visual(name="front", mesh=mesh, material=Material(name="photo", rgba=(1, 1, 1, 0.9), texture=image), uv=uv)
    model = Model(name="picture", links=[Link(name="frame", visuals=[visual])])
    for fmt, file in FORMATS.items():
        path = export_scene(single_model_scene(model), tmp_path / fmt, fmt).file
        back = read_model(path).link("frame").visuals[0]
        assert back.material.texture is not None and back.material.texture.is_file(), fmt
        assert np.array_equal(np.asarray(Image.open(back.material.texture)), np.asarray(Image.open(image))), fmt
        near(back.uv, uv, 1e-6, f"{fmt} uv")
        assert back.material.rgba[3] == pytest.approx(0.9), fmt


def test_primitive_collisions_keep_their_kind_and_size(tmp_path: Path) -> None:
    import trimesh

    from articulation.model import Collision

    shapes = [Box(size_m=(0.1, 0.2, 0.3)), Cylinder(radius_m=0.05, length_m=0.2), Sphere(radius_m=0.07)]
    link = Link(name="body", visuals=[Visual(name="v", mesh=trimesh.creation.box((0.1, 0.1, 0.1)), material=Material(name="m"))],
                collisions=[Collision(name=f"c{i}", geometry=s) for i, s in enumerate(shapes)])
    model = Model(name="shapes", links=[link])
    for fmt in FORMATS:
        back = read_model(export_scene(single_model_scene(model), tmp_path / fmt, fmt).file).link("body").collisions
        assert [type(c.geometry) for c in back] == [Box, Cylinder, Sphere], fmt
        assert [c.name for c in back] == ["c0", "c1", "c2"], fmt
        near(back[0].geometry.size_m, (0.1, 0.2, 0.3), 1e-6, fmt)
        near([back[1].geometry.radius_m, back[1].geometry.length_m, back[2].geometry.radius_m], [0.05, 0.2, 0.07], 1e-6, fmt)


# Hostile and corrupt files


@pytest.fixture(scope="module")
def small_exports(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """An exported cupboard (a hinge, a knob under it, meshes) in each format."""
    from sample_house import cupboard_model

    root = tmp_path_factory.mktemp("small")
    return {fmt: export_scene(single_model_scene(cupboard_model()), root / fmt, fmt).file for fmt in FORMATS}


HOSTILE = {
    "a billion laughs": '<?xml version="1.0"?><!DOCTYPE m [<!ENTITY a "aaaa"><!ENTITY b "&a;&a;&a;">]><mujoco>&b;</mujoco>',
    "an external entity": '<?xml version="1.0"?><!DOCTYPE m [<!ENTITY x SYSTEM "file:///etc/passwd">]><mujoco>&x;</mujoco>',
    "not XML": "\x00\x01PK\x03\x04 binary",
    "a cut file": "<mujoco><worldbody><body name='a'>",
}


@pytest.mark.parametrize("suffix", [".xml", ".sdf"])
@pytest.mark.parametrize("kind", HOSTILE)
def test_hostile_xml_is_one_line_naming_the_file(tmp_path: Path, suffix: str, kind: str) -> None:
    path = tmp_path / f"hostile{suffix}"
    path.write_text(HOSTILE[kind].replace("mujoco", "sdf") if suffix == ".sdf" else HOSTILE[kind])
    with pytest.raises(InputError) as caught:
        read_scene(path)
    assert str(path) in str(caught.value) and "\n" not in str(caught.value)


def test_a_mesh_outside_the_folder_and_a_missing_mesh_are_refused(small_exports: dict[str, Path]) -> None:
    for fmt, needle in (("mjcf", 'file="meshes/'), ("sdf", "<uri>meshes/")):
        path = small_exports[fmt]
        text = path.read_text()
        for target, message in (("../../../etc/", "outside"), ("meshes/nowhere/", "no such file")):
            bad = path.with_name(f"bad{path.suffix}")
            bad.write_text(text.replace(needle, needle.replace("meshes/", target), 1))
            with pytest.raises(InputError, match=message) as caught:
                read_scene(bad)
            assert str(bad) in str(caught.value) and "\n" not in str(caught.value)


@pytest.mark.parametrize("content", [b"#usda 1.0\n(\n  defaultPrim = \"World\"\n", b"PXR-USDC\x00\x00garbage", b""])
def test_a_corrupt_usd_stage_is_one_line_and_nothing_on_stderr(tmp_path: Path, capfd, content: bytes) -> None:
    path = tmp_path / ("bad.usdc" if content.startswith(b"PXR") else "bad.usda")
    path.write_bytes(content)
    capfd.readouterr()
    with pytest.raises(InputError) as caught:
        read_scene(path)
    assert str(path) in str(caught.value) and "\n" not in str(caught.value)
    assert capfd.readouterr().err == ""


def test_a_usd_stage_composing_a_file_outside_its_folder_is_refused(tmp_path: Path, small_exports: dict[str, Path]) -> None:
    outside = tmp_path / "outside.usda"
    shutil.copy(small_exports["usd"], outside)
    folder = tmp_path / "stage"
    folder.mkdir()
    path = folder / "scene.usda"
    path.write_text(f'#usda 1.0\n(\n    subLayers = [@{outside}@]\n)\n')
    with pytest.raises(InputError, match="outside the stage's folder"):
        read_scene(path)


def test_a_file_of_several_objects_is_not_one_model(kitchen_files: dict[str, Path]) -> None:
    with pytest.raises(InputError, match="holds 9 objects"):
        read_model(kitchen_files["mjcf"])


def _model_or_input_error(path: Path) -> None:
    try:
        read_scene(path)
    except InputError as exc:
        assert "\n" not in str(exc), str(exc)


@FUZZ_READERS
@given(data=st.data())
def test_mutated_mjcf_and_sdf_give_a_scene_or_an_input_error(small_exports: dict[str, Path], data) -> None:
    fmt = data.draw(st.sampled_from(["mjcf", "sdf"]))
    source = small_exports[fmt]
    path = source.with_name(f"fuzzed{source.suffix}")
    path.write_text(data.draw(mutated(source.read_text(), SPECIAL_XML, XML_NOISE, r'="([^"]*)"')))
    _model_or_input_error(path)


@FUZZ_READERS
@given(data=st.data())
def test_mutated_usda_gives_a_scene_or_an_input_error(small_exports: dict[str, Path], data) -> None:
    source = small_exports["usd"]
    path = source.with_name("fuzzed.usda")
    path.write_text(data.draw(mutated(source.read_text(), SPECIAL_XML, XML_NOISE, r"= ([^\n]*)")))
    _model_or_input_error(path)


def test_export_takes_another_simulators_file_of_one_model(
    small_exports: dict[str, Path], kitchen_files: dict[str, Path], tmp_path: Path, capfd
) -> None:
    """`homemodel export scene.xml --format usd`: a model from MuJoCo to Isaac, joints intact;
    a file of several objects is one line and nothing written."""
    from sample_house import cupboard_model
    from test_fuzz_loaders import _one_line_error
    from typer.testing import CliRunner

    from homemodel.cli import app

    runner = CliRunner()
    out = tmp_path / "usd"
    result = runner.invoke(app, ["export", str(small_exports["mjcf"]), "--format", "usd", "--out", str(out)])
    assert result.exit_code == 0, result.output
    original = single_model_scene(cupboard_model()).objects[0]
    assert_same_model(original, read_scene(out / "scene.usda").objects[0], "usd", TOLERANCE["usd"])
    capfd.readouterr()
    result = runner.invoke(app, ["export", str(kitchen_files["mjcf"]), "--format", "sdf", "--out", str(tmp_path / "many")])
    _one_line_error(result, capfd, str(kitchen_files["mjcf"]), "holds 9 objects")
    assert not (tmp_path / "many").exists()
    corrupt = tmp_path / "corrupt.usda"
    corrupt.write_text(small_exports["usd"].read_text()[:1500])
    result = runner.invoke(app, ["export", str(corrupt), "--format", "mjcf", "--out", str(tmp_path / "none")])
    _one_line_error(result, capfd, str(corrupt), "not a readable USD stage")
    assert not (tmp_path / "none").exists()


UNREADABLE = {
    "ball.xml": ("<mujoco><worldbody><body name='a'><geom size='0.1'/><body name='b'><joint type='ball'/>"
                 "<geom size='0.1'/></body></body></worldbody></mujoco>", "a ball joint inside a model is not read"),
    "frame.xml": ("<mujoco><worldbody><body name='a'><frame pos='1 0 0'><geom size='0.1'/></frame></body></worldbody>"
                  "</mujoco>", "<frame> is not read"),
    "hinged_to_world.xml": ("<mujoco><worldbody><body name='a'><joint type='hinge'/><geom size='0.1'/></body>"
                            "</worldbody></mujoco>", "only a free joint joins an object to the world"),
    "ball.sdf": ("<sdf version='1.9'><model name='m'><link name='a'/><link name='b'/><joint name='j' type='ball'>"
                 "<parent>a</parent><child>b</child></joint></model></sdf>", "type 'ball' is not read"),
    "nested.sdf": ("<sdf version='1.9'><model name='m'><link name='a'/><model name='inner'><link name='b'/></model>"
                   "</model></sdf>", "nested models and <include> are not read"),
    "old.sdf": ("<sdf version='1.6'><model name='m'><link name='a'/></model></sdf>", "read from 1.7 on"),
    "include.sdf": ("<sdf version='1.9'><world name='w'><include><uri>model://x</uri></include></world></sdf>",
                    "<include> is not read"),
}


@pytest.mark.parametrize("name", UNREADABLE)
def test_what_a_model_cannot_hold_is_refused_by_name(tmp_path: Path, name: str) -> None:
    path = tmp_path / name
    text, message = UNREADABLE[name]
    path.write_text(text)
    with pytest.raises(InputError, match=message) as caught:
        read_scene(path)
    assert str(caught.value).startswith(str(path)) and "\n" not in str(caught.value)


def test_a_spherical_joint_in_a_usd_stage_is_refused(tmp_path: Path) -> None:
    from pxr import Usd, UsdGeom, UsdPhysics

    path = tmp_path / "ball.usda"
    stage = Usd.Stage.CreateNew(str(path))
    for body in ("/a", "/b"):
        UsdPhysics.RigidBodyAPI.Apply(UsdGeom.Xform.Define(stage, body).GetPrim())
    joint = UsdPhysics.SphericalJoint.Define(stage, "/ball")
    joint.CreateBody0Rel().SetTargets(["/a"])
    joint.CreateBody1Rel().SetTargets(["/b"])
    stage.GetRootLayer().Save()
    with pytest.raises(InputError, match="PhysicsSphericalJoint is not read"):
        read_scene(path)
