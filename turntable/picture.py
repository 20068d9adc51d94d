"""A picture of the result: the coloured mesh in the table frame and the camera's orbit
around it (each used frame's camera centre), drawn off-screen with matplotlib."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import trimesh

from homemodel.core.atomic import write_bytes_atomic

_MAX_FACES = 6000  # enough to read the shape; matplotlib sorts every face


def draw_mesh_and_orbit(
    mesh: trimesh.Trimesh,
    vertex_colors: np.ndarray,
    cameras_from_table: list[np.ndarray],
    axis_xy_m: np.ndarray,
    path: Path,
) -> None:
    """`vertex_colors` (N, 3) in 0-1; one camera pose per used frame; the turntable's axis
    through `axis_xy_m` in the table frame."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    step = max(1, len(mesh.faces) // _MAX_FACES)
    faces = mesh.faces[::step]
    face_colors = np.clip(vertex_colors[faces].mean(axis=1), 0, 1)
    centres = np.array([np.linalg.inv(camera_from_table)[:3, 3] for camera_from_table in cameras_from_table])
    figure = plt.figure(figsize=(8, 7), dpi=110)
    axes = figure.add_subplot(projection="3d")
    axes.add_collection3d(Poly3DCollection(mesh.vertices[faces], facecolors=face_colors, edgecolors="none"))
    axes.plot(*centres.T, "o-", color="tab:blue", markersize=3, linewidth=0.8, label="camera centres (table frame)")
    top = max(float(mesh.bounds[1, 2]), float(centres[:, 2].max()))
    axes.plot([axis_xy_m[0]] * 2, [axis_xy_m[1]] * 2, [0.0, top], "--", color="tab:red", label="turntable axis")
    span = np.vstack([centres, mesh.bounds])
    middle, half = span.mean(axis=0), np.ptp(span, axis=0).max() / 2
    axes.set(xlim=(middle[0] - half, middle[0] + half), ylim=(middle[1] - half, middle[1] + half), zlim=(0, 2 * half))
    axes.set_xlabel("x (m)")
    axes.set_ylabel("y (m)")
    axes.set_zlabel("z (m)")
    axes.set_title(f"{len(mesh.faces)} triangles, {len(cameras_from_table)} frames")
    axes.legend(loc="upper left")
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png")
    plt.close(figure)
    write_bytes_atomic(Path(path), buffer.getvalue())
