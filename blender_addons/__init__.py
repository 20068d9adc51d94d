"""homemodel for Blender: the installer's extension.

Build furniture and small objects from measurement forms, move every joint, import and
export models and whole homes (the semantic map), and run the scan and photo
reconstructions as background jobs, all from the "homemodel" tab of the 3D viewport's
sidebar. The heavy work runs in the homemodel toolkit's own environment, called as a child
process (`toolkit`); this package never imports the toolkit.
"""

# Blender before 4.2 reads add-ons by this; 4.2 and later read blender_manifest.toml.
bl_info = {
    "name": "homemodel",
    "description": "Model a home for a service robot: furniture from measurements, joints, semantic map",
    "author": "homemodel developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "3D Viewport > Sidebar > homemodel",
    "category": "Import-Export",
}

from . import form_operators, home_operators, jobs, model_operators, panels, properties, render  # noqa: E402

_OPERATOR_CLASSES = (*form_operators.CLASSES, *model_operators.CLASSES, *home_operators.CLASSES, *jobs.CLASSES, *render.CLASSES)


def register() -> None:
    import bpy

    properties.register()
    for cls in _OPERATOR_CLASSES:
        bpy.utils.register_class(cls)
    panels.register()


def unregister() -> None:
    import bpy

    panels.unregister()
    for cls in reversed(_OPERATOR_CLASSES):
        bpy.utils.unregister_class(cls)
    properties.unregister()
