"""File formats, each with its reader and writer together (as trimesh keeps its `exchange/`).

This package sits below `articulation` and `semantic_map` (see the layers in setup.cfg), so it
holds what a format is on disk - the GLB container, the joint types the formats name, the URDF
document walked once, the Blender model document's keys - and never a domain type; the
articulated model's and the map's writers turn their types into these.
"""
