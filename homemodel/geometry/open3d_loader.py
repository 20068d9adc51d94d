"""Open3D, imported without its notebook viewer.

`open3d.visualization` imports `draw_plotly`, which imports dash, flask and plotly: about half
of Open3D's import (0.4 of 0.85 CPU-s), paid by every process that casts a ray or makes a
mesh, for a viewer homemodel never opens. `load_open3d` puts a stand-in in its place whose
functions import the real module when first called, so nothing is lost.
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import Any

_VIEWER = "open3d.visualization.draw_plotly"
_VIEWER_FUNCTIONS = ("get_plotly_fig", "draw_plotly", "draw_plotly_server")


def load_open3d() -> types.ModuleType:
    """The `open3d` module (import it through here, not with `import open3d`)."""
    if "open3d" not in sys.modules:
        sys.modules.setdefault(_VIEWER, _deferred_viewer())
    import open3d

    return open3d


def _deferred_viewer() -> types.ModuleType:
    viewer = types.ModuleType(_VIEWER, "Stand-in: the real module is imported when one of its functions is called.")
    for name in _VIEWER_FUNCTIONS:
        setattr(viewer, name, _importing_on_call(name))
    return viewer


def _importing_on_call(name: str):  # noqa: ANN202
    def call(*args: Any, **kwargs: Any) -> Any:
        if not hasattr(sys.modules.get(_VIEWER), "__file__"):  # still the stand-in
            sys.modules.pop(_VIEWER, None)
        return getattr(importlib.import_module(_VIEWER), name)(*args, **kwargs)

    call.__name__ = name
    return call
