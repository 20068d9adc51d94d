"""`homemodel map add` of a raw asset: a downloaded glb or OBJ of a small object, or a ROS
description package's URDF, imported into a model folder of its own (units and up axis
stated, mass from a closed volume at a stated density, the gate passed) and registered; a
corrupt or hostile file is one line and exit 2, with nothing written."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import trimesh
from typer.testing import CliRunner

from homemodel.cli import app
from ros_sample import write_ros_workspace
from homemodel.exchange.map_xml import load_map

RADIUS_M, HEIGHT_M, WALL_M, FLOOR_M = 0.04, 0.1, 0.005, 0.006


@pytest.fixture(scope="module")
def mug() -> trimesh.Trimesh:
    """A closed, thick-walled mug (z up, metres): its volume is the ground truth of its mass."""
    outer = trimesh.creation.cylinder(radius=RADIUS_M, height=HEIGHT_M, sections=48)
    inner = trimesh.creation.cylinder(radius=RADIUS_M - WALL_M, height=HEIGHT_M, sections=48)
    inner.apply_translation([0.0, 0.0, FLOOR_M])
    mug = outer.difference(inner)
    assert mug.is_volume
    return mug


def _add(map_path: Path, asset: Path, object_id: str, *flags: str):  # noqa: ANN202 (click's Result)
    return CliRunner().invoke(app, ["map", "add", str(map_path), str(asset), "--id", object_id, "--parent", "table", *flags])


def _summary(folder: Path) -> dict:
    return json.loads((folder / "summary.json").read_text())


def test_a_glb_cup_is_imported_y_up_to_z_up_with_its_mass_from_its_volume(mug, house_file: Path, tmp_path: Path) -> None:
    asset = tmp_path / "downloads" / "cup.glb"
    asset.parent.mkdir()
    y_up = mug.copy()
    y_up.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0]))  # glTF: +y up
    y_up.export(asset)
    done = _add(house_file, asset, "green_cup", "--type", "cup", "--property", "colour=green", "--xyz", "0.1", "0", "0.75")
    assert done.exit_code == 0, done.output
    folder = house_file.parent / "models" / "green_cup"
    assert "y up (glTF's) turned to z up" in done.output and "units: metres (glTF's)" in done.output
    summary = _summary(folder)
    assert summary["gate"]["valid"], summary["gate"]["failed_checks"]
    # Upright (its height along z), standing on the floor, at the default 500 kg/m^3.
    np.testing.assert_allclose(summary["extents_m"], [2 * RADIUS_M, 2 * RADIUS_M, HEIGHT_M], atol=1e-6)
    assert summary["mass_kg"] == pytest.approx(mug.volume * 500.0, rel=0.01)
    assert "at 500 kg/m^3" in done.output
    urdf = (folder / "model.urdf").read_text()
    assert not re.search(r"nan|inf", urdf, re.IGNORECASE)
    node = load_map(house_file).node("green_cup")
    assert node.type == "cup" and node.properties["colour"] == "green" and node.parent == "table"
    assert (house_file.parent / node.model_ref).resolve() == (folder / "model.urdf").resolve()


def test_an_obj_in_millimetres_needs_its_units_and_takes_a_stated_density(mug, house_file: Path, tmp_path: Path) -> None:
    asset = tmp_path / "mug_mm.obj"
    in_mm = mug.copy()
    in_mm.apply_scale(1000.0)
    in_mm.export(asset)
    before = house_file.read_bytes()
    refused = _add(house_file, asset, "mug")
    assert refused.exit_code == 2
    assert refused.output.strip().splitlines() == [f"error: {asset}: 100 units across, which as metres is no household object: "
                                                   "give its units (--units mm, cm or in; manifest options: {units: mm})"]  # fmt: skip
    assert house_file.read_bytes() == before and not (house_file.parent / "models").exists()
    done = _add(house_file, asset, "mug", "--units", "mm", "--density-kg-m3", "2400")
    assert done.exit_code == 0, done.output
    summary = _summary(house_file.parent / "models" / "mug")
    assert summary["gate"]["valid"] and summary["mass_kg"] == pytest.approx(mug.volume * 2400.0, rel=0.01)
    np.testing.assert_allclose(summary["extents_m"], [2 * RADIUS_M, 2 * RADIUS_M, HEIGHT_M], atol=1e-6)
    assert "units: mm (given), scaled by 0.001 to metres" in done.output and "at 2400 kg/m^3" in done.output


@pytest.mark.parametrize(
    ("name", "content", "problem"),
    [
        ("truncated.glb", None, "cannot be read"),
        ("nan.obj", b"v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "non-finite"),
        ("indices.obj", b"v 0 0 0\nf 1 2 9\n", "line 2: face corner '2' names v 2, but 1 are defined"),
        ("noise.obj", bytes(range(256)) * 16, "no triangles"),
    ],
)
def test_a_corrupt_or_hostile_mesh_file_is_one_line_and_exit_2_with_nothing_written(
    mug, house_file: Path, tmp_path: Path, name: str, content: bytes | None, problem: str
) -> None:
    asset = tmp_path / name
    asset.write_bytes(content if content is not None else mug.export(file_type="glb")[:3000])
    before = house_file.read_bytes()
    done = _add(house_file, asset, "bad_cup")
    lines = done.output.strip().splitlines()
    assert done.exit_code == 2 and len(lines) == 1 and lines[0].startswith(f"error: {asset}: ") and problem in lines[0], done.output
    assert house_file.read_bytes() == before and not (house_file.parent / "models").exists()


def test_a_ros_urdf_is_imported_whole_with_its_gaps_repaired(house_file: Path, tmp_path: Path, monkeypatch) -> None:
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    workspace = write_ros_workspace(tmp_path / "ws", arm_inertial=False)
    urdf = workspace / "arm_description" / "urdf" / "arm.urdf"
    args = ["map", "add", str(house_file), str(urdf), "--id", "arm", "--parent", "kitchen", "--parking", "1 0 0", "--import"]
    done = CliRunner().invoke(app, [*args, "--package-path", str(workspace)])
    assert done.exit_code == 0, done.output
    folder = house_file.parent / "models" / "arm"
    assert "link 'arm_link': no <inertial>;" in done.output and "at 500 kg/m^3" in done.output
    assert _summary(folder)["gate"]["valid"]
    # Self-contained: its meshes were copied in; the map reads it with no package path.
    assert "package://" not in (folder / "model.urdf").read_text()
    node = load_map(house_file).node("arm")
    assert (house_file.parent / node.model_ref).resolve() == (folder / "model.urdf").resolve()
    again = CliRunner().invoke(app, [*args[:5], "arm_2", *args[6:], "--package-path", str(workspace), "--model-dir", str(folder)])
    assert again.exit_code == 2 and "exists (give another --model-dir, or --force to replace it)" in again.output
