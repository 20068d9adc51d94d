"""A ROS description package validated as it is shipped: `package://` meshes in STL and DAE
(scaled by the DAE's <unit>, placed by its nodes) found in the package holding the URDF, then
in `--package-path` folders, then ROS_PACKAGE_PATH; never a traceback."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from homemodel.model_folder.gate import validate_path
from homemodel.core.errors import InputError
from homemodel.geometry.mesh_io import load_mesh
from ros_sample import write_ros_workspace

URDF = Path("arm_description/urdf/arm.urdf")


@pytest.fixture()
def workspace(tmp_path: Path, monkeypatch) -> Path:
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    return write_ros_workspace(tmp_path, arm_inertial=True)


def test_the_mesh_reader_reads_a_dae_in_metres_where_its_node_puts_it(workspace: Path) -> None:
    # 50 x 50 x 300 mm (<unit meter="0.001">), its node 150 mm up: z from 0 to 0.3 m.
    mesh = load_mesh(workspace / "arm_description" / "meshes" / "arm.dae")
    np.testing.assert_allclose(mesh.bounds, [[-0.025, -0.025, 0.0], [0.025, 0.025, 0.3]], atol=1e-9)
    dae = workspace / "shared_meshes" / "meshes" / "knob.dae"
    dae.write_text(dae.read_text().replace('meter="1.0"', 'meter="-2"'))
    with pytest.raises(InputError, match=r"knob\.dae: <unit meter='-2'> is not a positive length"):
        load_mesh(dae)


def test_a_ros_urdf_passes_the_gate_once_its_packages_are_found(workspace: Path, monkeypatch) -> None:
    urdf = workspace / URDF
    # The knob is in another package: not found without a package path, and said so.
    report = validate_path(urdf)
    failed = {c.name: c.detail for c in report.checks if not c.passed}
    assert set(failed) == {"meshes", "pybullet", "collisions", "physics"}, report.format()
    assert "package://shared_meshes/meshes/knob.dae" in failed["meshes"] and "give --package-path" in failed["meshes"]
    found = validate_path(urdf, package_paths=[workspace])
    assert found.ok, found.format()
    checks = {c.name: c.detail for c in found.checks}
    assert checks["meshes"].startswith("3 mesh files") and checks["pybullet"].startswith("loaded; 1 movable joint")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(workspace))  # a sourced ROS 1 workspace
    assert validate_path(urdf).ok


def test_validate_takes_package_paths_on_the_command_line(workspace: Path) -> None:
    """In this process (tests/test_input_bounds.py runs `validate` as a child process)."""
    from typer.testing import CliRunner

    from homemodel.cli import app

    done = CliRunner().invoke(app, ["validate", str(workspace / URDF), "--package-path", str(workspace)])
    assert done.exit_code == 0 and "OK: all 13 checks passed" in done.output, done.output


def test_map_add_registers_a_ros_urdf_whose_meshes_are_in_other_packages(workspace: Path, house_file: Path) -> None:
    from typer.testing import CliRunner

    from homemodel.cli import app
    from homemodel.exchange.map_xml import load_map

    add = ["map", "add", str(house_file), str(workspace / URDF), "--id", "arm", "--parent", "kitchen", "--parking", "1 0 0"]
    refused = CliRunner().invoke(app, add)
    assert refused.exit_code == 2 and "package://shared_meshes/meshes/knob.dae" in refused.output
    done = CliRunner().invoke(app, [*add, "--package-path", str(workspace)])
    assert done.exit_code == 0, done.output
    arm = load_map(house_file).node("arm")
    assert (house_file.parent / arm.model_ref).resolve() == (workspace / URDF).resolve()
