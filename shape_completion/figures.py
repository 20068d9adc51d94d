"""A PNG like D3.1's Figure 61: per example, the query depth, the retrieved model, the
reconstruction and the ground truth, the meshes shown as depth renders from the side."""

from __future__ import annotations

import io

import numpy as np
import trimesh

from homemodel.geometry.camera import Camera
from homemodel.geometry.raycast import RayCaster
from shape_completion.render import camera_from_object_on_sphere

SIDE_CAMERA = Camera(width=160, height=160, fx=200.0, fy=200.0, cx=79.5, cy=79.5)


def side_view(mesh: trimesh.Trimesh, centre: np.ndarray, direction: np.ndarray, distance_m: float) -> np.ndarray:
    return RayCaster(mesh).depth(SIDE_CAMERA, camera_from_object_on_sphere(centre, direction, distance_m))


def examples_png(examples: list) -> bytes:
    """The figure as PNG bytes; `examples` are `benchmark.Example`s."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    columns = ("query depth", "retrieved", "fitted", "completed", "ground truth")
    fig, axes = plt.subplots(
        len(examples), len(columns), figsize=(2.2 * len(columns), 2.3 * len(examples)), squeeze=False
    )
    for row, example in enumerate(examples):
        truth = example.truth
        centre = truth.bounds.mean(axis=0)
        # Seen from the side: a quarter turn around the object from the query camera's ray.
        ray = centre / np.linalg.norm(centre)
        direction = np.cross(ray, [0.0, 1.0, 0.0])
        direction = direction / np.linalg.norm(direction) if np.linalg.norm(direction) > 1e-6 else np.array([1.0, 0, 0])
        distance = 1.6 * float(np.linalg.norm(truth.extents)) * SIDE_CAMERA.fx / SIDE_CAMERA.width
        meshes = (example.completion.retrieved, example.completion.deformed, example.completion.mesh, truth)
        images = [example.depth_m] + [side_view(m, centre, -direction, distance) for m in meshes]
        for column, image in enumerate(images):
            ax = axes[row, column]
            ax.imshow(np.ma.masked_invalid(image), cmap="viridis_r")
            if column == 0:
                rows, cols = np.nonzero(np.isfinite(image))
                pad = 10
                ax.set_xlim(cols.min() - pad, cols.max() + pad)
                ax.set_ylim(rows.max() + pad, rows.min() - pad)
                ax.set_ylabel(example.class_name)
            if row == 0:
                ax.set_title(columns[column], fontsize=9)
            ax.set_xticks([])
            ax.set_yticks([])
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110)
    plt.close(fig)
    return buffer.getvalue()
