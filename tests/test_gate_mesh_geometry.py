"""The gate refuses broken geometry that every client loads: NaN or infinite vertices, no
triangles, triangles of zero area, a collision mesh with no volume; `map add` refuses it too."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest
from sample_house import box_model
from typer.testing import CliRunner

from homemodel.cli import app
from homemodel.core.safe_xml import parse_xml_file
from homemodel.exchange.model_files import export_model
from homemodel.model_folder.gate.mesh_geometry import mesh_geometry_check
from homemodel.model_folder.gate.urdf_rules import meshes_check

runner = CliRunner()
BOX_OBJ = "meshes/body_body.obj"


@pytest.fixture(scope="module")
def box_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An exported one-link box whose URDF names its OBJ as the visual and as the collision mesh."""
    folder = export_model(box_model("box", (0.4, 0.3, 0.9)), tmp_path_factory.mktemp("box") / "box")
    urdf = folder / "model.urdf"
    text = urdf.read_text()
    assert BOX_OBJ in text and text.count("</link>") == 1
    collision = f'<collision><geometry><mesh filename="{BOX_OBJ}"/></geometry></collision>'
    urdf.write_text(text.replace("</link>", f"{collision}</link>"))
    return folder


def _edited(box_folder: Path, tmp_path: Path, edit) -> Path:
    folder = tmp_path / "model"
    shutil.copytree(box_folder, folder)
    obj = folder / BOX_OBJ
    lines = obj.read_text().splitlines()
    vertices = [i for i, line in enumerate(lines) if line.startswith("v ")]
    obj.write_text("\n".join(edit(lines, vertices)) + "\n")
    return folder


def _checks(folder: Path):
    """The meshes check (present, readable, within bounds) and the mesh geometry check."""
    robot = parse_xml_file(folder / "model.urdf").getroot()
    return meshes_check(robot, folder), mesh_geometry_check(robot, folder)


def _all_nan(lines, vertices):
    return ["v nan nan nan" if i in vertices else line for i, line in enumerate(lines)]


def _one_nan(lines, vertices):
    return [line.replace(line, "v 0.1 nan 0.2") if i == vertices[3] else line for i, line in enumerate(lines)]


def _one_inf(lines, vertices):
    return [line.replace(line, "v inf 0 0") if i == vertices[0] else line for i, line in enumerate(lines)]


def _no_faces(lines, vertices):
    return [line for line in lines if not line.startswith("f ")]


def _zero_area_triangle(lines, vertices):
    return [*lines, "f 1 1 2"]


def _flat(lines, vertices):
    return [" ".join([*line.split()[:3], "0"]) if i in vertices else line for i, line in enumerate(lines)]


def _one_point(lines, vertices):
    return ["v 0.1 0.1 0.1" if i in vertices else line for i, line in enumerate(lines)]


@pytest.mark.parametrize(
    "edit, failing, problem",
    [
        (_all_nan, 1, "non-finite (NaN or infinite) vertex coordinates"),
        (_one_nan, 1, "non-finite (NaN or infinite) vertex coordinates"),
        (_one_inf, 1, "non-finite (NaN or infinite) vertex coordinates"),
        (_no_faces, 0, "holds no triangles"),
        (_zero_area_triangle, 1, "1 of 13 triangles have zero area"),
        (_flat, 1, "collision mesh with zero volume"),
        (_one_point, 1, "all its vertices are one point"),
    ],
)
def test_broken_geometry_fails_the_gate(box_folder: Path, tmp_path: Path, edit, failing: int, problem: str) -> None:
    """Each fault fails exactly one of the two mesh checks: `meshes` (0) or `mesh geometry` (1)."""
    assert all(check.passed for check in _checks(box_folder)), _checks(box_folder)
    checks = _checks(_edited(box_folder, tmp_path, edit))
    assert [check.passed for check in checks] == [i != failing for i in range(2)], checks
    detail = checks[failing].detail
    assert "link 'body': " in detail and BOX_OBJ in detail and problem in detail, detail


def test_validate_and_map_add_refuse_a_nan_model(box_folder: Path, tmp_path: Path, house_file: Path) -> None:
    folder = _edited(box_folder, tmp_path, _all_nan)
    result = runner.invoke(app, ["validate", str(folder)])
    assert result.exit_code == 1, result.output
    assert re.search(r"FAIL  mesh geometry +link 'body': visual mesh 'meshes/body_body.obj': the mesh has non-finite",
                     result.output), result.output
    before = house_file.read_bytes()
    result = runner.invoke(app, ["map", "add", str(house_file), str(folder), "--id", "nan_box", "--parent", "kitchen"])
    assert result.exit_code == 2
    assert result.output.count("\n") == 1 and "body_body.obj has non-finite" in result.output, result.output
    assert house_file.read_bytes() == before


def test_meshes_over_the_triangle_bound_are_never_given_to_the_clients(box_folder: Path, monkeypatch) -> None:
    monkeypatch.setenv("HOMEMODEL_MAX_TRIANGLES", "10")  # the box has 12
    result = runner.invoke(app, ["validate", str(box_folder)])
    assert result.exit_code == 1
    assert "12 triangles is over the limit of 10 (set HOMEMODEL_MAX_TRIANGLES to raise it)" in result.output
    for client in ("yourdfpy", "pybullet", "collisions"):
        assert re.search(rf"FAIL  {client} +not run: .*triangle bound", result.output), result.output
