"""Parametric modelling of furniture and small objects in Blender, from measurement specs.

Following RAMCIP D3.1 (section 3.3.2), an installer measures an object and writes
a YAML spec; `build_model` builds it from primitives in Blender at the real dimensions (a
box with its front face removed and walls of the measured thickness, doors and handles at
their measured places, joints with limits; a cup as a hollow cylinder and a bent handle)
and returns the `articulation.Model`. Frames and units: see `modeller.specs`. The entry,
`build(spec_path, out_dir, BuildOptions(...), progress=..., force=...)`, also writes the
model folder, validates it and, on request, renders it beside the spec's photos.

bpy is imported inside the functions that need it, and only here, in the add-on and in
`homemodel.geometry.cycles_scene` (the simulators' Cycles scenes).
"""

from modeller.build import BuildOptions, SpecBuild, build, build_from_spec, build_model
from modeller.spec_loading import load_spec, write_spec_schemas
from modeller.specs import CupboardSpec, CupSpec, TableSpec

__all__ = [
    "BuildOptions",
    "CupSpec",
    "CupboardSpec",
    "SpecBuild",
    "TableSpec",
    "build",
    "build_from_spec",
    "build_model",
    "load_spec",
    "write_spec_schemas",
]
