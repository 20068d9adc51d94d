"""`homemodel map export` and `homemodel export`: the kitchen and catalogue models in MuJoCo
(read back from the saved MJCF), Gazebo's SDFormat checker, USD (pxr) and its validators,
pybullet for the scene URDF, the Khronos validator for the scene glTF, and a ROS 2 package
through yourdfpy, check_urdf and the gate."""

from __future__ import annotations

import json
import py_compile
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from lxml import etree
from scene_compare import TOLERANCE, assert_same_model
from simulator_clients import (
    assert_mujoco_stable,
    load_mjcf,
    mujoco_figures,
    sdf_check,
    sdf_check_together,
    usd_errors,
)
from typer.testing import CliRunner

from homemodel.cli import app

pytestmark = pytest.mark.bpy

runner = CliRunner()
SMALL_OBJECTS = {"red_cup", "blue_cup", "bowl_1", "sugar_container", "pill_box"}
# A catalogue sample with every kind of joint: a bottom-hinged door, knobs and a drawer
# (oven), a flap and a side-hinged door (wall cabinet), a round door and a knob (washing
# machine). The kitchen's models are in the scene tests; the slow test takes the rest of the catalogue.
CATALOGUE_SAMPLE = ("oven", "wall_cabinet", "washing_machine")
CATALOGUE = tuple(sorted(p.stem for p in (Path(__file__).parents[1] / "examples" / "catalogue").glob("*.yaml")))


def _export_map(map_path: Path, out: Path, fmt: str, *extra: str) -> Path:
    result = runner.invoke(app, ["map", "export", str(map_path), "--format", fmt, "--out", str(out), *extra])
    assert result.exit_code == 0, result.output
    return out


@pytest.fixture(scope="module")
def kitchen_exports(built_kitchen: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("kitchen_exports")
    return {fmt: _export_map(built_kitchen / "map.xml", root / fmt, fmt) for fmt in ("mjcf", "sdf", "usd", "urdf", "glb")}


# MuJoCo


def test_kitchen_mjcf_loads_from_disk_and_stays_still(kitchen_exports: dict[str, Path]) -> None:
    figures = mujoco_figures(kitchen_exports["mjcf"] / "scene.xml")
    assert {name.removesuffix("__free") for name in figures.free_drift_m} == SMALL_OBJECTS
    assert len(figures.knob_error_deg) == 4  # the oven's knobs
    assert "oven_1__door_0_hinge" in figures.door_drift_deg  # bottom-hinged
    assert_mujoco_stable(figures)


def test_kitchen_mjcf_names_meshes_and_groups(kitchen_exports: dict[str, Path]) -> None:
    import mujoco

    xml = kitchen_exports["mjcf"] / "scene.xml"
    model = load_mjcf(xml)
    ids = {"table_1", "cupboard_1", "fridge_1", "oven_1", *SMALL_OBJECTS}
    bodies = [model.body(b).name for b in range(1, model.nbody)]
    assert len(bodies) == len(set(bodies))
    assert all(b.split("__")[0] in ids for b in bodies), bodies
    # Every object's main mesh is its own file: no two objects share a mesh (MuJoCo 3.3's trap).
    files = [m.get("file") for m in etree.parse(str(xml)).getroot().iter("mesh")]
    assert len(files) == len(set(files)) and all((xml.parent / f).is_file() for f in files)
    assert not any(Path(f).is_absolute() for f in files)
    table = model.geom("table_1__body_body").id
    fridge = model.geom("fridge_1__body_body").id
    assert model.geom_dataid[table] != model.geom_dataid[fridge]
    assert model.mesh_vertnum[model.geom_dataid[table]] != model.mesh_vertnum[model.geom_dataid[fridge]]
    # Visual geoms never collide; collision geoms do.
    for g in range(model.ngeom):
        if model.geom_group[g] == 2:
            assert model.geom_contype[g] == 0 and model.geom_conaffinity[g] == 0
    assert model.geom("floor").type == mujoco.mjtGeom.mjGEOM_PLANE
    assert sum(1 for g in range(model.ngeom) if model.geom(g).name.startswith("kitchen__wall_")) == 4


def test_kitchen_mjcf_walls_stand_outside_the_outline(kitchen_exports: dict[str, Path]) -> None:
    import mujoco

    model = load_mjcf(kitchen_exports["mjcf"] / "scene.xml")
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    # home.yaml: the kitchen is the rectangle 0..4 m by 0..5 m; each wall's inner face is on its edge.
    inner = []
    for g in range(model.ngeom):
        if model.geom(g).name.startswith("kitchen__wall_"):
            centre, half = data.geom_xpos[g], model.geom_size[g]
            rotation = data.geom_xmat[g].reshape(3, 3)
            normal = rotation[:, 1]
            inner.append(sorted(np.round([*(centre[:2] - half[1] * normal[:2]), *(centre[:2] + half[1] * normal[:2])], 6)))
    flat = sorted(v for face in inner for v in face)
    assert {0.0, 4.0, 5.0} <= set(np.round(flat, 6))


def test_kitchen_mjcf_keyframes_are_the_knob_states(kitchen_exports: dict[str, Path], built_kitchen: Path) -> None:
    import mujoco

    from homemodel.exchange.map_xml import load_map

    model = load_mjcf(kitchen_exports["mjcf"] / "scene.xml")
    data = mujoco.MjData(model)
    oven = load_map(built_kitchen / "map.xml").node("oven_1")
    for joint in oven.joints:
        for state in joint.states:
            key = model.key(f"oven_1__{joint.name}={state.name}")
            mujoco.mj_resetDataKeyframe(model, data, key.id)
            assert data.qpos[model.jnt_qposadr[model.joint(f"oven_1__{joint.name}").id]] == pytest.approx(state.position)
    assert model.nkey == 1 + sum(len(j.states) for j in oven.joints)


def test_map_joint_states_are_the_exports_initial_state(built_kitchen: Path, tmp_path: Path) -> None:
    """The fridge door open 0.6 rad in the map: MJCF qpos0, SDF link poses, USD joint frames
    and the glTF node all start there, and the limits keep their meaning."""
    import mujoco
    from pxr import Usd, UsdGeom

    from homemodel.exchange.map_xml import load_map, save_map

    smap = load_map(built_kitchen / "map.xml")
    smap.set_joint_state("fridge_1", "door_0_hinge", 0.6)
    home = tmp_path / "home"
    shutil.copytree(built_kitchen / "models", home / "models")
    save_map(smap, home / "map.xml")
    from homemodel.exchange.urdf.read import load_urdf

    fridge = load_urdf(home / "models" / "fridge_1" / "model.urdf")
    limits = fridge.joint("door_0_hinge").limits
    mjcf = _export_map(home / "map.xml", tmp_path / "mjcf", "mjcf", "--room", "kitchen")
    model = load_mjcf(mjcf / "scene.xml")
    hinge = model.joint("fridge_1__door_0_hinge")
    assert model.qpos0[hinge.qposadr[0]] == pytest.approx(0.6)
    assert model.jnt_range[hinge.id] == pytest.approx([limits.lower, limits.upper])  # the model's own range
    # The door body sits where the map's state puts it.
    world_from_door = smap.world_from_object("fridge_1") @ fridge.world_from_links({"door_0_hinge": 0.6})["door_0"]
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert data.xpos[model.body("fridge_1__door_0").id] == pytest.approx(world_from_door[:3, 3], abs=1e-5)

    sdf = _export_map(home / "map.xml", tmp_path / "sdf", "sdf")
    root = etree.parse(str(sdf / "scene.sdf")).getroot()
    joint = root.find(".//joint[@name='fridge_1__door_0_hinge']")
    lower, upper = (float(joint.findtext(f"axis/limit/{k}")) for k in ("lower", "upper"))
    assert (lower, upper) == pytest.approx((limits.lower - 0.6, limits.upper - 0.6), abs=1e-6)

    usd = _export_map(home / "map.xml", tmp_path / "usd", "usd")
    stage = Usd.Stage.Open(str(usd / "scene.usda"))
    door = UsdGeom.Xformable(stage.GetPrimAtPath("/World/fridge_1/fridge_1__door_0"))
    world = np.array(door.ComputeLocalToWorldTransform(Usd.TimeCode.Default())).T
    assert world[:3, 3] == pytest.approx(world_from_door[:3, 3], abs=1e-5)
    assert stage.GetPrimAtPath("/World/fridge_1/joints/fridge_1__door_0_hinge").GetAttribute(
        "homemodel:initialPosition"
    ).Get() == pytest.approx(0.6)


# SDF, USD, URDF, glTF of the kitchen


def test_kitchen_sdf_passes_gazebos_check(kitchen_exports: dict[str, Path]) -> None:
    sdf = kitchen_exports["sdf"] / "scene.sdf"
    valid, said = sdf_check(sdf)
    assert valid, said
    root = etree.parse(str(sdf)).getroot()
    models = {m.get("name"): m for m in root.iter("model")}
    assert {"floor", "kitchen__wall_0"} <= set(models)
    for small in SMALL_OBJECTS:  # free: no joint to the world, not static
        assert models[small].find("joint/parent[.='world']") is None and models[small].findtext("static") is None
    assert models["oven_1"].find("joint/parent[.='world']") is not None
    dynamics = models["oven_1"].find("joint[@name='oven_1__door_0_hinge']/axis/dynamics")
    assert float(dynamics.findtext("friction")) > 0 and float(dynamics.findtext("damping")) > 0


def test_a_broken_sdf_fails_gazebos_check_alone_and_among_good_ones(tmp_path: Path) -> None:
    from sample_house import cupboard_model

    from articulation.scene import single_model_scene
    from homemodel.exchange.simulator import export_scene

    good = export_scene(single_model_scene(cupboard_model()), tmp_path / "good", "sdf").file
    broken = tmp_path / "broken" / "scene.sdf"
    broken.parent.mkdir()
    text = good.read_text().replace('<world name="', '<world name="broken_', 1)  # its own world's name
    assert "<child>cupboard__door</child>" in text
    broken.write_text(text.replace("<child>cupboard__door</child>", "<child>no_such_link</child>", 1))
    valid, said = sdf_check_together([good, broken], tmp_path / "both.sdf")  # alone too, to name it
    assert not valid and str(broken) in said and str(good) not in said, said


def test_kitchen_usd_passes_usds_validators_and_matches_the_models(kitchen_exports: dict[str, Path], built_kitchen: Path) -> None:
    from pxr import Usd, UsdPhysics

    from homemodel.exchange.urdf.read import load_urdf

    path = kitchen_exports["usd"] / "scene.usda"
    assert usd_errors(path) == []
    stage = Usd.Stage.Open(str(path))
    assert UsdPhysics.GetStageKilogramsPerUnit(stage) == 1.0
    for object_id in ("oven_1", "cupboard_1", "red_cup"):
        model = load_urdf(built_kitchen / "models" / object_id / "model.urdf")
        for link in model.links:
            prim = stage.GetPrimAtPath(f"/World/{object_id}/{object_id}__{link.name}")
            assert prim.HasAPI(UsdPhysics.RigidBodyAPI)
            if link.inertial is not None:
                assert UsdPhysics.MassAPI(prim).GetMassAttr().Get() == pytest.approx(link.inertial.mass_kg, rel=1e-6)
        for joint in model.movable_joints:
            prim = stage.GetPrimAtPath(f"/World/{object_id}/joints/{object_id}__{joint.name}")
            usd_joint = UsdPhysics.RevoluteJoint(prim) if joint.type == "revolute" else UsdPhysics.PrismaticJoint(prim)
            scale = 1.0 if joint.type == "prismatic" else np.degrees(1.0)
            assert usd_joint.GetLowerLimitAttr().Get() == pytest.approx(joint.limits.lower * scale, abs=1e-4)
            assert usd_joint.GetUpperLimitAttr().Get() == pytest.approx(joint.limits.upper * scale, abs=1e-4)
    fixed = {str(p.GetPath()) for p in stage.Traverse() if p.IsA(UsdPhysics.FixedJoint) and p.GetName().endswith("__placed")}
    assert "/World/oven_1/joints/oven_1__placed" in fixed and not any(s in p for p in fixed for s in SMALL_OBJECTS)
    from pxr import UsdGeom, UsdShade

    visuals = [p for p in stage.Traverse() if p.IsA(UsdGeom.Mesh) and "/visuals/" in str(p.GetPath())]
    for prim in visuals:
        material, _ = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()
        object_id = str(prim.GetPath()).split("/")[2]
        assert material and material.GetPrim().GetName().startswith(f"{object_id}__"), prim.GetPath()
    colliders = [p for p in stage.Traverse() if p.HasAPI(UsdPhysics.CollisionAPI)]
    models = [load_urdf(urdf) for urdf in sorted((built_kitchen / "models").glob("*/model.urdf"))]
    floor_and_walls = 5
    assert len(colliders) == floor_and_walls + sum(len(link.collisions) for m in models for link in m.links)


def test_mesh_colliders_are_convex_hulls_in_every_format(tmp_path: Path) -> None:
    """A concave collision mesh (a bowl-like ring) goes out as its convex hull, with USD's
    convexHull approximation named."""
    import trimesh
    from pxr import Usd, UsdPhysics

    from articulation import Collision, Inertial, Link, Material, MeshGeometry, Model, Visual
    from articulation.scene import single_model_scene
    from homemodel.exchange.simulator import export_scene

    ring = trimesh.creation.annulus(r_min=0.05, r_max=0.08, height=0.04)
    link = Link(
        name="body",
        visuals=[Visual(name="ring", mesh=ring, material=Material(name="grey"))],
        collisions=[Collision(name="ring", geometry=MeshGeometry(mesh=ring))],
        inertial=Inertial(mass_kg=0.2, inertia_kgm2=np.eye(3) * 1e-4),
    )
    scene = single_model_scene(Model(name="ring", links=[link]))
    usd = export_scene(scene, tmp_path / "usd", "usd").file
    stage = Usd.Stage.Open(str(usd))
    hulls = [p for p in stage.Traverse() if p.HasAPI(UsdPhysics.MeshCollisionAPI)]
    assert len(hulls) == 1 and UsdPhysics.MeshCollisionAPI(hulls[0]).GetApproximationAttr().Get() == "convexHull"
    assert usd_errors(usd) == []
    mjcf = export_scene(scene, tmp_path / "mjcf", "mjcf").file
    model = load_mjcf(mjcf)
    hull = model.geom("ring__body_ring_collision")
    assert model.mesh_vertnum[hull.dataid[0]] == len(ring.convex_hull.vertices)
    sdf = export_scene(scene, tmp_path / "sdf", "sdf").file
    assert sdf_check(sdf)[0]
    uri = etree.parse(str(sdf)).getroot().findtext(".//collision/geometry/mesh/uri")
    assert trimesh.load(sdf.parent / uri).is_convex


def test_usd_validators_catch_a_broken_stage(kitchen_exports: dict[str, Path], tmp_path: Path) -> None:
    text = (kitchen_exports["usd"] / "scene.usda").read_text()
    broken = tmp_path / "scene.usda"
    broken.write_text(text.replace("</World/oven_1/oven_1__door_0>", "</World/oven_1/no_such_link>", 1))
    assert any("non existent prim" in e for e in usd_errors(broken))


def test_kitchen_scene_urdf_loads_in_pybullet_and_every_joint_moves(
    kitchen_exports: dict[str, Path], built_kitchen: Path
) -> None:
    import pybullet as pb

    from homemodel.exchange.urdf.read import load_urdf

    urdf = kitchen_exports["urdf"] / "scene.urdf"
    root = etree.parse(str(urdf)).getroot()
    movable = [j.get("name") for j in root.findall("joint") if j.get("type") != "fixed"]
    models = [load_urdf(urdf) for urdf in sorted((built_kitchen / "models").glob("*/model.urdf"))]
    assert len(movable) == sum(len(m.movable_joints) for m in models) and all("__" in name for name in movable)
    initial = {e.get("joint") for e in root.find("homemodel").findall("initial_position")}
    assert initial == set(movable)
    client = pb.connect(pb.DIRECT)
    try:
        body = pb.loadURDF(str(urdf), useFixedBase=True, physicsClientId=client)
        names = {pb.getJointInfo(body, i, physicsClientId=client)[1].decode(): i for i in range(pb.getNumJoints(body, physicsClientId=client))}
        for name in movable:
            info = pb.getJointInfo(body, names[name], physicsClientId=client)
            link = info[0]
            before = pb.getLinkState(body, link, computeForwardKinematics=True, physicsClientId=client)[4:6]
            pb.resetJointState(body, link, (info[8] + info[9]) / 2, physicsClientId=client)
            after = pb.getLinkState(body, link, computeForwardKinematics=True, physicsClientId=client)[4:6]
            moved = np.linalg.norm(np.subtract(after[0], before[0])) + np.linalg.norm(np.subtract(after[1], before[1]))
            assert moved > 1e-3, name
    finally:
        pb.disconnect(physicsClientId=client)
    from homemodel.model_folder.gate.clients import find_check_urdf

    assert subprocess.run([find_check_urdf(), str(urdf)], capture_output=True, timeout=60).returncode == 0


def test_kitchen_scene_glb_passes_the_khronos_validator(kitchen_exports: dict[str, Path]) -> None:
    from homemodel.model_folder.gate.gltf import gltf_checks

    checks = gltf_checks(kitchen_exports["glb"] / "scene.glb")
    assert all(c.passed for c in checks), [c for c in checks if not c.passed]
    doc = json.loads((kitchen_exports["glb"] / "export_summary.json").read_text())
    assert doc["format"] == "glb" and len(doc["objects"]) == 9


# One model: MuJoCo, SDF, USD, ROS 2 package


def _export_model(model_dir: Path, out: Path, fmt: str, *extra: str) -> Path:
    result = runner.invoke(app, ["export", str(model_dir), "--format", fmt, "--out", str(out), *extra])
    assert result.exit_code == 0, result.output
    return out


SCENE_FILES = {"mjcf": "scene.xml", "sdf": "scene.sdf", "usd": "scene.usda"}


def _scene_files(model_dir: Path, model, out: Path, *, by_command: bool) -> dict[str, Path]:
    """The model's MJCF, SDF and USD scene files, written by `homemodel export` (`by_command`)
    or by the same writer on `model`, the folder's one reading: the same files without the
    command's parsing and three more readings (33 catalogue models: 14 -> 7 CPU-s)."""
    if by_command:
        return {fmt: _export_model(model_dir, out / fmt, fmt) / file for fmt, file in SCENE_FILES.items()}
    from homemodel.exchange.simulator import export_model_for

    return {fmt: export_model_for(model, out / fmt, fmt).out_dir / file for fmt, file in SCENE_FILES.items()}


def _check_model_everywhere(model_dir: Path, out: Path, *, check_sdf: bool = True, by_command: bool = True) -> Path:
    """MuJoCo, USD and (`check_sdf`) Gazebo's check on the model's exports, and each export read
    back by our readers to the model (joints, limits, origins, masses, meshes); returns the SDF."""
    from articulation.scene import single_model_scene
    from homemodel.exchange.simulator_read import read_scene
    from homemodel.exchange.urdf.read import find_urdf, load_urdf

    model = load_urdf(find_urdf(model_dir))
    files = _scene_files(model_dir, model, out, by_command=by_command)
    original = single_model_scene(model).objects[0]
    for fmt, file in files.items():
        assert_same_model(original, read_scene(file).objects[0], fmt, TOLERANCE[fmt])
    assert_mujoco_stable(mujoco_figures(files["mjcf"]))
    if check_sdf:
        valid, said = sdf_check(files["sdf"])
        assert valid, said
    assert usd_errors(files["usd"]) == []
    return files["sdf"]


def _catalogue_model_dir(catalogue, name: str) -> Path:
    """The model's folder as the catalogue fixture exported it (only read here: the exports go
    to the test's own folder)."""
    catalogue[name]  # builds and exports it
    return catalogue._out_dir / name


@pytest.mark.parametrize("name", CATALOGUE_SAMPLE)
def test_catalogue_sample_in_every_simulator(catalogue, tmp_path: Path, name: str) -> None:
    _check_model_everywhere(_catalogue_model_dir(catalogue, name), tmp_path)


@pytest.mark.slow
def test_every_catalogue_model_in_every_simulator(catalogue, tmp_path: Path) -> None:
    """With the sample's tests above, every catalogue model: the sample is not checked twice.
    Gazebo's checker reads the SDF files in one run, and the exports are the writers' own on
    one reading of each folder (the sample's tests check theirs alone, through `homemodel export`)."""
    failures, sdfs = {}, []
    for name in sorted(set(CATALOGUE) - set(CATALOGUE_SAMPLE)):
        try:
            model_dir = _catalogue_model_dir(catalogue, name)
            sdfs.append(_check_model_everywhere(model_dir, tmp_path / name, check_sdf=False, by_command=False))
        except AssertionError as exc:
            failures[name] = str(exc).splitlines()[0]
    assert not failures, failures
    valid, said = sdf_check_together(sdfs, tmp_path / "catalogue.sdf")
    assert valid and len(sdfs) == len(CATALOGUE) - len(CATALOGUE_SAMPLE), said


def test_ros_package_resolves_every_uri_and_loads(built_kitchen: Path, tmp_path: Path) -> None:
    import yourdfpy

    from homemodel.exchange.urdf.mesh_paths import resolve_mesh
    from homemodel.model_folder.gate.clients import find_check_urdf
    from homemodel.model_folder.gate.validate import validate_path

    package = _export_model(built_kitchen / "models" / "oven_1", tmp_path / "kitchen_oven", "urdf-ros", "--package", "kitchen_oven")
    manifest = etree.parse(str(package / "package.xml")).getroot()
    assert manifest.findtext("name") == "kitchen_oven" and manifest.findtext("export/build_type") == "ament_cmake"
    assert {d.text for d in manifest.findall("exec_depend")} >= {"robot_state_publisher", "joint_state_publisher_gui"}
    cmake = (package / "CMakeLists.txt").read_text()
    assert "project(kitchen_oven)" in cmake and "install(DIRECTORY urdf meshes launch DESTINATION share/${PROJECT_NAME})" in cmake
    launch = package / "launch" / "display.launch.py"
    py_compile.compile(str(launch), doraise=True)
    assert "frame_prefix" in launch.read_text() and 'default_value="oven_1/"' in launch.read_text()
    urdf = package / "urdf" / "kitchen_oven.urdf"
    uris = [m.get("filename") for m in etree.parse(str(urdf)).getroot().iter("mesh")]
    assert uris and all(u.startswith("package://kitchen_oven/meshes/") for u in uris)
    for uri in uris:  # as RViz's resource retriever: the package's share folder is the package folder
        assert (package / uri.removeprefix("package://kitchen_oven/")).is_file()
        assert resolve_mesh(uri, urdf.parent) == (package / uri.removeprefix("package://kitchen_oven/")).resolve()

    def in_package(fname: str) -> str:
        return str(package / fname.removeprefix("package://kitchen_oven/"))

    loaded = yourdfpy.URDF.load(str(urdf), load_meshes=True, filename_handler=in_package)
    visuals = [m for v in etree.parse(str(urdf)).getroot().iter("visual") for m in v.iter("mesh")]
    assert len(loaded.scene.geometry) >= len(visuals) > 0
    assert subprocess.run([find_check_urdf(), str(urdf)], capture_output=True, timeout=60).returncode == 0
    report = validate_path(urdf)
    assert report.ok, report.format()


def test_package_uris_outside_the_package_are_refused(tmp_path: Path) -> None:
    from homemodel.core.errors import InputError
    from homemodel.exchange.urdf.mesh_paths import resolve_mesh

    package = tmp_path / "pkg"
    (package / "urdf").mkdir(parents=True)
    (package / "meshes").mkdir()
    (package / "meshes" / "a.obj").write_text("v 0 0 0\n")
    (tmp_path / "secret.obj").write_text("v 0 0 0\n")
    (package / "package.xml").write_text("<package format='3'><name>pkg</name></package>")
    assert resolve_mesh("package://pkg/meshes/a.obj", package / "urdf") == (package / "meshes" / "a.obj").resolve()
    for uri in ("package://pkg/../secret.obj", "package://other/meshes/a.obj", "package://pkg/meshes/none.obj"):
        with pytest.raises(InputError):
            resolve_mesh(uri, package / "urdf")


# Bad input: one line, exit 2, nothing written


def test_export_errors_are_one_line_and_write_nothing(built_kitchen: Path, tmp_path: Path) -> None:
    cases = [
        ["map", "export", str(built_kitchen / "map.xml"), "--format", "mjcf", "--room", "attic", "--out", str(tmp_path / "a")],
        ["map", "export", str(tmp_path / "none.xml"), "--format", "sdf", "--out", str(tmp_path / "b")],
        ["map", "export", str(built_kitchen / "map.xml"), "--format", "usd", "--out", str(built_kitchen / "models"), "--force"],
        ["export", str(built_kitchen / "models" / "oven_1"), "--format", "urdf-ros", "--package", "Bad-Name", "--out", str(tmp_path / "c")],
        ["export", str(built_kitchen / "models" / "oven_1"), "--format", "mjcf", "--package", "p", "--out", str(tmp_path / "d")],
    ]
    for args in cases:
        result = runner.invoke(app, args)
        assert result.exit_code == 2, (args, result.output)
        assert result.output.startswith("error: ") and len(result.output.strip().splitlines()) == 1, result.output
    assert not any((tmp_path / name).exists() for name in "abcd")
    assert (built_kitchen / "models" / "oven_1" / "model.urdf").is_file()


def test_a_map_whose_model_is_missing_names_the_object(built_kitchen: Path, tmp_path: Path) -> None:
    home = tmp_path / "home"
    shutil.copytree(built_kitchen, home, ignore=shutil.ignore_patterns("*.blend"))
    shutil.rmtree(home / "models" / "bowl_1")
    result = runner.invoke(app, ["map", "export", str(home / "map.xml"), "--format", "mjcf", "--out", str(tmp_path / "out")])
    assert result.exit_code == 2 and "bowl_1" in result.output and not (tmp_path / "out").exists()


def test_room_outline_comes_from_home_yaml_and_round_trips(built_kitchen: Path, tmp_path: Path) -> None:
    from homemodel.core.errors import MapError
    from homemodel.exchange.map_xml import load_map, map_to_bytes, save_map

    smap = load_map(built_kitchen / "map.xml")
    kitchen = smap.node("kitchen")
    assert kitchen.outline == [(0.0, 0.0), (4.0, 0.0), (4.0, 5.0), (0.0, 5.0)]
    assert smap.node("bathroom").outline is None
    save_map(smap, tmp_path / "map.xml")
    assert (tmp_path / "map.xml").read_bytes() == (built_kitchen / "map.xml").read_bytes() == map_to_bytes(smap)
    two_corners = (built_kitchen / "map.xml").read_text().replace('<corner xy="4.0 5.0"/>', "").replace('<corner xy="0.0 5.0"/>', "")
    (tmp_path / "bad.xml").write_text(two_corners)
    with pytest.raises(MapError, match="corner"):
        load_map(tmp_path / "bad.xml")


def test_photo_textures_on_flat_faces_in_mjcf_sdf_and_usd(tmp_path: Path) -> None:
    """A photo on a flat face (one quad, no volume) loads, with its texture and coordinates."""
    import trimesh
    from PIL import Image

    from articulation import Box, Collision, Inertial, Link, Material, Model, Visual
    from articulation.scene import single_model_scene
    from homemodel.exchange.simulator import export_scene

    photo = tmp_path / "front.jpg"
    Image.new("RGB", (64, 32), (200, 40, 30)).save(photo)
    quad = trimesh.Trimesh(vertices=[[0, -0.1, 0], [0, 0.1, 0], [0, 0.1, 0.2], [0, -0.1, 0.2]], faces=[[0, 1, 2], [0, 2, 3]])
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    link = Link(
        name="body",
        visuals=[
            Visual(name="box", mesh=trimesh.creation.box((0.1, 0.2, 0.2)), material=Material(name="card", rgba=(0.9, 0.8, 0.1, 1))),
            Visual(name="front", mesh=quad, material=Material(name="photo", texture=photo), uv=uv),
        ],
        collisions=[Collision(name="box", geometry=Box(size_m=(0.1, 0.2, 0.2)))],
        inertial=Inertial(mass_kg=0.3, inertia_kgm2=np.eye(3) * 1e-3),
    )
    scene = single_model_scene(Model(name="packet", links=[link]))
    xml = export_scene(scene, tmp_path / "mjcf", "mjcf").file
    model = load_mjcf(xml)
    assert model.ntex == 1 and Image.open(xml.parent / "meshes" / "packet" / "packet__front.png").size == (64, 32)
    front = model.geom("packet__body_front")
    assert model.mat_texid[front.matid[0]].max() == 0  # the photo's texture
    assert model.mesh_texcoordnum[front.dataid[0]] == 4
    assert model.geom("packet__body_box").matid[0] == -1 and model.geom("packet__body_box").rgba == pytest.approx([0.9, 0.8, 0.1, 1])

    sdf = export_scene(scene, tmp_path / "sdf", "sdf").file
    assert sdf_check(sdf)[0]
    albedo = etree.parse(str(sdf)).getroot().findtext(".//visual[@name='packet__body_front']/material/pbr/metal/albedo_map")
    assert Image.open(sdf.parent / albedo).size == (64, 32)
    assert "vt 1 1" in (sdf.parent / "meshes" / "packet" / "packet__body_front.obj").read_text()

    from pxr import Usd, UsdGeom, UsdShade

    usd = export_scene(scene, tmp_path / "usd", "usd").file
    assert usd_errors(usd) == []
    stage = Usd.Stage.Open(str(usd))
    front = stage.GetPrimAtPath("/World/packet/packet__body/visuals/packet__front")
    assert np.array(UsdGeom.PrimvarsAPI(front).GetPrimvar("st").Get()) == pytest.approx(uv)
    material, _ = UsdShade.MaterialBindingAPI(front).ComputeBoundMaterial()
    image = UsdShade.Shader(stage.GetPrimAtPath(f"{material.GetPath()}/photo"))
    assert Image.open(usd.parent / image.GetInput("file").Get().path).size == (64, 32)


def test_rooms_sharing_an_edge_get_one_wall_centred_on_it() -> None:
    from articulation.scene import WALL_THICKNESS_M, walls_from_outlines

    living = [(0.0, 0.0), (6.0, 0.0), (6.0, 3.0), (3.0, 3.0), (3.0, 5.0), (0.0, 5.0)]  # an L
    utility = [(3.0, 3.0), (6.0, 3.0), (6.0, 5.0), (3.0, 5.0)]
    walls = walls_from_outlines([("living", living), ("utility", utility)])
    shared = [w for w in walls if w.name.startswith("living__utility__")]
    assert len(walls) == 8 and len(shared) == 2
    for wall in shared:  # centred on x = 3 or y = 3
        centre = wall.world_from_wall()[:2, 3]
        assert min(abs(centre[0] - 3.0), abs(centre[1] - 3.0)) < 1e-9
    outer = next(w for w in walls if w.name == "living__wall_0")  # y = 0, outside the room
    assert outer.world_from_wall()[1, 3] == pytest.approx(-WALL_THICKNESS_M / 2)


@pytest.mark.parametrize("object_id", ["pill_box"])
def test_a_small_model_exported_free_rests_on_a_floor(built_kitchen: Path, tmp_path: Path, object_id: str) -> None:
    model_dir = built_kitchen / "models" / object_id
    figures = mujoco_figures(_export_model(model_dir, tmp_path / "mjcf", "mjcf", "--free") / "scene.xml")
    assert list(figures.free_drift_m) == [f"{object_id}__free"]
    assert_mujoco_stable(figures)
    sdf = _export_model(model_dir, tmp_path / "sdf", "sdf", "--free") / "scene.sdf"
    assert sdf_check(sdf)[0] and etree.parse(str(sdf)).getroot().find(".//joint/parent[.='world']") is None
    assert usd_errors(_export_model(model_dir, tmp_path / "usd", "usd", "--free") / "scene.usda") == []
    result = runner.invoke(app, ["export", str(model_dir), "--format", "urdf-ros", "--free", "--out", str(tmp_path / "ros")])
    assert result.exit_code == 2 and "--free" in result.output


def test_a_door_with_named_states_gets_keyframes_but_no_actuator(built_kitchen: Path, tmp_path: Path) -> None:
    """At a reset MuJoCo zeroes every control: a position actuator would pull a door shut."""
    import mujoco

    from articulation import JointState
    from articulation.scene import single_model_scene
    from homemodel.exchange.simulator import export_scene
    from homemodel.exchange.urdf.read import load_urdf

    cupboard = load_urdf(built_kitchen / "models" / "cupboard_1" / "model.urdf")
    cupboard.joint("door_0_hinge").states = [JointState(name="closed", position=0.0), JointState(name="open", position=1.5)]
    xml = export_scene(single_model_scene(cupboard), tmp_path / "mjcf", "mjcf").file
    model = load_mjcf(xml)
    assert model.nu == 0
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("cupboard_1__door_0_hinge=open").id)
    assert data.qpos[model.joint("cupboard_1__door_0_hinge").qposadr[0]] == pytest.approx(1.5)
    assert_mujoco_stable(mujoco_figures(xml))
