"""AprilTag turntable capture to a metric, coloured mesh (D3.1 section 3.3.3).

The entry: `reconstruct(capture_dir, out_dir, ReconstructOptions(...), progress=..., force=...)`
writes the model folder (and registers it into a map when the options name one).

- `board`, `board_pdf`: the tag grid, board.yaml, the printable PDF;
- `simulate`, `blender_render`: synthetic captures (Cycles colour, ray-cast depth, sensor noise);
- `capture`: the capture folder and its files (poses.json is `homemodel.exchange.poses`);
- `tags`, `pose`, `orbit`, `turntable_model`: detection, PnP, the axis, the joint pose refinement;
- `fusion`, `meshing`, `texture`: merging, Poisson, the baked texture;
- `reconstruct`, `outputs`, `picture`: the pipeline and its model folder (the one-link model
  of `articulation.scan_model`).

No module here imports bpy: `blender_render` builds its Cycles scene with
`homemodel.geometry.cycles_scene` (called by `simulate_capture`); reconstruction runs without Blender.
See docs/turntable.md.

The three names below are imported when first asked for, so a command that needs only the
board (`homemodel turntable board`) does not pay for the pipeline's trimesh and scipy.
The entry function shares its name with its module `turntable.reconstruct`; Python sets a
package's attribute to a submodule whenever that submodule is first imported, so the package's
class keeps `turntable.reconstruct` the function, as it was when this file imported it eagerly.
The command line and the database import `from turntable.reconstruct import reconstruct`, the
same function either way.
"""

from __future__ import annotations

import sys
import types
from typing import Any

__all__ = ["Reconstruction", "ReconstructOptions", "reconstruct"]


class _Package(types.ModuleType):
    def __setattr__(self, name: str, value: Any) -> None:
        if name == "reconstruct" and isinstance(value, types.ModuleType):
            return  # the import system binding the submodule: the entry function keeps the name
        super().__setattr__(name, value)

    def __getattr__(self, name: str) -> Any:
        if name == "reconstruct":
            from turntable.reconstruct import reconstruct as value
        elif name in ("Reconstruction", "ReconstructOptions"):
            from turntable import reconstruction

            value = getattr(reconstruction, name)
        else:
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
        super().__setattr__(name, value)
        return value


sys.modules[__name__].__class__ = _Package
