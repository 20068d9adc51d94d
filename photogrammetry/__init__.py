"""Photos to a textured, metric, cleaned mesh through COLMAP on the CPU (D3.1 section 3.3.3).

The entry: `reconstruct(photos_dir, out_dir, ReconstructOptions(...), progress=..., force=...)`
writes the model folder (and registers it into a map when the options name one).
`photogrammetry.pipeline` runs the stages: `sfm` (pycolmap), `stereo` (CPU semi-global
matching; `patch_match` where pycolmap has CUDA), `support_plane`, `markers` and
`metric_frame` (scale and levelling), `visibility` and `cleaning` (the manual clean-up of
Figure 17), `texturing` (a chart atlas and projection). `synthetic_scene` renders a photo set with
ground truth in Blender for the tests and the benchmark; `picture` draws the cameras.
"""

from photogrammetry.pipeline import Reconstruction, ReconstructOptions, reconstruct

__all__ = ["ReconstructOptions", "Reconstruction", "reconstruct"]
