"""Run inside a real Blender window (Debian's Blender 3.4 under xvfb, --enable-event-simulate):
a turntable reconstruction as the modal background job an installer starts from the panel,
polled by its timer to the end; then a second one cancelled with Esc. Writes what it saw to
OUT.json: the statuses the panel showed, the model that landed, the operator's results.

    blender --factory-startup --enable-event-simulate EMPTY.blend --python tests/blender_window_job.py -- REPO CAPTURE OUT.json

or after tools/addon_screenshots.py in its window (its SCRIPT ARGS: this script, CAPTURE, OUT.json),
on the scene emptied of the screenshots' kitchen.
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
from blender_addons import jobs, rig  # noqa: E402

SEEN: dict = {"statuses": [], "modal_results": []}
TIMEOUT_S = 300
STARTED = [time.monotonic()]  # reset when the job starts: the screenshots may come first
LOOP_S = 0.05
NAP_S = 2.0
LABEL = jobs.JOB_BUTTONS["turntable"][0] + ": "
JOBS: list[jobs.Job] = []  # the jobs the operator started, in order, for the waits below
_start_job = jobs.Job.start


def _recorded_start(job: jobs.Job) -> None:
    JOBS.append(job)
    _start_job(job)


jobs.Job.start = _recorded_start


def _reported(job: jobs.Job) -> str:
    """What the toolkit has reported that the panel can show: its last stage, or "ended"."""
    if job.process is None or job.process.poll() is not None:
        return "ended"
    try:
        lines = job.progress_file.read_text(encoding="utf-8").splitlines()
        return json.loads(lines[-1])["stage"] if lines else "starting"
    except FileNotFoundError:
        return "starting"
    except ValueError:  # a line half-written: news on its way
        return "news"


def _until_news(job: jobs.Job, shown: str) -> float:
    """The timer interval after a wait on the job's state: idle, Blender's event loop wakes every
    5 ms (0.25 CPU-s a second here) while the toolkit's child does the work, so while the panel
    already shows the child's last stage this callback sleeps (up to NAP_S) until the child
    reports another or ends. Then the loop runs (LOOP_S between calls) until the job's own
    timer has polled it and the panel shows the news; Esc and the status are handled as
    without the naps."""
    deadline = time.monotonic() + NAP_S
    while _reported(job) == shown and time.monotonic() < deadline:
        time.sleep(LOOP_S)
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
            bpy.app.timers.register(_start_second, first_interval=LOOP_S)
            return None
        return None if _timed_out() else _until_news(JOBS[0], status.removeprefix(LABEL))
    except Exception:
        _finish(traceback.format_exc())
        return None


def _start_second() -> float | None:
    try:
        SEEN["first_statuses"], SEEN["statuses"] = SEEN["statuses"], []
        _start("turntable")
        bpy.app.timers.register(_press_escape, first_interval=LOOP_S)
    except Exception:
        _finish(traceback.format_exc())
    return None


def _press_escape() -> float | None:
    """Esc once the job's timer has polled the second job (the panel shows it, no longer the
    first one's "done") while its child runs."""
    try:
        if _record().endswith("done") or JOBS[-1].process.poll() is not None:
            return None if _timed_out() else LOOP_S
        bpy.context.window_manager.windows[0].event_simulate(type="ESC", value="PRESS")
        bpy.app.timers.register(_watch_second, first_interval=LOOP_S)
    except Exception:
        _finish(traceback.format_exc())
    return None


def _watch_second() -> float | None:
    status = _record()
    if status.endswith("cancelled") or _timed_out():
        _finish(None if status.endswith("cancelled") else "Esc did not cancel the job")
        return None
    return LOOP_S


def _timed_out() -> bool:
    if time.monotonic() - STARTED[0] > TIMEOUT_S:
        _finish(f"no end after {TIMEOUT_S} s")
        return True
    return False


def main() -> float | None:
    try:
        # Blender's default 8-sample anti-aliasing draws the viewport 8 times after each change,
        # here in software (llvmpipe); FXAA is one pass.
        bpy.context.preferences.system.viewport_aa = "FXAA"
        if not getattr(jobs.CLASSES[0], "is_registered", False):  # the screenshots registered it
            blender_addons.register()
        for obj in list(bpy.data.objects):  # the screenshots' kitchen: the job lands alone
            bpy.data.objects.remove(obj)
        STARTED[0] = time.monotonic()
        bpy.context.scene.cursor.location = (1.0, 2.0, 0.0)
        _start("turntable")
        bpy.app.timers.register(_watch_first, first_interval=0.25)
    except Exception:
        _finish(traceback.format_exc())
    return None


bpy.app.timers.register(main, first_interval=1.0)  # once the window and its event loop run
