"""The model type, URDF/glTF export, URDF import: determinism, round trip, kinematics."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pytest
import trimesh
from PIL import Image

from articulation import (
    Box,
    Collision,
    GraspPoint,
    Joint,
    JointLimits,
    JointState,
    Link,
    Material,
    Model,
    Visual,
)
from articulation.inertia import inertial_from_meshes
from homemodel.core.errors import InputError, ModelError, UnsafeXMLError
from homemodel.core.transforms import transform_from_xyz_rpy
from homemodel.exchange.model_files import export_model
from homemodel.exchange.urdf.read import load_urdf


def _panel(size, centre) -> trimesh.Trimesh:
    mesh = trimesh.creation.box(size)
    mesh.apply_translation(centre)
    return mesh


def cupboard_model(texture: Path | None = None) -> Model:
    """A 0.4 m deep, 0.8 m wide, 0.9 m tall body; a door hinged on its left front edge; a knob."""
    body = _panel((0.4, 0.8, 0.9), (0.0, 0.0, 0.45))
    door = _panel((0.02, 0.78, 0.86), (0.01, -0.39, 0.0))
    knob = trimesh.creation.cylinder(radius=0.015, height=0.03)
    white = Material(name="white", rgba=(0.95, 0.95, 0.95, 1.0))
    wood = Material(name="oak", rgba=(1.0, 1.0, 1.0, 1.0), texture=texture)
    uv = None
    if texture is not None:
        uv = np.column_stack([(door.vertices[:, 1] + 0.78) / 0.78, door.vertices[:, 2] / 0.86 + 0.5])
    links = [
        Link(
            name="body",
            visuals=[Visual(name="shell", mesh=body, material=white)],
            collisions=[Collision(name="shell", geometry=Box(size_m=(0.4, 0.8, 0.9)), link_from_collision=transform_from_xyz_rpy((0, 0, 0.45)))],
            inertial=inertial_from_meshes([body], mass_kg=25.0),
        ),
        Link(
            name="door",
            visuals=[Visual(name="front", mesh=door, material=wood, uv=uv)],
            collisions=[Collision(name="front", geometry=Box(size_m=(0.02, 0.78, 0.86)), link_from_collision=transform_from_xyz_rpy((0.01, -0.39, 0)))],
            inertial=inertial_from_meshes([door], density_kg_m3=600.0),
        ),
        Link(
            name="knob",
            visuals=[Visual(name="knob", mesh=knob, material=white, link_from_visual=transform_from_xyz_rpy((0, 0, 0.015)))],
            inertial=inertial_from_meshes([knob], mass_kg=0.05),
        ),
    ]
    joints = [
        Joint(
            name="door_hinge",
            type="revolute",
            parent="body",
            child="door",
            parent_from_joint=transform_from_xyz_rpy((0.2, 0.4, 0.45)),
            axis=(0, 0, 1),
            limits=JointLimits(lower=0.0, upper=np.radians(100)),
            states=[JointState(name="closed", position=0.0), JointState(name="open", position=1.5)],
        ),
        Joint(
            name="knob_mount",
            type="fixed",
            parent="door",
            child="knob",
            parent_from_joint=transform_from_xyz_rpy((0.02, -0.7, 0.0), (0, np.pi / 2, 0)),
        ),
    ]
    grasp = GraspPoint(name="door_knob", link="knob", link_from_grasp=transform_from_xyz_rpy((0, 0, 0.03)), kind="knob")
    return Model(name="cupboard", links=links, joints=joints, grasp_points=[grasp], category="cupboard", affordances=["container"])


@pytest.fixture
def texture(tmp_path: Path) -> Path:
    path = tmp_path / "oak.png"
    rng = np.random.default_rng(0)
    Image.fromarray(rng.integers(0, 255, (32, 32, 3), dtype=np.uint8)).save(path)
    return path


def _tree_bytes(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_world_from_links_moves_the_door_about_its_hinge() -> None:
    model = cupboard_model()
    closed = model.world_from_grasp_points()["door_knob"][:3, 3]
    opened = model.world_from_grasp_points({"door_hinge": np.pi / 2})["door_knob"][:3, 3]
    hinge = np.array([0.2, 0.4])
    # The knob keeps its distance to the hinge line and its height, and swings out in front (+x).
    assert np.linalg.norm(closed[:2] - hinge) == pytest.approx(np.linalg.norm(opened[:2] - hinge))
    assert opened[2] == pytest.approx(closed[2])
    assert opened[0] > 0.2 + 0.6
    assert opened[1] == pytest.approx(0.4 + 0.02 + 0.03, abs=1e-9)  # knob standoff + grasp offset


def test_model_rejects_a_second_root_and_unknown_links() -> None:
    link = Link(name="a")
    with pytest.raises(ModelError, match="one root"):
        Model(name="m", links=[link, Link(name="b")])
    with pytest.raises(ModelError, match="unknown link"):
        Model(name="m", links=[link], joints=[Joint(name="j", type="fixed", parent="a", child="zz")])


def test_export_is_deterministic(tmp_path: Path, texture: Path) -> None:
    export_model(cupboard_model(texture), tmp_path / "one")
    export_model(cupboard_model(texture), tmp_path / "two")
    one, two = _tree_bytes(tmp_path / "one"), _tree_bytes(tmp_path / "two")
    assert set(one) >= {"model.urdf", "model.glb", "meshes/door_front.obj", "meshes/door_front.mtl", "meshes/oak_texture.png"}
    assert one == two


def test_urdf_paths_are_relative_and_textures_travel(tmp_path: Path, texture: Path) -> None:
    export_model(cupboard_model(texture), tmp_path / "m")
    urdf = (tmp_path / "m" / "model.urdf").read_text()
    assert 'filename="meshes/' in urdf and str(tmp_path) not in urdf
    assert "map_Kd oak_texture.png" in (tmp_path / "m" / "meshes" / "door_front.mtl").read_text()
    assert "vt " in (tmp_path / "m" / "meshes" / "door_front.obj").read_text()


def test_round_trip_export_import_export_is_byte_identical(tmp_path: Path, texture: Path) -> None:
    export_model(cupboard_model(texture), tmp_path / "first")
    model = load_urdf(tmp_path / "first" / "model.urdf")
    assert [j.name for j in model.movable_joints] == ["door_hinge"]
    assert [s.name for s in model.joint("door_hinge").states] == ["closed", "open"]
    assert model.grasp_points[0].kind == "knob" and model.category == "cupboard"
    assert model.link("door").visuals[0].material.texture is not None
    export_model(model, tmp_path / "second")
    assert _tree_bytes(tmp_path / "first") == _tree_bytes(tmp_path / "second")


def test_glb_has_a_node_per_link_with_joint_extras(tmp_path: Path) -> None:
    export_model(cupboard_model(), tmp_path / "m")
    data = (tmp_path / "m" / "model.glb").read_bytes()
    magic, version, length = struct.unpack("<4sII", data[:12])
    assert (magic, version, length) == (b"glTF", 2, len(data))
    (json_length,) = struct.unpack("<I", data[12:16])
    doc = json.loads(data[20 : 20 + json_length])
    nodes = {n["name"]: n for n in doc["nodes"]}
    assert set(nodes) == {"cupboard", "body", "door", "knob"}
    assert nodes["door"]["extras"]["joint"]["type"] == "revolute"
    assert nodes["door"]["translation"] == pytest.approx([0.2, 0.4, 0.45])
    assert nodes["cupboard"]["extras"]["homemodel"]["grasp_points"][0]["name"] == "door_knob"


def test_glb_reads_back_in_trimesh_in_the_same_place(tmp_path: Path) -> None:
    model = cupboard_model()
    export_model(model, tmp_path / "m")
    scene = trimesh.load(tmp_path / "m" / "model.glb")
    # trimesh keeps glTF's y-up; turn it back to the model's z-up before comparing.
    y_up_to_z_up = transform_from_xyz_rpy((0, 0, 0), (np.pi / 2, 0, 0))
    bounds = trimesh.transform_points(scene.bounds, y_up_to_z_up)
    expected = model.world_mesh().bounds
    assert np.sort(bounds, axis=0) == pytest.approx(expected, abs=1e-5)


def _partnet_folder(root: Path) -> Path:
    """A PartNet-Mobility-style folder: mobility.urdf, several OBJ parts per link, no inertials."""
    objs = root / "textured_objs"
    objs.mkdir(parents=True)
    for i, centre in enumerate([(0, 0, 0.2), (0, 0, 0.6), (0.21, -0.2, 0.4), (0.23, -0.35, 0.4)]):
        _panel((0.4, 0.4, 0.4) if i < 2 else (0.02, 0.38, 0.38), centre).export(objs / f"original-{i + 1}.obj")
    (root / "mobility.urdf").write_text(
        """<?xml version="1.0"?>
<robot name="partnet_7128">
  <link name="base"/>
  <link name="link_0">
    <visual name="door-1"><origin xyz="0 0 0"/><geometry><mesh filename="textured_objs/original-3.obj"/></geometry></visual>
    <visual name="door-2"><origin xyz="0 0 0"/><geometry><mesh filename="textured_objs/original-4.obj"/></geometry></visual>
    <collision><origin xyz="0 0 0"/><geometry><mesh filename="textured_objs/original-3.obj"/></geometry></collision>
  </link>
  <joint name="joint_0" type="revolute">
    <origin xyz="0.22 0.0 0"/><axis xyz="0 0 1"/><child link="link_0"/><parent link="link_1"/>
    <limit lower="0.0" upper="1.5707963"/>
  </joint>
  <link name="link_1">
    <visual name="body-1"><geometry><mesh filename="textured_objs/original-1.obj"/></geometry></visual>
    <visual name="body-2"><geometry><mesh filename="textured_objs/original-2.obj"/></geometry></visual>
  </link>
  <joint name="joint_1" type="fixed"><origin rpy="1.570796326794897 0 -1.570796326794897" xyz="0 0 0"/><child link="link_1"/><parent link="base"/></joint>
</robot>
"""
    )
    return root / "mobility.urdf"


def test_import_partnet_mobility_style_urdf(tmp_path: Path) -> None:
    model = load_urdf(_partnet_folder(tmp_path / "7128"))
    assert model.root_link == "base"
    assert [len(model.link(n).visuals) for n in ("base", "link_0", "link_1")] == [0, 2, 2]
    assert model.movable_joints[0].limits.upper == pytest.approx(np.pi / 2)
    assert isinstance(model.link("link_0").collisions[0].geometry.mesh, trimesh.Trimesh)
    export_model(model, tmp_path / "out")
    export_model(load_urdf(tmp_path / "out" / "model.urdf"), tmp_path / "again")
    assert _tree_bytes(tmp_path / "out") == _tree_bytes(tmp_path / "again")
    assert load_urdf(tmp_path / "out" / "model.urdf").world_from_links({"joint_0": 1.0}).keys() == {"base", "link_0", "link_1"}


@pytest.mark.parametrize(
    ("body", "error", "match"),
    [
        ('<!DOCTYPE r [<!ENTITY e SYSTEM "file:///etc/passwd">]><robot name="&e;"/>', UnsafeXMLError, "DOCTYPE"),
        ('<robot name="r"><link name="a"><visual><geometry><mesh filename="../x.obj"/></geometry></visual></link></robot>', InputError, "outside the model folder"),
        ('<robot name="r"><link name="a"><visual><geometry><mesh filename="/etc/x.obj"/></geometry></visual></link></robot>', InputError, "absolute paths are not allowed"),
        ('<robot name="r"><link name="a"/><link name="b"/></robot>', InputError, "one root"),
        ('<robot name="r"><link name="a"><visual><origin xyz="1 two 3"/><geometry><box size="1 1 1"/></geometry></visual></link></robot>', InputError, "line 1"),
        ("<robot name='r'><link", InputError, "not well-formed"),
    ],
)
def test_import_refuses_bad_urdf_with_the_file_named(tmp_path: Path, body: str, error: type, match: str) -> None:
    path = tmp_path / "bad.urdf"
    path.write_text(body)
    with pytest.raises(error, match=match) as info:
        load_urdf(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def test_a_partnet_mobility_folder_registers_into_a_map_from_the_cli(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from homemodel.cli import app
    from homemodel.exchange.map_xml import load_map, save_map
    from semantic_map import SemanticMap

    folder = _partnet_folder(tmp_path / "7128").parent
    smap = SemanticMap.new(apartment_id="flat", name="Flat")
    smap.add_room(room_id="kitchen", name="Kitchen")
    save_map(smap, tmp_path / "map.xml")
    result = CliRunner().invoke(
        app,
        ["map", "add", str(tmp_path / "map.xml"), str(folder), "--id", "cabinet", "--parent", "kitchen", "--parking", "front=1 0 3.14"],
    )
    assert result.exit_code == 0, result.output
    node = load_map(tmp_path / "map.xml").node("cabinet")
    assert [j.name for j in node.joints] == ["joint_0"]
    assert node.model_ref == "7128/mobility.urdf"


def test_joint_dynamics_round_trip_through_urdf(tmp_path):
    """`<dynamics damping friction>` is written for a joint that has it and read back."""
    import trimesh

    from articulation import Joint, JointDynamics, JointLimits, Link, Material, Model, Visual
    from homemodel.exchange.urdf.read import load_urdf
    from homemodel.exchange.urdf.write import write_urdf

    box = trimesh.creation.box((0.1, 0.1, 0.1))
    grey = Material(name="grey")
    links = [Link(name=n, visuals=[Visual(name=n, mesh=box, material=grey)]) for n in ("base", "door")]
    door = Joint(
        name="hinge", type="revolute", parent="base", child="door",
        limits=JointLimits(lower=0.0, upper=1.5), dynamics=JointDynamics(damping=0.5, friction=0.25),
    )
    loaded = load_urdf(write_urdf(Model(name="m", links=links, joints=[door]), tmp_path))
    assert loaded.joint("hinge").dynamics == JointDynamics(damping=0.5, friction=0.25)


def test_glb_joint_extras_carry_the_joint_dynamics(tmp_path: Path) -> None:
    from articulation import JointDynamics

    model = cupboard_model()
    model.joint("door_hinge").dynamics = JointDynamics(damping=0.5, friction=0.25)
    export_model(model, tmp_path / "m")
    data = (tmp_path / "m" / "model.glb").read_bytes()
    (json_length,) = struct.unpack("<I", data[12:16])
    nodes = {n["name"]: n for n in json.loads(data[20 : 20 + json_length])["nodes"]}
    assert (nodes["door"]["extras"]["joint"]["damping"], nodes["door"]["extras"]["joint"]["friction"]) == (0.5, 0.25)
    assert "damping" not in nodes["knob"]["extras"]["joint"]
