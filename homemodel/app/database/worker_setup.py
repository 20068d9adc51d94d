"""What each Dask worker of a database build does once: import the heavy libraries of the
build's sources before its first entry, and end its process cleanly when it closes.

Dask runs tasks on a thread of the worker's executor, never on the process's main thread.
bpy copes with that as long as it stays on that one thread, but its module teardown, when the
interpreter finalises on the main thread, runs Blender's exit (WM_exit), which frees the
screens set up on the other thread and segfaults (bpy 5.0.1; pycolmap's glog handler prints
the crash as a stack trace, else the worker just dies by SIGSEGV). So a worker that used bpy
off the main thread, once Dask has closed it, ends from an exit handler with `os._exit(0)`,
skipping the module teardown (and the exit handlers registered before it: logging's is run
by hand); it first removes Blender's session folder in /tmp, the one thing of Blender's exit
that outlives the process.
"""

from __future__ import annotations

import asyncio
import atexit
import importlib
import logging
import os
import shutil
import sys
import threading

from distributed.diagnostics.plugin import WorkerPlugin

log = logging.getLogger(__name__)

PLUGIN_NAME = "homemodel-db-worker"
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


def _end_without_teardown() -> None:
    logging.shutdown()
    # Blender's session folder: read now, since every factory reset makes a new one.
    shutil.rmtree(sys.modules["bpy"].app.tempdir, ignore_errors=True)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


class DatabaseWorker(WorkerPlugin):
    """Warms the worker up for the build's sources; when the worker closes, arranges the clean
    end of its process if bpy ran there (see the module's note). Given to a local cluster's
    workers as they start, it runs before they join the scheduler; registered with a running
    cluster, on each worker there and each that joins later."""

    name = PLUGIN_NAME

    def __init__(self, sources: tuple[str, ...], sys_path: list[str] | None = None) -> None:
        self.sources = tuple(sorted(set(sources)))
        self.sys_path = sys_path  # a local cluster's: its client's, without Blender's folders

    async def setup(self, worker) -> None:  # noqa: ANN001 (distributed.Worker)
        if self.sys_path is not None:
            sys.path[:] = self.sys_path
        # On the executor's thread (one per worker), and awaited: the worker takes its first
        # entry, which its event loop unpickles, only once these imports are done (imports of
        # the same modules on two threads at once are what a stalled build was suspected of).
        try:
            await asyncio.wrap_future(worker.executor.submit(warm_up, self.sources))
        except Exception as exc:  # noqa: BLE001 (the entries then fail with their own error)
            log.warning("warming up failed: %s", exc)

    def teardown(self, worker) -> None:  # noqa: ANN001
        if _bpy_off_main_thread:
            atexit.unregister(_end_without_teardown)  # once, whatever the number of builds
            atexit.register(_end_without_teardown)
