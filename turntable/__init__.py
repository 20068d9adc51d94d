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
"""

from turntable.reconstruct import reconstruct
from turntable.reconstruction import Reconstruction, ReconstructOptions

__all__ = ["Reconstruction", "ReconstructOptions", "reconstruct"]
