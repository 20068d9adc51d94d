"""End to end: `homemodel build examples/kitchen`, the models it writes, and the map."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from homemodel.cli import app

pytestmark = pytest.mark.bpy

runner = CliRunner()


@pytest.fixture(scope="module")
def built(built_kitchen: Path) -> Path:
    return built_kitchen


def test_build_writes_every_model_and_the_map(built: Path) -> None:
    import json

    rows = json.loads((built / "home_summary.json").read_text())["objects"]
    assert not (built / "summary.json").exists()  # summary.json is a model folder's, under models/<id>/
    assert {r["id"] for r in rows} == {
        "table_1",
        "cupboard_1",
        "fridge_1",
        "oven_1",
        "red_cup",
        "blue_cup",
        "bowl_1",
        "sugar_container",
        "pill_box",
    }
    assert all(r["valid"] for r in rows), [r["failed_checks"] for r in rows]
    for row in rows:
        folder = built / "models" / row["id"]
        for name in ("model.urdf", "model.glb", "model.blend", "summary.json"):
            assert (folder / name).is_file(), f"{row['id']}: {name} missing"
    cupboard = next(r for r in rows if r["id"] == "cupboard_1")
    assert cupboard["joints"] >= 3 and cupboard["grasp_points"] >= 3


def test_the_figure_47_scenario_is_in_the_map(built: Path) -> None:
    """D3.1 Figure 47: a kitchen and a bathroom; a table, cupboard, fridge and oven in the
    kitchen, each with parking positions; four small objects on the table; the pill box in
    the cupboard with its lid's hinge; the oven's knobs with their discrete states."""
    from homemodel.exchange.map_xml import load_map
    from semantic_map import LargeArticulatedObject

    smap = load_map(built / "map.xml")
    assert [r.id for r in smap.apartment.rooms] == ["kitchen", "bathroom"]
    kitchen = smap.node("kitchen")
    assert {o.type for o in kitchen.objects} == {"table", "cupboard", "fridge", "oven"}
    for large in kitchen.objects:
        assert smap.parking_positions(large.id), large.id
    assert {s.type for s in smap.node("table_1").small_objects} == {"cup", "bowl", "sugar_container"}
    pill_box = smap.node("pill_box")
    assert (pill_box.parent, pill_box.relation) == ("cupboard_1", "in")
    assert [j.name for j in pill_box.joints] == ["lid_hinge"]
    for appliance in ("fridge_1", "oven_1"):
        assert isinstance(smap.node(appliance), LargeArticulatedObject)
    knobs = [j for j in smap.node("oven_1").joints if j.states]
    assert knobs and all(j.states[0].name == "off" for j in knobs)
    smap.set_joint_state("oven_1", knobs[0].name, knobs[0].states[2].name)
    assert smap.node("oven_1").joint(knobs[0].name).position == pytest.approx(knobs[0].states[2].position)


def test_every_built_model_passes_the_gate_from_the_cli(built: Path) -> None:
    for folder in sorted((built / "models").iterdir()):
        result = runner.invoke(app, ["validate", str(folder)])
        assert result.exit_code == 0, result.output


def test_built_models_survive_import_and_re_export_byte_for_byte(built: Path, tmp_path: Path) -> None:
    from homemodel.exchange.model_files import export_model
    from homemodel.exchange.urdf.read import load_urdf

    for folder in sorted((built / "models").iterdir()):
        export_model(load_urdf(folder / "model.urdf"), tmp_path / folder.name)
        for name in ["model.urdf", "model.glb", *(f"meshes/{p.name}" for p in (folder / "meshes").iterdir())]:
            assert (tmp_path / folder.name / name).read_bytes() == (folder / name).read_bytes(), f"{folder.name}/{name}"


def test_the_blue_cup_walk_from_the_cli_and_the_api(built: Path) -> None:
    from homemodel.exchange.map_xml import load_map

    result = runner.invoke(app, ["map", "find", str(built / "map.xml"), "--type", "cup", "--property", "colour=blue"])
    assert result.exit_code == 0, result.output
    assert "blue_cup" in result.output and "table_1" in result.output and "south" in result.output
    assert "red_cup" not in result.output

    smap = load_map(built / "map.xml")
    (cup,) = smap.find(type="cup", properties={"colour": "blue"})
    assert smap.path_to(cup.id) == ["demo_house", "kitchen", "table_1", "blue_cup"]
    parent = smap.parent(cup.id)
    assert parent.id == "table_1"
    names = [p.name for p in smap.parking_positions(parent.id)]
    assert names == ["south", "east", "north"]
    # The cup stands on the table top in the map frame: table at (2.0, 1.5), cup at (-0.3, 0.2, 0.75) on it.
    assert smap.world_from_object(cup.id)[:3, 3] == pytest.approx([1.7, 1.7, 0.75], abs=1e-6)


def test_cupboard_joints_and_handles_flow_into_the_map(built: Path) -> None:
    from homemodel.exchange.map_xml import load_map
    from homemodel.exchange.urdf.read import load_urdf

    model = load_urdf(built / "models" / "cupboard_1" / "model.urdf")
    node = load_map(built / "map.xml").node("cupboard_1")
    assert {j.name for j in node.joints} == {j.name for j in model.movable_joints}
    assert {g.name for g in node.grasp_points} == {g.name for g in model.grasp_points}


def test_blender_imports_the_glb_back_at_the_right_size(built: Path) -> None:
    import bpy

    from homemodel.exchange.urdf.read import load_urdf

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=str(built / "models" / "table_1" / "model.glb"))
    meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    assert meshes
    corners = np.array([o.matrix_world @ v.co for o in meshes for v in o.data.vertices])
    expected = load_urdf(built / "models" / "table_1" / "model.urdf").world_mesh().bounds
    # Blender's importer turns glTF's y-up back into z-up: the table stands as built.
    assert np.array([corners.min(axis=0), corners.max(axis=0)]) == pytest.approx(expected, abs=1e-4)


def test_a_missing_spec_is_one_line_and_writes_nothing(tmp_path: Path, kitchen_dir: Path) -> None:
    example = tmp_path / "kitchen"
    shutil.copytree(kitchen_dir, example)
    (example / "blue_cup.yaml").unlink()
    out = tmp_path / "out"
    result = runner.invoke(app, ["build", str(example), "--out", str(out)])
    assert result.exit_code == 2
    assert "blue_cup.yaml" in result.output and "home.yaml" in result.output
    assert not out.exists()


def test_a_cup_floating_above_the_table_is_refused(tmp_path: Path, kitchen_dir: Path) -> None:
    example = tmp_path / "kitchen"
    shutil.copytree(kitchen_dir, example)
    home = example / "home.yaml"
    home.write_text(home.read_text().replace("pose: {xyz: [0.25, -0.15, 0.75]}", "pose: {xyz: [0.25, -0.15, 0.9]}"))
    out = tmp_path / "out"
    result = runner.invoke(app, ["build", str(example), "--out", str(out)])
    assert result.exit_code == 2, result.output
    assert "rooms.0.objects.0.objects.0.pose.xyz" in result.output
    assert not out.exists() and not list(tmp_path.glob(".out*"))


def test_build_refuses_to_write_over_or_inside_its_input(tmp_path: Path, kitchen_dir: Path) -> None:
    example = tmp_path / "kitchen"
    shutil.copytree(kitchen_dir, example)
    for out in (example, tmp_path, example / "out"):
        result = runner.invoke(app, ["build", str(example), "--out", str(out), "--force"])
        assert result.exit_code == 2 and "outside the input" in result.output, result.output
    assert (example / "home.yaml").is_file()


@pytest.mark.parametrize(
    ("old", "new", "field"),
    [
        ("xyz: [2.0, 1.5, 0.0]", "xyz: [.nan, 1.5, 0.0]", "rooms.0.objects.0.pose.xyz.0"),
        ("relation: \"on\"", "relation: beside", "rooms.0.objects.0.objects.0.relation"),
    ],
)
def test_bad_home_values_name_the_field(tmp_path: Path, kitchen_dir: Path, old: str, new: str, field: str) -> None:
    example = tmp_path / "kitchen"
    shutil.copytree(kitchen_dir, example)
    home = example / "home.yaml"
    assert old in home.read_text()
    home.write_text(home.read_text().replace(old, new, 1))
    result = runner.invoke(app, ["build", str(example), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2 and field in result.output, result.output


def test_build_refuses_a_non_empty_out_dir_without_force(tmp_path: Path, kitchen_dir: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    result = runner.invoke(app, ["build", str(kitchen_dir), "--out", str(out)])
    assert result.exit_code == 2 and "--force" in result.output
    assert (out / "keep.txt").read_text() == "mine"


def test_small_objects_set_on_their_parents_stay_put(built: Path) -> None:
    """Every model at its map pose in pybullet, the large ones fixed and the small ones free
    on their parents' surfaces: in 1 s of gravity no small object moves 5 mm."""
    import pybullet as pb

    from homemodel.core.c_stdio_capture import captured_c_output
    from homemodel.core.transforms import rpy_from_rotation
    from homemodel.exchange.map_xml import load_map
    from semantic_map import SmallObject

    smap = load_map(built / "map.xml")
    objects = [o for room in smap.apartment.rooms for o in room.objects]
    objects += [s for o in list(objects) for s in o.small_objects]
    assert sum(isinstance(o, SmallObject) for o in objects) == 5
    with captured_c_output():
        client = pb.connect(pb.DIRECT)
        try:
            free = {}
            for node in objects:
                world_from_object = smap.world_from_object(node.id)
                quaternion = pb.getQuaternionFromEuler(rpy_from_rotation(world_from_object[:3, :3]))
                body = pb.loadURDF(
                    str(built / "models" / node.id / "model.urdf"),
                    basePosition=world_from_object[:3, 3],
                    baseOrientation=quaternion,
                    useFixedBase=not isinstance(node, SmallObject),
                    flags=pb.URDF_USE_INERTIA_FROM_FILE,
                    physicsClientId=client,
                )
                if isinstance(node, SmallObject):
                    free[node.id] = body
            start = {k: np.array(pb.getBasePositionAndOrientation(b, physicsClientId=client)[0]) for k, b in free.items()}
            pb.setGravity(0, 0, -9.81, physicsClientId=client)
            for _ in range(240):
                pb.stepSimulation(physicsClientId=client)
            drift_mm = {
                k: 1000 * float(np.linalg.norm(np.array(pb.getBasePositionAndOrientation(b, physicsClientId=client)[0]) - start[k]))
                for k, b in free.items()
            }
        finally:
            pb.disconnect(physicsClientId=client)
    assert max(drift_mm.values()) < 5.0, drift_mm
