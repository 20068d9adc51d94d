"""The render button: the selected model, or the whole room, to an image.

The picture is made by Blender itself (Cycles on the CPU, a few samples: a look, not a
beauty shot) from a camera that frames what is rendered, so it can be laid beside the
photos the model was measured or textured from.
"""

from __future__ import annotations

import math
from pathlib import Path

import bpy
from bpy.props import IntProperty, StringProperty
from mathutils import Vector

from . import home, rig

CAMERA_NAME = "homemodel render camera"
FIELD_OF_VIEW_RAD = math.radians(40)
SUN_STRENGTH = 4.0  # W/m^2, Blender's sun units


def _targets(context) -> tuple[str, list[bpy.types.Object]]:
    """What to render: the selected model, else the chosen room's objects."""
    root = rig.model_root(context.active_object)
    if root is not None and context.active_object.select_get():
        return home.object_id(root), rig.model_objects(root)
    room = next((r for r in home.rooms(context.scene) if r[home.ROOM] == context.scene.homemodel_room), None)
    if room is None:
        return "", []
    return room[home.ROOM], [o for o in room.all_objects if o.type == "MESH"]


def _frame(camera: bpy.types.Object, objects: list[bpy.types.Object]) -> None:
    """Aim `camera` from the front-right, above, at the objects' bounding sphere."""
    corners = [o.matrix_world @ Vector(c) for o in objects if o.type == "MESH" for c in o.bound_box]
    low = Vector([min(c[i] for c in corners) for i in range(3)])
    high = Vector([max(c[i] for c in corners) for i in range(3)])
    centre, radius = (low + high) / 2, max((high - low).length / 2, 0.05)
    distance = radius / math.sin(FIELD_OF_VIEW_RAD / 2) * 1.1
    direction = Vector((1.0, -0.8, 0.7)).normalized()
    camera.location = centre + direction * distance
    camera.rotation_euler = (-direction).to_track_quat("-Z", "Y").to_euler()
    camera.data.angle = FIELD_OF_VIEW_RAD
    camera.data.clip_end = distance * 4


class HOMEMODEL_OT_render(bpy.types.Operator):
    """Render the selected model, or the whole room, to a picture"""

    bl_idname = "homemodel.render"
    bl_label = "Render"
    bl_options = {"REGISTER"}
    directory: StringProperty(subtype="DIR_PATH", description="where to write render_<id>.png (beside the photos)")
    resolution_px: IntProperty(name="Width", default=640, min=64, max=4096)
    samples: IntProperty(name="Samples", default=16, min=1, max=4096)

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def execute(self, context):
        name, objects = _targets(context)
        if not any(o.type == "MESH" for o in objects):
            self.report({"ERROR"}, "select a model, or choose a room with objects in it")
            return {"CANCELLED"}
        scene = context.scene
        rig.evaluate(context.view_layer, home.model_roots(scene))
        hidden = [o for o in scene.objects if o.type == "MESH" and o not in objects and not o.hide_render]
        camera = bpy.data.objects.new(CAMERA_NAME, bpy.data.cameras.new(CAMERA_NAME))
        sun = bpy.data.objects.new(CAMERA_NAME + " sun", bpy.data.lights.new(CAMERA_NAME + " sun", "SUN"))
        sun.data.energy = SUN_STRENGTH
        scene.collection.objects.link(camera)
        scene.collection.objects.link(sun)
        settings = (scene.camera, scene.render.engine, scene.render.filepath, scene.render.resolution_x,
                    scene.render.resolution_y, scene.render.resolution_percentage)
        path = Path(bpy.path.abspath(self.directory)) / f"render_{name}.png"
        try:
            for obj in hidden:
                obj.hide_render = True
            _frame(camera, objects)
            sun.rotation_euler = camera.rotation_euler  # light from the viewer's side
            scene.camera = camera
            scene.render.engine = "CYCLES"
            scene.cycles.samples = self.samples
            scene.cycles.device = "CPU"
            scene.render.resolution_x, scene.render.resolution_y = self.resolution_px, self.resolution_px * 3 // 4
            scene.render.resolution_percentage = 100
            scene.render.filepath = str(path)
            bpy.ops.render.render(write_still=True)
        finally:
            for obj in hidden:
                obj.hide_render = False
            (scene.camera, scene.render.engine, scene.render.filepath, scene.render.resolution_x,
             scene.render.resolution_y, scene.render.resolution_percentage) = settings
            bpy.data.objects.remove(camera, do_unlink=True)
            bpy.data.objects.remove(sun, do_unlink=True)
        self.report({"INFO"}, f"rendered {path}")
        return {"FINISHED"}


CLASSES = (HOMEMODEL_OT_render,)
