"""A picture of the result: the coloured mesh in the table frame and the camera's orbit
around it (each used frame's camera centre), drawn off-screen with matplotlib."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from homemodel.core.atomic import write_bytes_atomic
from turntable.reconstruct import Reconstruction

_MAX_FACES = 6000  # enough to read the shape; matplotlib sorts every face


def draw_mesh_and_orbit(result: Reconstruction, path: Path) -> None:
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    mesh = result.mesh
    step = max(1, len(mesh.faces) // _MAX_FACES)
    faces = mesh.faces[::step]
    face_colors = np.clip(result.vertex_colors[faces].mean(axis=1), 0, 1)
    centres = np.array([np.linalg.inv(p.camera_from_table)[:3, 3] for p in result.poses.values()])
    figure = plt.figure(figsize=(8, 7), dpi=110)
    axes = figure.add_subplot(projection="3d")
    axes.add_collection3d(Poly3DCollection(mesh.vertices[faces], facecolors=face_colors, edgecolors="none"))
    axes.plot(*centres.T, "o-", color="tab:blue", markersize=3, linewidth=0.8, label="camera centres (table frame)")
    axis_xy = result.axis.axis_xy_m
    top = max(float(mesh.bounds[1, 2]), float(centres[:, 2].max()))
    axes.plot([axis_xy[0]] * 2, [axis_xy[1]] * 2, [0.0, top], "--", color="tab:red", label="turntable axis")
    span = np.vstack([centres, mesh.bounds])
    middle, half = span.mean(axis=0), np.ptp(span, axis=0).max() / 2
    axes.set(xlim=(middle[0] - half, middle[0] + half), ylim=(middle[1] - half, middle[1] + half), zlim=(0, 2 * half))
    axes.set_xlabel("x (m)")
    axes.set_ylabel("y (m)")
    axes.set_zlabel("z (m)")
    axes.set_title(f"{len(mesh.faces)} triangles, {len(result.poses)} frames")
    axes.legend(loc="upper left")
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png")
    plt.close(figure)
    write_bytes_atomic(Path(path), buffer.getvalue())
