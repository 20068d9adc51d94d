"""What a process that builds database entries imports before its first entry, and how a
worker process that ran bpy off its main thread ends.

Light on purpose (no Dask): the build's own process imports it before its first entry, and
Dask's `distributed` (half a second of CPU) must not be on that path.

Dask runs tasks on a thread of the worker's executor, never on the process's main thread.
bpy copes with that as long as it stays on that one thread, but its module teardown, when the
interpreter finalises on the main thread, runs Blender's exit (WM_exit), which frees the
screens set up on the other thread and segfaults (bpy 5.0.1; pycolmap's glog handler prints
the crash as a stack trace, else the worker just dies by SIGSEGV). So such a process ends
with `os._exit(0)` (`end_without_teardown`), skipping the module teardown; it first removes
Blender's session folder in /tmp, the one thing of Blender's exit that outlives the process.
"""

from __future__ import annotations

import importlib
import logging
import os
import shutil
import sys
import threading

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

_bpy_off_main_thread = False  # whether bpy ran on a thread other than the main one


def warm_up(sources: tuple[str, ...]) -> None:
    """Import what the entries of `sources` need, on the thread that will run them."""
    for name in (*(m for s in sources for m in WARM_MODULES[s]), *SHARED_MODULES):
        importlib.import_module(name)
    note_blender_thread()


def note_blender_thread() -> None:
    """Note whether bpy is loaded and this is not the main thread."""
    global _bpy_off_main_thread
    if "bpy" in sys.modules and threading.current_thread() is not threading.main_thread():
        _bpy_off_main_thread = True


def bpy_ran_off_main_thread() -> bool:
    return _bpy_off_main_thread


def end_without_teardown() -> None:
    """End the process now, skipping the module teardown that would crash in Blender's exit."""
    logging.shutdown()
    # Blender's session folder: read now, since every factory reset makes a new one.
    shutil.rmtree(sys.modules["bpy"].app.tempdir, ignore_errors=True)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)
