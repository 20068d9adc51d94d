"""File formats, each with its reader and writer together (as trimesh keeps its `exchange/`).

This package sits above the domain types (`articulation`'s model and scene, `semantic_map`'s
nodes) and maps them to and from files; below it no module opens an XML, glTF or USD library
(setup.cfg's `formats` contract). Simulator decisions that are not format (joint dynamics,
actuators) stay in `articulation` as plain data the writers consume.

- `urdf`: the URDF document opened (safely, bounded) and walked; `urdf.read` (URDF to model),
  `urdf.write` (model to URDF), `urdf.mesh_paths` (its mesh references and `package://`),
  `urdf.scene` (a scene as one URDF), `urdf.ros_package` (a ROS 2 description package);
- `glb`: the GLB container, read strictly (version, chunk bounds) and written; `gltf`: a model
  or a scene as glTF binary;
- `mjcf`, `sdf`, `usd`: MuJoCo, Gazebo and Isaac files of a model or a scene, their meshes by
  `scene_meshes`; `simulator`: which writer a format name means; `mjcf_read`, `sdf_read`,
  `usd_read`: those files read back into the scene and its models (`scene_read`: what the
  three share); `simulator_read`: which reader a file means;
- `obj`: Wavefront OBJ and MTL text; `numbers`: the exporters' fixed number formatting;
- `model_files`: a model's `model.urdf`, `model.glb` and `meshes/`;
- `partnet`: a PartNet-Mobility folder read into a model;
- `map_xml`: the semantic map's XML and its schema; `home_scene`: a map as one simulator scene;
- `cameras`: `cameras.json`, the one per-view camera file (intrinsics and `camera_from_<frame>`
  per view), reading the older `poses.json` and photogrammetry list too;
- `blender_document`, `blender_glb`: the Blender model document's keys, and its glb reader.
"""
