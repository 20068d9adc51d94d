"""Geometry shared by the pipelines: the pinhole camera, ray casting, depth and mesh I/O,
mesh operations and the UV atlas."""
