"""What trimesh leaves out of a COLLADA (.dae) file: its `<unit meter>`.

ROS tools scale a DAE mesh by its unit (RViz and Gazebo both do) but ignore its `<up_axis>`
(RViz drops the root transform assimp adds for it, and MoveIt's geometric_shapes copies that),
so a URDF's DAE meshes are read the same way: scaled to metres, axes as written. Both mesh
readers (`homemodel.geometry.mesh_io` and the asset importer's) go through this.
"""

from __future__ import annotations

import math
from pathlib import Path

from homemodel.core.errors import InputError
from homemodel.core.safe_xml import parse_xml_bytes


def collada_unit_m(data: bytes, path: Path) -> float:
    """Metres per unit of the DAE file `data` (1 when it does not say). Parsing it with the
    safe parser first also refuses a DOCTYPE or entities before pycollada sees the file."""
    root = parse_xml_bytes(data, str(path)).getroot()
    element = root.find("{*}asset/{*}unit")
    if element is None:
        return 1.0
    text = element.get("meter", "1")
    try:
        unit = float(text)
    except ValueError:
        raise InputError(f"{path}: <unit meter={text!r}> is not a number") from None
    if not (math.isfinite(unit) and unit > 0):
        raise InputError(f"{path}: <unit meter={text!r}> is not a positive length")
    return unit
