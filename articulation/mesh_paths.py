"""Where a URDF's mesh reference points: always inside the model folder, never elsewhere.

The importer and the validation gate share this, so what one accepts the other does too.
"""

from __future__ import annotations

from pathlib import Path

from homemodel.core.errors import InputError
from homemodel.core.input_files import confined_path


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
        raise InputError("package:// path cannot be resolved inside the model folder")
    return confined_path(folder, filename, folder_role="model folder")
