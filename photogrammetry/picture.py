"""A picture of the registered cameras around the reconstructed mesh (matplotlib, off-screen)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from homemodel.geometry.mesh_ops import decimate
from photogrammetry.sfm import View

MAX_DRAWN_FACES = 4000


def draw_cameras(mesh: trimesh.Trimesh, views: list[View], path: Path, *, title: str) -> Path:
    """Write a PNG of `mesh` with a small frustum for every view (all in the mesh's frame)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

    from homemodel.core.atomic import write_bytes_atomic

    mesh = decimate(mesh, MAX_DRAWN_FACES)
    triangles = mesh.vertices[mesh.faces]
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    shade = 0.35 + 0.6 * np.clip(normals @ np.array([0.3, -0.4, 0.87]), 0, 1)
    centres = np.array([v.centre_world for v in views])
    distance = float(np.median(np.linalg.norm(centres - mesh.centroid, axis=1)))
    size = 0.12 * distance
    segments = []
    for view in views:
        world_from_camera = np.linalg.inv(view.camera_from_world)
        width, height = view.camera.width, view.camera.height
        corners = view.camera.rays(np.array([[0, 0], [width, 0], [width, height], [0, height]])) * size
        corners = corners @ world_from_camera[:3, :3].T + world_from_camera[:3, 3]
        apex = world_from_camera[:3, 3]
        segments += [[apex, c] for c in corners] + [[corners[i], corners[(i + 1) % 4]] for i in range(4)]

    figure = plt.figure(figsize=(8, 7), dpi=110)
    axes = figure.add_subplot(projection="3d")
    axes.add_collection3d(Poly3DCollection(triangles, facecolors=plt.cm.Greys(1 - shade), linewidths=0))
    axes.add_collection3d(Line3DCollection(segments, colors="tab:blue", linewidths=0.8))
    everything = np.vstack([mesh.vertices, centres])
    middle = (everything.min(axis=0) + everything.max(axis=0)) / 2
    half = np.ptp(everything, axis=0).max() / 2
    axes.set(xlim=(middle[0] - half, middle[0] + half), ylim=(middle[1] - half, middle[1] + half))
    axes.set(zlim=(middle[2] - half, middle[2] + half), xlabel="x", ylabel="y", zlabel="z")
    axes.set_box_aspect((1, 1, 1))
    axes.view_init(elev=30, azim=-60)
    axes.set_title(title)
    from io import BytesIO

    buffer = BytesIO()
    figure.savefig(buffer, format="png")
    plt.close(figure)
    write_bytes_atomic(path, buffer.getvalue())
    return path
