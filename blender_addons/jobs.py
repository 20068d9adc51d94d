"""Reconstructions as background jobs: a turntable capture, photos, or one depth image
become a model in the scene while Blender stays responsive.

The toolkit runs as a child process and reports its progress through the file
HOMEMODEL_PROGRESS_FILE names; a timer on Blender's main thread polls it (only the main
thread touches bpy), Esc cancels. `Job` holds the work in plain methods, so scripts and
tests run the same steps without a timer (the operator's `execute` waits for the job).
"""

from __future__ import annotations

import json
import shutil
import tempfile
import time
from pathlib import Path

import bpy
from bpy.props import EnumProperty, StringProperty
from bpy_extras.io_utils import ImportHelper
from mathutils import Matrix

from . import rig, toolkit
from .properties import preference

JOB_BUTTONS = {
    "turntable": ("Reconstruct turntable capture", "MESH_CYLINDER"),
    "photos": ("Reconstruct from photos", "IMAGE_DATA"),
    "completion": ("Complete from one depth image", "MOD_REMESH"),
}
POLL_S = 0.5


class Job:
    """One reconstruction in a child process, and its model document when it is done."""

    def __init__(self, kind: str, source: Path, preference_text: str, *, completion_model: str = "", camera: str = "") -> None:
        self.kind, self.preference = kind, preference_text
        self.work = Path(tempfile.mkdtemp(prefix=f"homemodel-{kind}-"))
        self.out = self.work / "model"
        self.progress_file = self.work / "progress.jsonl"
        self.log = self.work / "log.txt"
        self.args = self._arguments(kind, Path(source), completion_model, camera)
        self.fraction, self.stage = 0.0, "starting"
        self.process = None

    def _arguments(self, kind: str, source: Path, completion_model: str, camera: str) -> list[str]:
        out = ["--out", str(self.out), "--force"]
        if kind == "turntable":
            return ["turntable", "reconstruct", str(source), *out]
        if kind == "photos":
            return ["photogrammetry", "reconstruct", str(source), *out]
        if kind == "completion":
            camera = camera or str(source.parent / "camera.yaml")
            return ["completion", "run", completion_model, str(source), "--camera", camera, *out]
        raise ValueError(f"unknown job {kind!r}")

    def start(self) -> None:
        self.process = toolkit.start(self.args, self.preference, log_path=self.log, env={"HOMEMODEL_PROGRESS_FILE": str(self.progress_file)})

    def poll(self) -> bool:
        """Read the progress so far; True once the child has ended."""
        if self.progress_file.exists():
            lines = self.progress_file.read_text(encoding="utf-8").splitlines()
            if lines:
                last = json.loads(lines[-1])
                self.stage = last["stage"]
                self.fraction = last["done"] / last["total"] if last.get("total") else self.fraction
        return self.process.poll() is not None

    def cancel(self) -> None:
        """Stop the child and remove its work folder (a finished job's stays: the model's
        textures are read from it)."""
        self.process.terminate()
        self.process.wait()
        shutil.rmtree(self.work, ignore_errors=True)

    def document(self) -> dict:
        """The finished model's document; ToolkitError with the toolkit's message if it failed."""
        if not self.work.exists():
            raise toolkit.ToolkitError("the job was cancelled")
        if self.process.returncode != 0:
            lines = [line for line in self.log.read_text(encoding="utf-8").splitlines() if line.strip()]
            raise toolkit.ToolkitError(next((l for l in reversed(lines) if l.startswith("error:")), lines[-1] if lines else "the job failed"))
        toolkit.run(["addon", "describe", str(self.out), "--out", str(self.work / "model.json")], self.preference)
        return toolkit.read_json(self.work / "model.json")


def _land(context, job: Job) -> bpy.types.Object:
    """Put the finished model at the 3D cursor, selected."""
    root = rig.add_model(job.document(), context.collection)
    root.matrix_world = Matrix.Translation(context.scene.cursor.location)
    rig.select_only(context, root)
    return root


class HOMEMODEL_OT_run_job(bpy.types.Operator, ImportHelper):
    """Reconstruct a model in the background; Esc cancels"""

    bl_idname = "homemodel.run_job"
    bl_label = "Reconstruct"
    bl_options = {"REGISTER", "UNDO"}
    kind: EnumProperty(items=[(k, label, "") for k, (label, _) in JOB_BUTTONS.items()], options={"HIDDEN"})
    filename_ext = ""
    completion_model: StringProperty(name="Completion model", description="completion: the model file `homemodel completion train` wrote", subtype="FILE_PATH")
    camera: StringProperty(name="Camera", description="completion: camera.yaml of the depth image (default: beside it)", subtype="FILE_PATH")

    def _job(self, context) -> Job:
        source = Path(self.filepath)
        if self.kind != "completion" and source.is_file():
            source = source.parent  # a capture or photo folder, picked through one of its files
        return Job(self.kind, source, preference(context), completion_model=self.completion_model, camera=self.camera)

    def execute(self, context):
        """In a window: start the job and poll it from a timer. Without one (scripts, tests,
        `blender --background`): wait for it to end."""
        if context.window is not None and not bpy.app.background:
            return self.start_modal(context)
        try:
            job = self._job(context)
            job.start()
            while not job.poll():
                time.sleep(POLL_S)
            _land(context, job)
        except toolkit.ToolkitError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        return {"FINISHED"}

    def modal(self, context, event):
        if event.type == "ESC":
            self.job.cancel()
            return self._finish(context, "cancelled")
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        done = self.job.poll()
        self._show(context)
        if not done:
            return {"RUNNING_MODAL"}
        try:
            _land(context, self.job)
        except toolkit.ToolkitError as exc:
            self.report({"ERROR"}, str(exc))
            return self._finish(context, "failed", cancelled=True)
        return self._finish(context, "done")

    def _show(self, context) -> None:
        """The job's stage and progress in the panel, redrawn only when they change (each redraw
        draws the scene: without a GPU, in software)."""
        shown = (f"{JOB_BUTTONS[self.kind][0]}: {self.job.stage}", round(100.0 * self.job.fraction, 1))
        if shown != getattr(self, "shown", None):
            self.shown = shown
            context.scene.homemodel_job_status, context.scene.homemodel_job_progress = shown
            context.window_manager.progress_update(int(shown[1]))
            if context.area is not None:
                context.area.tag_redraw()

    def _finish(self, context, status: str, *, cancelled: bool = False):
        context.window_manager.event_timer_remove(self.timer)
        context.window_manager.progress_end()
        context.scene.homemodel_job_status = f"{JOB_BUTTONS[self.kind][0]}: {status}"
        return {"CANCELLED"} if cancelled or status == "cancelled" else {"FINISHED"}

    def start_modal(self, context):
        try:
            self.job = self._job(context)
            self.job.start()
        except toolkit.ToolkitError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        self.timer = context.window_manager.event_timer_add(POLL_S, window=context.window)
        context.window_manager.progress_begin(0, 100)
        context.window_manager.modal_handler_add(self)
        self._show(context)  # "starting" at once, not the last job's status until the first poll
        return {"RUNNING_MODAL"}


CLASSES = (HOMEMODEL_OT_run_job,)
