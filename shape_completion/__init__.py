"""A full mesh of a new object from one depth image (Rock et al. 2015, D3.1 section 3.3.3).

The entry: `complete(model_file_or_completer, depth_png, out_dir, CompletionOptions(camera_path=...),
progress=..., force=...)` writes the model folder of the completed object, upright (+z up, origin
on the support under it) when the camera's pose or a support plane in the depth image gives up
(`upright`, `support`), else in the camera's frame.
Matching (`features`, `shape_codes`, `matching`), Fitting (`spin_images`, `registration`,
`symmetry`, `deformation`) and Filling (`filling`) are tied together by
`pipeline.ShapeCompleter`; `query_input` reads and checks a query, `queries` makes synthetic
ones; `library` and `procedural` provide the class library, `model_io` saves models,
`model_export` holds the entry, `benchmark` runs D3.1 Table 1's protocol. See
docs/shape_completion.md.
"""

from shape_completion.model_export import CompletionOptions, complete
from shape_completion.pipeline import Completion, ShapeCompleter

__all__ = ["Completion", "CompletionOptions", "ShapeCompleter", "complete"]
