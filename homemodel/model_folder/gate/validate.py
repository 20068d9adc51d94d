"""The validation gate: a model folder, URDF or GLB through our rules and the real clients.

Order matters once: the URDF is parsed safely first, and an unsafe or unparseable file
stops the gate there, so hostile XML never reaches check_urdf, yourdfpy or pybullet.
Every later check runs whatever the others found, so one report lists every fault.
"""

from __future__ import annotations

import tempfile
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from homemodel.core.errors import HomemodelError, InputError
from homemodel.exchange import urdf as urdf_doc
from homemodel.exchange.urdf import Element
from homemodel.exchange.urdf.mesh_paths import with_package_uris_resolved
from homemodel.exchange.urdf.read import find_urdf
from homemodel.geometry.mesh_io import meshes_read_once
from homemodel.model_folder.gate.clients import check_urdf_beside, pybullet_check, yourdfpy_check
from homemodel.model_folder.gate.collisions import collisions_check
from homemodel.model_folder.gate.finite_numbers import finite_numbers_check
from homemodel.model_folder.gate.gltf import gltf_checks
from homemodel.model_folder.gate.mesh_geometry import mesh_geometry_check, over_triangle_bound
from homemodel.model_folder.gate.physics import physics_check
from homemodel.model_folder.gate.real_meshes import RealMeshes
from homemodel.model_folder.gate.report import Check, ValidationReport
from homemodel.model_folder.gate.urdf_rules import (
    axes_check,
    inertials_check,
    limits_check,
    meshes_check,
    tree_check,
    unsafe_mesh_references,
)

__all__ = ["Check", "ValidationReport", "validate_path"]

GLB_NAME = "model.glb"


def _inputs(path: Path) -> tuple[Path | None, Path | None]:
    """The URDF and GLB to check for `path`."""
    if not path.exists():
        raise InputError(f"{path}: no such file or folder")
    if path.is_dir():
        glb = path / GLB_NAME
        return find_urdf(path), glb if glb.exists() else None
    if not path.is_file():
        raise InputError(f"{path}: not a regular file")
    suffix = path.suffix.lower()
    if suffix == ".urdf":
        return path, None
    if suffix == ".glb":
        return None, path
    raise InputError(f"{path}: expected a model folder, a .urdf or a .glb file")


# pybullet's client state buffers hold 128 coordinates (MAX_DEGREE_OF_FREEDOM), 7 of them
# the base's: with more joints it fails to report link states, or reports wrong poses
# (measured on generated chains: right up to 122 joints, wrong from 124).
PYBULLET_MAX_JOINTS = 121


def _pybullet_refusal(
    tree: Check, robot: Element, folder: Path, package_paths: Sequence[Path], meshes: Check, geometry: Check, finite: Check
) -> str | None:
    """Why pybullet must not load this URDF in our process, or None."""
    if not finite.passed:
        return "a simulation with NaN or infinite numbers means nothing (see finite numbers)"
    if over_triangle_bound(meshes):
        return "its meshes are over the triangle bound (see meshes)"
    if not geometry.passed:
        return "a simulation of broken meshes means nothing (see mesh geometry)"
    if not tree.passed:
        # pybullet 3.2.7 segfaults on several root links, a cycle or duplicate joint names.
        return "pybullet crashes the process on a broken kinematic tree (see kinematic tree)"
    joints = len(urdf_doc.joints(robot))
    if joints > PYBULLET_MAX_JOINTS:
        return f"pybullet reports the poses of at most {PYBULLET_MAX_JOINTS} joints, and the URDF has {joints}"
    unsafe = unsafe_mesh_references(robot, folder, package_paths)
    if unsafe:
        return f"pybullet would open {unsafe[:3]}, outside the model folder or not regular files (see meshes)"
    return None


def _urdf_checks(urdf: Path, robot: Element, package_paths: Sequence[Path]) -> list[Check]:
    """The checks of a URDF whose XML was safe to parse (`robot`)."""
    checks = [Check("safe XML", True, f"no DOCTYPE or entities; <robot name={robot.get('name')!r}>")]
    with check_urdf_beside(urdf) as check_urdf:
        tree = tree_check(robot)
        meshes = meshes_check(robot, urdf.parent, package_paths)
        finite = finite_numbers_check(robot)
        checks += [tree, finite, limits_check(robot), axes_check(robot), inertials_check(robot), meshes]
        geometry = mesh_geometry_check(robot, urdf.parent, package_paths)
        checks += [geometry, check_urdf()]
    if over_triangle_bound(meshes):  # the clients would read every triangle into memory
        declared_check, declared = Check("yourdfpy", False, "not run: meshes over the triangle bound"), None
    else:
        declared_check, declared = yourdfpy_check(urdf)
    checks.append(declared_check)
    refusal = _pybullet_refusal(tree, robot, urdf.parent, package_paths, meshes, geometry, finite)
    with tempfile.TemporaryDirectory(prefix="homemodel-gate-") as tmp:
        # pybullet gets a copy naming package:// meshes by absolute paths; our own reading of
        # the collision meshes follows the URIs of the URDF itself.
        loadable = with_package_uris_resolved(urdf, Path(tmp), package_paths)
        checks.append(Check("pybullet", False, f"not run: {refusal}") if refusal else pybullet_check(loadable, declared))
        checks.append(Check("collisions", False, f"not run: {refusal}") if refusal else collisions_check(loadable, meshes=RealMeshes(urdf, package_paths)))
        checks.append(Check("physics", False, f"not run: {refusal}") if refusal else physics_check(loadable))
    return checks


def validate_path(path: Path, *, package_paths: Sequence[Path] = ()) -> ValidationReport:
    """Validate a model folder (model.urdf, optional model.glb), a .urdf or a .glb file;
    `package://NAME/...` meshes are found in the package holding the URDF, `package_paths`,
    then ROS_PACKAGE_PATH and AMENT_PREFIX_PATH (see `homemodel.exchange.urdf.mesh_paths`).

    Raises InputError when `path` is missing or of an unknown kind; every fault of the
    model itself is a failed check in the report.
    """
    path = Path(path)
    urdf, glb = _inputs(path)
    report = ValidationReport(path=path)
    robot = None
    if urdf is not None:
        try:
            robot = urdf_doc.read_urdf_robot(urdf)
        except HomemodelError as exc:
            report.checks.append(Check("safe XML", False, str(exc)))
            return report
    with ThreadPoolExecutor(max_workers=1) as beside:
        # The glTF checks mostly wait for node's reply: asked first, node validates the GLB while
        # this thread runs the URDF's checks (listed first, as before). On a completed cup's folder
        # the gate then waits 0.5 ms for them instead of spending 27-33 ms on them (medians, load 8).
        gltf = beside.submit(gltf_checks, glb) if glb is not None else None
        if robot is not None:
            with meshes_read_once():
                report.checks += _urdf_checks(urdf, robot, package_paths)
        if gltf is not None:
            report.checks += gltf.result()
    return report
