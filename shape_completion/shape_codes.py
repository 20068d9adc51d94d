"""Each training view's shape as a few hidden shape features (Rock et al.'s matching targets).

A view's shape is the object's solid occupancy on a small cube grid aligned with that
view's camera (so it encodes the shape and the viewpoint), centred on the object and
scaled to its bounding sphere. Non-negative matrix factorisation of all views' grids gives
a basis of hidden shape features; a view's code is its non-negative least-squares
coefficients on that basis, as in the paper.
"""

from __future__ import annotations

import warnings

import numpy as np
import trimesh
from scipy.optimize import nnls

from homemodel.evaluation.voxels import VoxelGrid, solid_occupancy

VIEW_GRID = 16
FINE_GRID = 48


class ObjectOccupancy:
    """A fine solid occupancy of one mesh in its own frame, to resample in any view frame."""

    def __init__(self, mesh: trimesh.Trimesh) -> None:
        self.centre_m = mesh.bounds.mean(axis=0)
        self.radius_m = float(np.linalg.norm(mesh.extents)) / 2
        voxel = 2 * self.radius_m / FINE_GRID
        self.grid = VoxelGrid(origin_m=self.centre_m - self.radius_m, voxel_size_m=voxel, shape=(FINE_GRID,) * 3)
        self.occupancy = solid_occupancy(mesh, self.grid)

    def in_view(self, camera_from_object: np.ndarray) -> np.ndarray:
        """Flattened VIEW_GRID^3 occupancy on a cube aligned with the camera's axes."""
        steps = (np.arange(VIEW_GRID) + 0.5) / VIEW_GRID * 2 - 1
        cube = np.stack(np.meshgrid(steps, steps, steps, indexing="ij"), -1).reshape(-1, 3) * self.radius_m
        # Cube axes are the camera's: rotate them into the object frame about the object's centre.
        points = cube @ camera_from_object[:3, :3] + self.centre_m
        index = self.grid.index_of(points)
        inside = self.grid.holds(index)
        values = np.zeros(len(points), dtype=bool)
        values[inside] = self.occupancy[tuple(index[inside].T)]
        return values


class ShapeBasis:
    """NMF basis of view occupancies; codes by non-negative least squares."""

    def __init__(self, *, n_components: int, random_state: int) -> None:
        self.n_components = n_components
        self.random_state = random_state

    def fit(self, occupancies: np.ndarray) -> ShapeBasis:
        from sklearn.decomposition import NMF
        from sklearn.exceptions import ConvergenceWarning

        # NNDSVD starts from an SVD, which has at most min(views, voxels) components: a small
        # library (one class of two meshes, few views) asks for more than that.
        components = min(self.n_components, *occupancies.shape)
        nmf = NMF(n_components=components, init="nndsvda", max_iter=200, random_state=self.random_state)
        with warnings.catch_warnings():
            # A basis short of full convergence is still a basis: the codes come from NNLS on it.
            warnings.simplefilter("ignore", ConvergenceWarning)
            nmf.fit(occupancies.astype(np.float64))
        self.components_ = nmf.components_
        return self

    def codes(self, occupancies: np.ndarray) -> np.ndarray:
        basis = self.components_.T
        return np.stack([nnls(basis, row.astype(np.float64))[0] for row in occupancies])
