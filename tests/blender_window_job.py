"""Run inside a real Blender window (Debian's Blender 3.4 under xvfb, --enable-event-simulate):
a turntable reconstruction as the modal background job an installer starts from the panel,
polled by its timer to the end; then a second one cancelled with Esc. Writes what it saw to
OUT.json: the statuses the panel showed, the model that landed, the operator's results.

    blender --factory-startup --enable-event-simulate EMPTY.blend --python tests/blender_window_job.py -- REPO CAPTURE OUT.json
"""

from __future__ import annotations

import json
import sys
import time
import traceback
from pathlib import Path

import bpy

REPO, CAPTURE, OUT = (Path(a) for a in sys.argv[sys.argv.index("--") + 1 :][:3])
sys.path.insert(0, str(REPO))
import blender_addons  # noqa: E402
from blender_addons import rig  # noqa: E402

SEEN: dict = {"statuses": [], "modal_results": []}
TIMEOUT_S = 300
STARTED = time.monotonic()
LOOP_S = 0.05


def _after(wait_s: float) -> float:
    """The timer interval that calls again after `wait_s`, most of it spent asleep in this
    callback: idle, Blender's event loop wakes every 5 ms (0.25 CPU-s a second here) while the
    toolkit's child does the work. The loop still runs LOOP_S between naps, so the job's own
    timer, Esc and the panel's status are handled as without them."""
    time.sleep(max(wait_s - LOOP_S, 0.0))
    return LOOP_S


def _window_context() -> dict:
    window = bpy.context.window_manager.windows[0]
    area = next(a for a in window.screen.areas if a.type == "VIEW_3D")
    return {"window": window, "area": area, "region": next(r for r in area.regions if r.type == "WINDOW")}


def _start(kind: str) -> None:
    with bpy.context.temp_override(**_window_context()):
        SEEN["modal_results"].append(sorted(bpy.ops.homemodel.run_job(kind=kind, filepath=str(CAPTURE))))


def _record() -> str:
    status = bpy.context.scene.homemodel_job_status
    if not SEEN["statuses"] or SEEN["statuses"][-1] != status:
        SEEN["statuses"].append(status)
    return status


def _finish(error: str | None = None) -> None:
    SEEN["error"] = error
    OUT.write_text(json.dumps(SEEN, indent=1))
    bpy.ops.wm.quit_blender()


def _watch_first() -> float | None:
    try:
        status = _record()
        if status.endswith(("done", "failed", "cancelled")):
            roots = [o for o in bpy.data.objects if rig.MODEL in o]
            SEEN["landed"] = [{"name": json.loads(r[rig.MODEL])["name"], "location": list(r.location),
                               "meshes": sum(1 for o in rig.owned(r) if o.type == "MESH")} for r in roots]
            SEEN["cursor"] = list(bpy.context.scene.cursor.location)
            bpy.app.timers.register(_start_second, first_interval=0.5)
            return None
        return None if _timed_out() else _after(0.25)
    except Exception:
        _finish(traceback.format_exc())
        return None


def _start_second() -> float | None:
    try:
        SEEN["first_statuses"], SEEN["statuses"] = SEEN["statuses"], []
        _start("turntable")
        bpy.app.timers.register(_press_escape, first_interval=2.0)
    except Exception:
        _finish(traceback.format_exc())
    return None


def _press_escape() -> float | None:
    try:
        _record()
        bpy.context.window_manager.windows[0].event_simulate(type="ESC", value="PRESS")
        bpy.app.timers.register(_watch_second, first_interval=0.5)
    except Exception:
        _finish(traceback.format_exc())
    return None


def _watch_second() -> float | None:
    status = _record()
    if status.endswith("cancelled") or _timed_out():
        _finish(None if status.endswith("cancelled") else "Esc did not cancel the job")
        return None
    return _after(0.25)


def _timed_out() -> bool:
    if time.monotonic() - STARTED > TIMEOUT_S:
        _finish(f"no end after {TIMEOUT_S} s")
        return True
    return False


def main() -> float | None:
    try:
        # Blender's default 8-sample anti-aliasing draws the viewport 8 times after each change,
        # here in software (llvmpipe); FXAA is one pass.
        bpy.context.preferences.system.viewport_aa = "FXAA"
        blender_addons.register()
        bpy.context.scene.cursor.location = (1.0, 2.0, 0.0)
        _start("turntable")
        bpy.app.timers.register(_watch_first, first_interval=0.25)
    except Exception:
        _finish(traceback.format_exc())
    return None


bpy.app.timers.register(main, first_interval=1.0)  # once the window and its event loop run
