"""How a worker process that ran bpy off its main thread ends.

Dask runs tasks on a thread of the worker's executor, never on the process's main thread.
bpy copes with that as long as it stays on that one thread, but its module teardown, when the
interpreter finalises on the main thread, runs Blender's exit (WM_exit), which frees the
screens set up on the other thread and segfaults (bpy 5.0.1; pycolmap's glog handler prints
the crash as a stack trace, else the worker just dies by SIGSEGV). So such a process ends
with `os._exit(0)` (`end_without_teardown`), skipping the module teardown; it first removes
Blender's session folder in /tmp, the one thing of Blender's exit that outlives the process.

Its own module, below both the warm-up (which imports the entry build by name) and the entry
build (which notes the thread after each entry), so neither imports the other.
"""

from __future__ import annotations

import logging
import os
import shutil
import sys
import threading

_bpy_off_main_thread = False  # whether bpy ran on a thread other than the main one


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
