"""File formats, each with its reader and writer together (as trimesh keeps its `exchange/`).

This package sits below `articulation` and `semantic_map` (see the layers in setup.cfg), so it
holds what a format is on disk and never a domain type; the articulated model's and the map's
writers turn their types into these:

- `glb`: the GLB container, read strictly (version, chunk bounds) and written;
- `urdf`: the URDF document opened (safely, bounded) and walked: links, joints, their meshes;
- `obj`: Wavefront OBJ and MTL text; `numbers`: the exporters' fixed number formatting;
- `joint_types`: the joint types the formats name;
- `cameras`: `cameras.json`, the one per-view camera file (intrinsics and `camera_from_<frame>`
  per view), reading the older `poses.json` and photogrammetry list too;
- `blender_document`, `blender_glb`: the Blender model document's keys, and its glb reader.
"""
