"""What a process that builds database entries imports before its first entry.

Light on purpose (no Dask): the build's own process imports it before its first entry, and
Dask's `distributed` (half a second of CPU) must not be on that path. A worker that ran bpy
off its main thread ends as `blender_exit` says.
"""

from __future__ import annotations

import importlib

from homemodel.app.database.blender_exit import note_blender_thread

# What each source's entries import on their first build: the pipeline (open3d only for the
# reconstructions: 1.1 s of CPU, which spec and import entries need for nothing), then the
# gate and the entry's own build, which every entry uses.
WARM_MODULES = {
    "spec": ("bpy", "modeller"),
    "turntable": ("turntable", "open3d"),
    "photos": ("photogrammetry", "open3d"),
    "completion": ("shape_completion", "open3d"),
    "urdf": ("homemodel.model_folder.asset_import",),
}
SHARED_MODULES = ("homemodel.model_folder.gate.validate", "homemodel.app.database.entry_build")


def warm_up(sources: tuple[str, ...]) -> None:
    """Import what the entries of `sources` need, on the thread that will run them."""
    for name in (*(m for s in sources for m in WARM_MODULES[s]), *SHARED_MODULES):
        importlib.import_module(name)
    note_blender_thread()
