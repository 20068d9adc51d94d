"""Where a URDF's mesh reference points: always inside the model folder (or, for a
`package://NAME/...` URI, inside the ROS package NAME that holds the URDF), never elsewhere.

The importer and the validation gate share this, so what one accepts the other does too.
"""

from __future__ import annotations

from pathlib import Path

from homemodel.core.errors import HomemodelError, InputError
from homemodel.core.input_files import confined_path
from homemodel.core.safe_xml import parse_xml_file


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


def _package_file(rest: str, urdf_dir: Path) -> Path | None:
    """The file `package://rest` names inside the package that holds the URDF, if it is one."""
    package = _enclosing_package(urdf_dir)
    name, _, inside = rest.partition("/")
    if package is None or package[0] != name or not inside:
        return None
    target = (package[1] / inside).resolve()
    return target if target.is_relative_to(package[1]) and target.is_file() else None


def resolve_mesh(filename: str, urdf_dir: Path) -> Path:
    """The file `filename` names inside the URDF's folder (it may not exist).

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
        target = _package_file(rest, folder)
        if target is not None:
            return target
        raise InputError("package:// path cannot be resolved inside the model folder or the package holding it")
    return confined_path(folder, filename, folder_role="model folder")


def with_package_uris_resolved(urdf: Path, out_dir: Path) -> Path:
    """`urdf`, or, when it names meshes by `package://` URIs, a copy in `out_dir` with each
    such URI replaced by the absolute path it resolves to: pybullet looks for
    `package://NAME/meshes/x.obj` only as `NAME/meshes/x.obj` beside the URDF, not in the
    ROS package that holds it. URIs that do not resolve are left for the clients to refuse."""
    tree = parse_xml_file(urdf)
    changed = False
    for mesh in tree.getroot().iter("mesh"):
        filename = mesh.get("filename") or ""
        if not filename.startswith("package://"):
            continue
        try:
            mesh.set("filename", str(resolve_mesh(filename, urdf.parent)))
            changed = True
        except InputError:
            continue
    if not changed:
        return urdf
    copy = Path(out_dir) / urdf.name
    tree.write(str(copy), xml_declaration=True, encoding="utf-8")
    return copy
