"""URDF rules that pybullet, check_urdf and yourdfpy all let through.

All three accept a negative mass, a zero axis, lower > upper and an inertia that breaks the
triangle inequality, and none checks that meshes stay inside the model folder. The rules
read only `<link>` and `<joint>` elements directly under `<robot>`, so extension elements
(`<homemodel>`, `<gazebo>`, `<transmission>`) are ignored as the tools ignore them.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from articulation.joint_types import LIMITED_JOINT_TYPES, URDF_JOINT_TYPES
from homemodel.core.errors import InputError
from homemodel.exchange import urdf as urdf_doc
from homemodel.exchange.urdf import Element
from homemodel.exchange.urdf.mesh_paths import resolve_mesh
from homemodel.model_folder.gate.mesh_files import load_gate_mesh
from homemodel.model_folder.gate.report import Check, check_from_problems, count

AXIS_UNIT_TOLERANCE = 1e-6
# Relative to the sum of the principal moments. A thin plate sits exactly on the bound, and
# written to six significant digits (as our exporter does) can pass it by 5e-6 of the sum.
TRIANGLE_RELATIVE_TOLERANCE = 1e-5
INERTIA_KEYS = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")


def _floats(text: str | None, n: int) -> list[float] | None:
    """`n` finite numbers separated by spaces, or None."""
    if text is None:
        return None
    try:
        values = [float(v) for v in text.split()]
    except ValueError:
        return None
    if len(values) != n or not all(math.isfinite(v) for v in values):
        return None
    return values


def _float(text: str | None) -> float | None:
    values = _floats(text, 1)
    return None if values is None else values[0]


def _link_of(joint: Element, tag: str) -> str | None:
    el = joint.find(tag)
    return None if el is None else el.get("link")


def tree_check(robot: Element) -> Check:
    """Unique names, known joint types, joints between existing links, one root, no cycle."""
    links, joints = urdf_doc.links(robot), urdf_doc.joints(robot)
    problems: list[str] = []
    if not links:
        problems.append("the URDF has no <link>")
    link_names = [link.get("name") for link in links]
    joint_names = [joint.get("name") for joint in joints]
    for kind, names in (("link", link_names), ("joint", joint_names)):
        if None in names:
            problems.append(f"a <{kind}> has no name")
        dupes = sorted({n for n in names if n is not None and names.count(n) > 1})
        if dupes:
            problems.append(f"duplicate {kind} names {dupes}")
    known = {n for n in link_names if n is not None}
    parent_of: dict[str, str] = {}
    children_of: dict[str, list[str]] = {}
    for joint, name in zip(joints, joint_names):
        if joint.get("type") not in URDF_JOINT_TYPES:
            problems.append(f"joint {name!r}: unknown type {joint.get('type')!r}")
        parent, child = _link_of(joint, "parent"), _link_of(joint, "child")
        for role, link in (("parent", parent), ("child", child)):
            if link is None:
                problems.append(f"joint {name!r}: no <{role} link=...>")
            elif link not in known:
                problems.append(f"joint {name!r}: {role} link {link!r} does not exist")
        if parent is None or child is None:
            continue
        if child in parent_of:
            problems.append(f"link {child!r} is the child of more than one joint")
        parent_of[child] = parent
        children_of.setdefault(parent, []).append(child)
    roots = sorted(known - set(parent_of))
    if known and len(roots) != 1:
        problems.append(f"expected exactly one root link, found {roots or 'none (the joints form a cycle)'}")
    else:
        reached, stack = set(roots), list(roots)
        while stack:
            for child in children_of.get(stack.pop(), []):
                if child not in reached:
                    reached.add(child)
                    stack.append(child)
        if known - reached:
            problems.append(f"links {sorted(known - reached)} are not connected to the root (a cycle)")
    root = roots[0] if len(roots) == 1 else None
    return check_from_problems(
        "kinematic tree", problems, f"{count(len(links), 'link')}, {count(len(joints), 'joint')}, root {root!r}"
    )


def limits_check(robot: Element) -> Check:
    problems: list[str] = []
    limited = [j for j in urdf_doc.joints(robot) if j.get("type") in LIMITED_JOINT_TYPES]
    for joint in limited:
        name = joint.get("name")
        limit = joint.find("limit")
        if limit is None:
            problems.append(f"joint {name!r} ({joint.get('type')}): no <limit>")
            continue
        # URDF's default for a missing lower or upper is 0.
        lower, upper = _float(limit.get("lower", "0")), _float(limit.get("upper", "0"))
        if lower is None or upper is None:
            problems.append(f"joint {name!r}: limit lower/upper is not a finite number")
        elif not lower < upper:
            problems.append(f"joint {name!r}: limit lower {lower:g} is not below upper {upper:g}")
    detail = f"lower < upper on {count(len(limited), 'revolute/prismatic joint')}" if limited else "no limited joints"
    return check_from_problems("joint limits", problems, detail)


def axes_check(robot: Element) -> Check:
    problems: list[str] = []
    moving = [j for j in urdf_doc.joints(robot) if j.get("type") != "fixed"]
    for joint in moving:
        axis_el = joint.find("axis")
        if axis_el is None or axis_el.get("xyz") is None:
            continue  # URDF's default axis 1 0 0
        text = axis_el.get("xyz")
        axis = _floats(text, 3)
        if axis is None:
            problems.append(f"joint {joint.get('name')!r}: axis {text!r} is not three finite numbers")
            continue
        norm = float(np.linalg.norm(axis))
        if norm == 0:
            problems.append(f"joint {joint.get('name')!r}: axis {text!r} is zero")
        elif abs(norm - 1) >= AXIS_UNIT_TOLERANCE:
            problems.append(f"joint {joint.get('name')!r}: axis {text!r} has length {norm:.6g}, not 1")
    detail = f"unit axes on {count(len(moving), 'non-fixed joint')}" if moving else "no non-fixed joints"
    return check_from_problems("joint axes", problems, detail)


def inertial_problems(name: str | None, inertial: Element) -> list[str]:
    where = f"link {name!r}"
    problems: list[str] = []
    mass_el = inertial.find("mass")
    mass = None if mass_el is None else _float(mass_el.get("value"))
    if mass is None:
        problems.append(f"{where}: no finite <mass value=...>")
    elif mass <= 0:
        problems.append(f"{where}: mass {mass:g} kg is not positive")
    inertia_el = inertial.find("inertia")
    values = [None if inertia_el is None else _float(inertia_el.get(k)) for k in INERTIA_KEYS]
    if None in values:
        problems.append(f"{where}: <inertia> needs finite {', '.join(INERTIA_KEYS)}")
        return problems
    ixx, ixy, ixz, iyy, iyz, izz = values
    # Built from six values, the matrix is symmetric by construction.
    moments = np.linalg.eigvalsh(np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]))
    shown = ", ".join(f"{m:.4g}" for m in moments)
    if moments[0] <= 0:
        problems.append(f"{where}: inertia is not positive definite (principal moments {shown})")
    elif moments[2] > moments[0] + moments[1] + TRIANGLE_RELATIVE_TOLERANCE * moments.sum():
        problems.append(f"{where}: principal moments {shown} break the triangle inequality")
    return problems


def inertials_check(robot: Element) -> Check:
    problems: list[str] = []
    with_inertial = 0
    for link in urdf_doc.links(robot):
        inertial = link.find("inertial")
        if inertial is not None:
            with_inertial += 1
            problems += inertial_problems(link.get("name"), inertial)
        elif link.find("visual") is not None or link.find("collision") is not None:
            # A massless frame link is fine; a body someone can see or touch needs mass.
            problems.append(f"link {link.get('name')!r} has geometry but no <inertial>")
    detail = f"positive mass and valid inertia on {count(with_inertial, 'link')}"
    return check_from_problems("inertials", problems, detail)


def mesh_references(robot: Element) -> Iterator[tuple[str | None, str | None]]:
    """(link name, mesh filename) of every visual and collision mesh."""
    for link, _, mesh in urdf_doc.mesh_elements(robot):
        yield link.get("name"), mesh.get("filename")


def _mesh_problem(path: Path) -> str | None:
    """Why `path` cannot be read as a mesh (bounded in bytes and triangles), or None; what it
    holds is the mesh geometry check's."""
    try:
        load_gate_mesh(path, require_finite=False)
    except InputError as exc:
        return str(exc).removeprefix(f"{path}: ")
    return None


def meshes_check(robot: Element, urdf_dir: Path, package_paths: Sequence[Path] = ()) -> Check:
    problems: list[str] = []
    read: dict[Path, str | None] = {}
    for link, filename in mesh_references(robot):
        where = f"link {link!r}: mesh {filename!r}"
        if not filename:
            problems.append(f"link {link!r}: <mesh> without a filename")
            continue
        try:
            path = resolve_mesh(filename, urdf_dir, package_paths)
        except InputError as exc:
            problems.append(f"{where}: {exc}")
            continue
        if not path.exists():
            problems.append(f"{where}: no such file")
        elif not path.is_file():
            problems.append(f"{where}: not a regular file")
        else:
            if path not in read:
                read[path] = _mesh_problem(path)
            if read[path] is not None:
                problems.append(f"{where}: {read[path]}")
    detail = f"{count(len(read), 'mesh file')} inside the model folder read" if read else "no mesh files"
    return check_from_problems("meshes", problems, detail)


def unsafe_mesh_references(robot: Element, urdf_dir: Path, package_paths: Sequence[Path] = ()) -> list[str]:
    """Mesh references a client must not open: outside the folder, or not a regular file
    (a FIFO or device would block or never end)."""
    unsafe = []
    for _, filename in mesh_references(robot):
        if not filename:
            continue
        try:
            path = resolve_mesh(filename, urdf_dir, package_paths)
        except InputError:
            unsafe.append(filename)
            continue
        if path.exists() and not path.is_file():
            unsafe.append(filename)
    return unsafe
