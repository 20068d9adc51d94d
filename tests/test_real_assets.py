"""Real assets imported whole: a PartNet-Mobility folder with the real ones' traits (open
sheets, many OBJ parts per link, y up, no inertials), a ROS description package with
`package://` STL and DAE meshes, and a glb of a small object; masses from closed volumes,
never NaN, every repair stated, the gate passed; the gate refuses NaN and infinity."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import trimesh

from homemodel.model_folder.asset_import import ImportOptions, import_asset
from homemodel.exchange.model_files import write_model_files
from homemodel.model_folder.gate import validate_path
from homemodel.model_folder.repair import RepairOptions, repair
from homemodel.core.errors import InputError
from partnet_sample import REAL_D, REAL_H, REAL_W, write_partnet_real_traits
from ros_sample import write_ros_workspace

DENSITY = 500.0
VOXEL_M = 0.01


@pytest.fixture(scope="module")
def partnet_built(tmp_path_factory):
    folder = tmp_path_factory.mktemp("partnet_real")
    sheets = write_partnet_real_traits(folder / "asset")
    imported = import_asset(folder / "asset")
    model, done = repair(imported.model, imported.gaps, RepairOptions(density_kg_m3=DENSITY, voxel_size_m=VOXEL_M))
    write_model_files(model, folder / "out")
    return sheets, imported, model, done, folder / "out"


def test_partnet_masses_come_from_voxel_filled_sheets_not_their_hulls(partnet_built) -> None:
    sheets, imported, model, done, _ = partnet_built
    assert imported.kind == "partnet" and imported.gaps.links_without_inertial == ["link_0", "link_1", "link_2"]
    masses = {link.name: link.inertial.mass_kg for link in model.links if link.inertial is not None}
    # The body: open sheets one voxel thick (area x 10 mm x density, within the voxels' staircase),
    # about a tenth of what its convex hull (the cavity included) would weigh.
    body_area = sum(s.area for s in sheets["link_2"])
    assert 0.9 <= masses["link_2"] / (body_area * VOXEL_M * DENSITY) <= 1.6, masses
    assert masses["link_2"] < 0.15 * REAL_W * REAL_H * REAL_D * DENSITY
    # The door: six separate sheets that close a panel: the voxel fill fills it (20 x 700 x 900 mm).
    door_solid = 0.02 * REAL_H / 2 * REAL_W * DENSITY
    assert 0.9 <= masses["link_1"] / door_solid <= 1.8, masses
    for link in model.links:
        if link.inertial is not None:
            assert np.all(np.isfinite(link.inertial.com_m)) and np.all(np.isfinite(link.inertial.inertia_kgm2))
            assert np.all(np.linalg.eigvalsh(link.inertial.inertia_kgm2) > 0)
    # Every repair is stated with its method and density.
    said = "\n".join(done)
    assert said.count("voxel fill of its open meshes at 10 mm") == 3 and said.count("at 500 kg/m^3") == 3
    assert "flat collision mesh(es)" in said and "joint 'joint_0': effort set to 10, velocity set to 1" in said
    # The body's sheets in one file: a hull would fill the cavity the drawer slides in.
    assert imported.gaps.hollow_collisions == ["link_2/collision0"]
    assert "link 'link_2': 1 open collision mesh(es) whose hull would fill a cavity made one box 10 mm thick per flat panel" in said
    body = [c for c in model.link("link_2").collisions if c.name.startswith("collision0_panel")]
    assert len(body) == 5


def test_partnet_import_keeps_its_shape_frame_and_textures(partnet_built) -> None:
    _, imported, model, _, _ = partnet_built
    low, high = model.world_mesh().bounds
    assert low[2] == pytest.approx(0.0, abs=1e-9) and high[2] - low[2] == pytest.approx(REAL_H, abs=1e-6)  # y up -> z up
    # The drawer opens out of the front (+x), its full travel, and stays level.
    drawer = model.joint("joint_0")
    closed = model.world_from_links()["link_0"][:3, 3]
    opened = model.world_from_links({"joint_0": drawer.limits.upper})["link_0"][:3, 3]
    np.testing.assert_allclose(opened - closed, [drawer.limits.upper, 0, 0], atol=1e-9)
    # Many parts per link, several sharing one visual name; the MTL's ../images texture found.
    door = model.link("link_1")
    assert len(door.visuals) == 6 and all(v.material.texture is not None for v in door.visuals)
    assert door.visuals[0].material.texture.parent.name == "images"


def test_partnet_repaired_model_passes_the_gate_with_no_nan(partnet_built) -> None:
    *_, out = partnet_built
    text = (out / "model.urdf").read_text()
    assert not re.search(r"nan|inf", text, re.IGNORECASE)
    report = validate_path(out)
    assert report.ok, report.format()


@pytest.fixture()
def ros_workspace(tmp_path: Path) -> Path:
    """tests/ros_sample.py's workspace: the arm link without an inertial."""
    return write_ros_workspace(tmp_path)


def test_a_ros_package_imports_with_package_uris_dae_units_and_node_transforms(ros_workspace: Path, tmp_path: Path, monkeypatch) -> None:
    urdf = ros_workspace / "arm_description" / "urdf" / "arm.urdf"
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    with pytest.raises(InputError, match=r"arm\.urdf: line \d+: mesh 'package://shared_meshes/meshes/knob\.dae': .*cannot be resolved"):
        import_asset(urdf)  # shared_meshes is another package: not found without a package path
    imported = import_asset(urdf, ImportOptions(package_paths=[ros_workspace]))
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(ros_workspace))  # a sourced ROS 1 workspace finds it too
    assert len(import_asset(urdf).model.link("arm_link").visuals) == 2
    arm = imported.model.link("arm_link")
    dae = arm.visuals[0].mesh
    # 50 x 50 x 300 mm, its node 150 mm up: in metres, from z = 0 to 0.3 (RViz's reading).
    np.testing.assert_allclose(dae.bounds, [[-0.025, -0.025, 0.0], [0.025, 0.025, 0.3]], atol=1e-9)
    assert arm.visuals[1].mesh.extents == pytest.approx([0.06, 0.06, 0.06], rel=0.05)
    assert imported.gaps.links_without_inertial == ["arm_link"]
    model, done = repair(imported.model, imported.gaps, RepairOptions(density_kg_m3=1000.0))
    arm_mass = model.link("arm_link").inertial.mass_kg
    volume = 0.05 * 0.05 * 0.3 + 4 / 3 * np.pi * 0.03**3  # closed meshes: their own volume
    assert arm_mass == pytest.approx(1000.0 * volume, rel=0.02)
    assert "closed meshes' volume" in done[0]
    write_model_files(model, tmp_path / "out")
    report = validate_path(tmp_path / "out")
    assert report.ok, report.format()


def test_package_uris_stay_inside_their_package(ros_workspace: Path, tmp_path: Path) -> None:
    urdf = ros_workspace / "arm_description" / "urdf" / "arm.urdf"
    (tmp_path / "secret.stl").write_bytes((ros_workspace / "arm_description" / "meshes" / "base.stl").read_bytes())
    text = urdf.read_text().replace("package://arm_description/meshes/base.stl", "package://arm_description/../../../secret.stl")
    urdf.write_text(text)
    with pytest.raises(InputError, match="cannot be resolved"):
        import_asset(urdf, ImportOptions(package_paths=[ros_workspace]))


def test_a_dae_with_a_doctype_is_refused_before_pycollada_reads_it(ros_workspace: Path) -> None:
    dae = ros_workspace / "shared_meshes" / "meshes" / "knob.dae"
    dae.write_text(dae.read_text().replace('<?xml version="1.0" encoding="utf-8"?>', '<?xml version="1.0"?><!DOCTYPE c [<!ENTITY x SYSTEM "file:///etc/passwd">]>'))
    with pytest.raises(InputError, match="knob.dae"):
        import_asset(ros_workspace / "arm_description" / "urdf" / "arm.urdf", ImportOptions(package_paths=[ros_workspace]))


def test_a_glb_of_a_small_object_is_a_one_link_model_on_the_floor(tmp_path: Path) -> None:
    # A mug-sized cylinder, 10 cm tall along glTF's +y, coloured, off the origin.
    cup = trimesh.creation.cylinder(radius=0.04, height=0.1, sections=48)
    cup.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0]))  # z -> y
    cup.apply_translation((0.3, 0.5, -0.2))
    cup.visual = trimesh.visual.ColorVisuals(cup, face_colors=[30, 60, 200, 255])
    glb = tmp_path / "blue cup.glb"  # a space in the name, as downloaded files have
    glb.write_bytes(trimesh.Scene(cup).export(file_type="glb"))
    imported = import_asset(glb, texture_dir=tmp_path)
    assert imported.kind == "mesh" and [link.name for link in imported.model.links] == ["body"]
    low, high = imported.model.world_mesh().bounds
    np.testing.assert_allclose(low, [-0.04, -0.04, 0.0], atol=1e-3)
    np.testing.assert_allclose(high, [0.04, 0.04, 0.1], atol=1e-3)
    model, done = repair(imported.model, imported.gaps, RepairOptions(density_kg_m3=700.0))
    assert model.link("body").inertial.mass_kg == pytest.approx(700.0 * cup.volume, rel=1e-6)
    np.testing.assert_allclose(model.link("body").inertial.com_m, [0, 0, 0.05], atol=1e-6)
    assert "closed meshes' volume" in done[0] and "700 kg/m^3" in done[0]
    assert imported.notes == [
        "frame: 1 mesh part(s) as one link, y up (glTF's) turned to z up, standing on the floor (z = 0) with its footprint centred on the origin",
        "units: metres (glTF's)",
    ]
    write_model_files(model, tmp_path / "out")
    report = validate_path(tmp_path / "out")
    assert report.ok, report.format()


def test_a_bad_mesh_file_is_an_input_error_naming_it(tmp_path: Path) -> None:
    bad = tmp_path / "broken.glb"
    bad.write_bytes(b"glTF not really")
    with pytest.raises(InputError, match="broken.glb"):
        import_asset(bad)


@pytest.mark.parametrize(
    ("old", "new", "said"),
    [
        ('<origin xyz="0 0 0.05"/>', '<origin xyz="nan nan nan"/>', r"joint 'shoulder': line \d+: <origin xyz='nan nan nan'> is not finite"),
        ('<axis xyz="0 0 1"/>', '<axis xyz="0 0 inf"/>', "<axis xyz='0 0 inf'> is not finite"),
        ('upper="1.5"', 'upper="NaN"', "<limit upper='NaN'> is not finite"),
        ('<mass value="2.0"/>', '<mass value="nan"/>', "<mass value='nan'> is not finite"),
        ('ixx="0.03"', 'ixx="-inf"', "<inertia ixx='-inf'> is not finite"),
    ],
)
def test_the_gate_refuses_nan_and_infinity_anywhere(ros_workspace: Path, tmp_path: Path, old: str, new: str, said: str) -> None:
    urdf = ros_workspace / "arm_description" / "urdf" / "arm.urdf"
    urdf.write_text(urdf.read_text().replace(old, new))
    report = validate_path(urdf)
    checks = {c.name: c for c in report.checks}
    assert not checks["finite numbers"].passed and re.search(said, checks["finite numbers"].detail), report.format()
    assert checks["pybullet"].detail.startswith("not run: a simulation with NaN")


def test_an_axis_not_of_unit_length_is_made_so_and_said(ros_workspace: Path, tmp_path: Path) -> None:
    urdf = ros_workspace / "arm_description" / "urdf" / "arm.urdf"
    urdf.write_text(urdf.read_text().replace('<axis xyz="0 0 1"/>', '<axis xyz="0 0 0.9999"/>'))
    imported = import_asset(urdf, ImportOptions(package_paths=[ros_workspace]))
    assert imported.gaps.axes_not_unit == ["shoulder"]
    model, done = repair(imported.model, imported.gaps, RepairOptions())
    np.testing.assert_allclose(model.joint("shoulder").axis, [0, 0, 1])
    assert "joint 'shoulder': axis of length 0.9999 made of length 1 (its direction kept)" in done


@pytest.mark.parametrize("suffix", [".glb", ".obj"])
def test_a_textured_mesh_file_keeps_its_texture(tmp_path: Path, suffix: str) -> None:
    from PIL import Image

    box = trimesh.creation.box(extents=(0.1, 0.06, 0.04))
    gradient = Image.fromarray(np.tile(np.arange(256, dtype=np.uint8)[:, None, None], (1, 16, 3)))
    uv = np.random.default_rng(0).random((len(box.vertices), 2))
    box.visual = trimesh.visual.TextureVisuals(uv=uv, image=gradient)
    path = tmp_path / f"box{suffix}"
    if suffix == ".glb":
        path.write_bytes(trimesh.Scene(box).export(file_type="glb"))
    else:
        box.export(path)  # writes material.mtl and material_0.png beside it
    (tmp_path / "textures").mkdir()
    imported = import_asset(path, texture_dir=tmp_path / "textures")
    [visual] = imported.model.link("body").visuals
    assert visual.material.texture is not None and visual.uv is not None
    np.testing.assert_allclose(visual.uv, uv, atol=1e-6)
    kept = np.asarray(Image.open(visual.material.texture).convert("RGB"))
    assert kept.shape == (256, 16, 3) and kept[200, 0, 0] == 200  # the image itself, not a colour
    model, _ = repair(imported.model, imported.gaps, RepairOptions())
    write_model_files(model, tmp_path / "out")
    assert any(p.name.endswith("_texture.png") for p in (tmp_path / "out" / "meshes").iterdir())


def test_a_xacro_file_is_refused_with_what_to_do(tmp_path: Path) -> None:
    xacro = tmp_path / "robot.urdf.xacro"
    xacro.write_text('<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="r"><xacro:property name="w" value="1"/></robot>')
    with pytest.raises(InputError, match=r"robot\.urdf\.xacro: a xacro macro file, not a URDF: expand it first"):
        import_asset(xacro)


def test_link_mass_never_nan_and_each_way_measured() -> None:
    from articulation.inertia import link_mass
    from partnet_sample import _open_box

    kwargs = {"density_kg_m3": 500.0, "voxel_size_m": 0.01, "default_mass_kg": 2.0, "default_size_m": 0.1}
    # Closed: the mesh's own volume, exactly.
    box = trimesh.creation.box(extents=(0.4, 0.3, 0.2))
    closed = link_mass([box], **kwargs)
    assert closed.inertial.mass_kg == pytest.approx(500.0 * 0.024) and "closed meshes" in closed.method
    np.testing.assert_allclose(closed.inertial.inertia_kgm2, box.moment_inertia * 500.0, rtol=1e-9)
    # Open sheets: a voxel shell; symmetric sheets give a centre of mass on the symmetry axis.
    sheets = _open_box((-0.4, -0.3, -0.2), (0.4, 0.3, 0.2), "+z")
    shell = link_mass(sheets, **kwargs)
    area = sum(s.area for s in sheets)
    assert 0.9 <= shell.volume_m3 / (area * 0.01) <= 1.6 and "voxel fill" in shell.method
    np.testing.assert_allclose(shell.inertial.com_m[:2], [0, 0], atol=1e-9)
    assert shell.inertial.com_m[2] < 0  # the open top pulls it down
    # Closed by six separate sheets: filled, within the voxels' staircase.
    filled = link_mass(_open_box((-0.4, -0.3, -0.2), (0.4, 0.3, 0.2), None), **kwargs)
    assert filled.volume_m3 == pytest.approx(0.8 * 0.6 * 0.4, rel=0.12)
    # Nothing with area: the stated default, centred on what there is.
    line = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 1, 2]], process=False)
    default = link_mass([line], **kwargs)
    assert default.inertial.mass_kg == 2.0 and "stated default 2 kg" in default.method
    np.testing.assert_allclose(default.inertial.com_m, [1, 0, 0])
    for found in (closed, shell, filled, default):
        assert np.all(np.isfinite(found.inertial.inertia_kgm2)) and np.all(np.linalg.eigvalsh(found.inertial.inertia_kgm2) > 0)


def test_a_flat_mesh_file_gets_a_thin_collision_box(tmp_path: Path) -> None:
    """A sheet (a poster, a place mat) has no volume to collide with: its collision becomes a box."""
    from partnet_sample import _sheet

    mat = _sheet((0, 0, 0), (0.4, 0, 0), (0, 0.3, 0))
    mat.export(tmp_path / "place mat.stl")
    imported = import_asset(tmp_path / "place mat.stl")
    assert imported.gaps.flat_collisions == ["body/hull"]
    model, done = repair(imported.model, imported.gaps, RepairOptions(voxel_size_m=0.005))
    [collision] = model.link("body").collisions
    assert sorted(collision.geometry.size_m) == pytest.approx([0.005, 0.3, 0.4])
    assert any("1 flat collision mesh(es)" in line for line in done)
    write_model_files(model, tmp_path / "out")
    report = validate_path(tmp_path / "out")
    assert report.ok, report.format()


def test_a_mesh_file_where_a_model_is_needed_says_how_to_import_it(tmp_path: Path) -> None:
    from homemodel.exchange.urdf.read import find_urdf

    trimesh.creation.box().export(tmp_path / "cup.glb")
    with pytest.raises(InputError, match=r"cup\.glb: a mesh file, not a model: import it first"):
        find_urdf(tmp_path / "cup.glb")
