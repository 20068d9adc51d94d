"""Where a URDF's mesh reference points: always inside the model folder (or, for a
`package://NAME/...` URI, inside the ROS package NAME: the one that holds the URDF, or one
found in the given package paths, then in those of ROS_PACKAGE_PATH and AMENT_PREFIX_PATH,
as ROS finds it), never elsewhere.

The importer and the validation gate share this, so what one accepts the other does too.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from homemodel.core.errors import HomemodelError, InputError
from homemodel.core.input_files import confined_path
from homemodel.core.safe_xml import parse_xml_file
from homemodel.exchange import urdf as urdf_doc


def _enclosing_package(urdf_dir: Path) -> tuple[str, Path] | None:
    """(name, folder) of the ROS package holding `urdf_dir`: the nearest `package.xml` above."""
    for folder in (urdf_dir, *urdf_dir.parents):
        manifest = folder / "package.xml"
        if manifest.is_file():
            try:
                name = parse_xml_file(manifest).getroot().findtext("name")
            except HomemodelError:
                return None
            return ((name or "").strip(), folder)
    return None


def _package_name(folder: Path) -> str | None:
    try:
        return (parse_xml_file(folder / "package.xml").getroot().findtext("name") or "").strip()
    except HomemodelError:
        return None


# A package path is searched this deep for package.xml files (ROS_PACKAGE_PATH's crawl, bounded).
MAX_PACKAGE_DEPTH = 4


def find_package(name: str, package_paths: Sequence[Path]) -> Path | None:
    """The folder of ROS package `name` in `package_paths` (each a package, a folder of
    packages, or an install prefix with `share/NAME`): the first whose package.xml names it."""
    for root in package_paths:
        root = Path(root).resolve()
        for candidate in (root, root / name, root / "share" / name):
            if (candidate / "package.xml").is_file() and _package_name(candidate) == name:
                return candidate
        for depth in range(1, MAX_PACKAGE_DEPTH + 1):
            for manifest in sorted(root.glob("/".join(["*"] * depth) + "/package.xml")):
                if _package_name(manifest.parent) == name:
                    return manifest.parent.resolve()
    return None


def environment_package_paths() -> list[Path]:
    """The package paths a sourced ROS workspace sets: ROS_PACKAGE_PATH's folders (ROS 1)
    and AMENT_PREFIX_PATH's install prefixes (ROS 2, packages in share/NAME)."""
    paths = []
    for variable in ("ROS_PACKAGE_PATH", "AMENT_PREFIX_PATH"):
        paths += [Path(p) for p in os.environ.get(variable, "").split(os.pathsep) if p]
    return paths


def _package_file(rest: str, urdf_dir: Path, package_paths: Sequence[Path]) -> Path | None:
    """The file `package://rest` names inside package NAME: the one holding the URDF if it
    is NAME, else NAME found in `package_paths`; never outside that package's folder."""
    name, _, inside = rest.partition("/")
    if not inside:
        return None
    package = _enclosing_package(urdf_dir)
    if package is not None and package[0] == name:
        folder = package[1]
    else:
        folder = find_package(name, [*package_paths, *environment_package_paths()])
    if folder is None:
        return None
    target = (folder / inside).resolve()
    return target if target.is_relative_to(folder.resolve()) and target.is_file() else None


def resolve_mesh(filename: str, urdf_dir: Path, package_paths: Sequence[Path] = ()) -> Path:
    """The file `filename` names inside the URDF's folder (it may not exist), or for a
    `package://` URI inside its package (the one holding the URDF, or in `package_paths`).

    Raises InputError for absolute paths, URIs and paths escaping the folder after `..`
    and symlinks are resolved.
    """
    folder = urdf_dir.resolve()
    if filename.startswith("package://"):
        rest = filename.removeprefix("package://")
        # As pybullet does: try the remainder, then without its first part (the package name).
        for candidate in (rest, rest.partition("/")[2]):
            target = (folder / candidate).resolve() if candidate else None
            if target is not None and target.is_relative_to(folder) and target.is_file():
                return target
        target = _package_file(rest, folder, package_paths)
        if target is not None:
            return target
        searched = f" or the package paths {[str(p) for p in package_paths]}" if package_paths else " (give --package-path)"
        raise InputError(f"package:// path cannot be resolved inside the model folder, the package holding it{searched}")
    return confined_path(folder, filename, folder_role="model folder")


def with_package_uris_resolved(urdf: Path, out_dir: Path, package_paths: Sequence[Path] = ()) -> Path:
    """`urdf`, or, when it names meshes by `package://` URIs, a copy in `out_dir` with each
    such URI replaced by the absolute path it resolves to: pybullet looks for
    `package://NAME/meshes/x.obj` only as `NAME/meshes/x.obj` beside the URDF, not in the
    ROS package that holds it. URIs that do not resolve are left for the clients to refuse."""
    tree = parse_xml_file(urdf)
    changed = False
    for _, _, mesh in urdf_doc.mesh_elements(tree.getroot()):
        filename = mesh.get("filename") or ""
        if not filename.startswith("package://"):
            continue
        try:
            mesh.set("filename", str(resolve_mesh(filename, urdf.parent, package_paths)))
            changed = True
        except InputError:
            continue
    if not changed:
        return urdf
    copy = Path(out_dir) / urdf.name
    tree.write(str(copy), xml_declaration=True, encoding="utf-8")
    return copy
