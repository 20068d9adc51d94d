"""Screenshots of the Blender extension's panels in a real Blender window.

The bpy module cannot draw panels, so `make addon-screenshots` runs this inside Debian's
Blender 3.4 under xvfb (the panels' drawing code keeps to API 3.4 and 5.0 share):

    xvfb-run -a -s "-screen 0 1600x1000x24" blender --factory-startup --enable-event-simulate \
        EMPTY.blend --python tools/addon_screenshots.py -- REPO MAP.xml OUT_DIR

It registers the extension from REPO/blender_addons, clicks the sidebar's "homemodel" tab
(3.4 has no API to choose a tab), imports the kitchen map, opens a cupboard door half way and
saves one screenshot per panel into OUT_DIR, with OUT_DIR/screenshots.json naming
the panels that drew (a panel's draw runs only when it is on screen). Given a SCRIPT [ARGS...]
after OUT_DIR, Blender runs it next in the same window (as `--python SCRIPT -- REPO ARGS...`)
instead of quitting: the extension's window tests start Blender once for both of theirs.
"""

from __future__ import annotations

import json
import math
import runpy
import sys
import time
import traceback
from pathlib import Path

import bpy

REPO, MAP_PATH, OUT_DIR = (Path(a) for a in sys.argv[sys.argv.index("--") + 1 :][:3])
THEN = sys.argv[sys.argv.index("--") + 4 :]  # SCRIPT ARGS...: run next instead of quitting
sys.path.insert(0, str(REPO))
import blender_addons  # noqa: E402
from blender_addons import home, panels, rig  # noqa: E402

DRAWN: set[str] = set()
TAB_STEP_PX = 24  # a tab's label is 40-80 px long
LOOP_S = 0.05


def after(wait_s: float) -> float:
    """The timer interval that calls again after `wait_s`, most of it spent asleep in this
    callback: idle, Blender's event loop wakes every 5 ms (0.25 CPU-s a second under xvfb). What
    was tagged draws when the callback returns, and the loop handles the simulated clicks and
    draws again in the LOOP_S between naps."""
    time.sleep(max(wait_s - LOOP_S, 0.0))
    return LOOP_S


def _recording(cls):
    draw = cls.draw

    def recorded(self, context):
        DRAWN.add(cls.__name__)
        draw(self, context)

    cls.draw = recorded


def _view3d():
    window = bpy.context.window_manager.windows[0]
    area = next(a for a in window.screen.areas if a.type == "VIEW_3D")
    return window, area, next(r for r in area.regions if r.type == "UI")


def _only_panels(*names: str) -> None:
    """Leave only these homemodel panels registered, so each screenshot shows its own."""
    for cls in panels.CLASSES:
        if issubclass(cls, bpy.types.Panel):
            registered = getattr(cls, "is_registered", False)
            if cls.__name__ in names and not registered:
                bpy.utils.register_class(cls)
            elif cls.__name__ not in names and registered:
                bpy.utils.unregister_class(cls)


def setup() -> None:
    """The extension registered and the sidebar shown, on the empty scene: the tab search
    (click_tabs) redraws the window many times, cheaply while the kitchen is not there yet."""
    # Blender's default 8-sample anti-aliasing draws the viewport 8 times after each change,
    # here in software (llvmpipe); FXAA is one pass.
    bpy.context.preferences.system.viewport_aa = "FXAA"
    blender_addons.register()
    for cls in panels.CLASSES:
        if issubclass(cls, bpy.types.Panel):
            _recording(cls)
    window, area, _ = _view3d()
    space = area.spaces.active
    space.show_region_ui = True
    space.shading.color_type = "MATERIAL"
    space.overlay.show_relationship_lines = False
    space.region_3d.view_perspective = "PERSP"


def load_kitchen() -> None:
    bpy.ops.homemodel.import_map(filepath=str(MAP_PATH))
    roots = {home.object_id(r): r for r in home.model_roots(bpy.context.scene)}
    cupboard = roots["cupboard_1"]
    door = next(j for j in rig.joints_of(cupboard) if j[rig.JOINT] == "door_0_hinge")
    rig.set_position(door, math.radians(50))
    rig.select_only(bpy.context, cupboard)
    form = bpy.context.scene.homemodel_form
    form.kind = "cupboard"
    bpy.ops.homemodel.form_kind()
    look((1.6, 2.9, 0.4), 6.0, 60, 40)  # the kitchen from the south-east, looking north-west


def look(at, distance_m: float, tilt_deg: float, heading_deg: float) -> None:
    """Point the viewport at `at`; heading 0 looks along +y, 90 along -x."""
    from mathutils import Euler

    view = _view3d()[1].spaces.active.region_3d
    view.view_location = at
    view.view_distance = distance_m
    view.view_rotation = Euler((math.radians(tilt_deg), 0.0, math.radians(heading_deg)), "XYZ").to_quaternion()


def click_tabs():
    """Click down the sidebar's tab strip until the homemodel panels draw; None when done."""
    window, area, region = _view3d()
    state = click_tabs.__dict__.setdefault("state", {"y": region.y + region.height - 20})
    if "HOMEMODEL_PT_build" in DRAWN:
        return None
    if state["y"] < region.y + 20:
        raise RuntimeError("no sidebar tab drew the homemodel panels")
    x = region.x + region.width - 8
    # One click per call (the loop handles the queued events in order): each call redraws.
    window.event_simulate(type="LEFTMOUSE", value="PRESS", x=x, y=state["y"])
    window.event_simulate(type="LEFTMOUSE", value="RELEASE", x=x, y=state["y"])
    window.event_simulate(type="MOUSEMOVE", value="NOTHING", x=region.x - 300, y=region.y + 300)
    state["y"] -= TAB_STEP_PX
    DRAWN.clear()
    region.tag_redraw()
    return after(0.3)


SHOTS = [
    ("addon_build.png", ("HOMEMODEL_PT_build",)),
    ("addon_joints.png", ("HOMEMODEL_PT_model",)),
    ("addon_home.png", ("HOMEMODEL_PT_home", "HOMEMODEL_PT_jobs")),
]


def shoot():
    """One screenshot per entry of SHOTS, each after a redraw with only its panels."""
    index = shoot.__dict__.setdefault("index", 0)
    window, area, region = _view3d()
    if index > 0:
        name, wanted = SHOTS[index - 1]
        drew = sorted(n for n in DRAWN if n.startswith("HOMEMODEL_PT"))
        report[name] = drew
        with bpy.context.temp_override(window=window, area=area):
            bpy.ops.screen.screenshot_area(filepath=str(OUT_DIR / name))
    if index == len(SHOTS):
        (OUT_DIR / "screenshots.json").write_text(json.dumps(report, indent=1))
        finish()
        return None
    name, wanted = SHOTS[index]
    roots = {home.object_id(r): r for r in home.model_roots(bpy.context.scene)}
    if name == "addon_joints.png":  # the cupboard from in front, its left door half open
        rig.select_only(bpy.context, roots["cupboard_1"])
        look((0.3, 3.0, 0.45), 2.6, 70, 105)
    if name == "addon_home.png":  # the table with its cups and the robot's parking arrows
        rig.select_only(bpy.context, roots["table_1"])
        look((2.0, 1.5, 0.4), 4.2, 50, 20)
    _only_panels(*wanted)
    DRAWN.clear()
    for a in window.screen.areas:
        a.tag_redraw()
    shoot.index = index + 1
    return after(1.0)


report: dict[str, list[str]] = {}


def finish() -> None:
    """Quit, or run THEN's script in this window on its own arguments."""
    if not THEN:
        bpy.ops.wm.quit_blender()
        return
    script, *args = THEN
    sys.argv = [*sys.argv[: sys.argv.index("--")], "--", str(REPO), *args]
    runpy.run_path(script, run_name="__main__")


def guarded(step):
    def run():
        try:
            return step()
        except Exception:
            traceback.print_exc()
            print("SCREENSHOT SCRIPT FAILED", flush=True)
            bpy.ops.wm.quit_blender()
            return None

    return run


def start():
    setup()
    bpy.app.timers.register(guarded(chain), first_interval=1.0)
    return None


def chain():
    wait_s = click_tabs()
    if wait_s is not None:
        return wait_s
    load_kitchen()
    bpy.app.timers.register(guarded(shoot), first_interval=1.0)
    return None


OUT_DIR.mkdir(parents=True, exist_ok=True)
bpy.app.timers.register(guarded(start), first_interval=1.0)
