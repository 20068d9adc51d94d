"""Inertial properties of a link from its meshes: by a density, or scaled to a given mass.

`link_mass` is for imported assets, whose meshes are often open sheets (PartNet-Mobility's
are): a sheet encloses no volume, and the convex hull of a cabinet's sheets encloses its
cavity too (about ten times the material). So a link's volume comes from the first of:
its meshes' own volume when every one is closed; a voxel fill of its sheets (the sheets
one voxel thick, with whatever they close off filled); its convex hull; a stated default.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from articulation.model import Inertial
from homemodel.core.errors import ModelError

if TYPE_CHECKING:
    import trimesh

# Thin or open meshes (a sheet, an unclosed scan) have no trustworthy volume; their
# convex hull is used instead so every link still gets a physically plausible inertia.
_MIN_VOLUME_M3 = 1e-12
# The voxel fill's grid: at least this many voxels across a small link (so a cup's wall is
# not a centimetre thick), and at most this many across a large one (memory and time).
MIN_VOXELS_ACROSS = 24
MAX_VOXELS_ACROSS = 256


def _solid(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    if mesh.is_volume and mesh.volume > _MIN_VOLUME_M3:
        return mesh
    return mesh.convex_hull


def inertial_from_meshes(
    meshes: Sequence[trimesh.Trimesh], *, density_kg_m3: float | None = None, mass_kg: float | None = None
) -> Inertial:
    """Mass properties of the union of `meshes` (each already in the link frame).

    Give exactly one of `density_kg_m3` (mass follows from the volume) or `mass_kg`
    (the mass is spread uniformly over the volume).
    """
    if (density_kg_m3 is None) == (mass_kg is None):
        raise ValueError("give exactly one of density_kg_m3 and mass_kg")
    if not meshes:
        raise ModelError("cannot compute an inertial without meshes")
    # A flat part's hull has no volume and no centre of mass (NaN): it adds nothing.
    solids = [s for s in map(_solid, meshes) if s.volume > _MIN_VOLUME_M3 and np.all(np.isfinite(s.center_mass))]
    volumes = np.array([s.volume for s in solids])
    total_volume = float(volumes.sum())
    if total_volume <= _MIN_VOLUME_M3:
        raise ModelError(f"meshes enclose no volume ({total_volume:.3g} m^3)")
    density = density_kg_m3 if density_kg_m3 is not None else float(mass_kg) / total_volume
    if density <= 0:
        raise ModelError(f"density must be positive, got {density} kg/m^3")
    mass = density * total_volume
    com = sum(v * s.center_mass for v, s in zip(volumes, solids)) / total_volume
    inertia = np.zeros((3, 3))
    for volume, solid in zip(volumes, solids):
        part_mass = density * volume
        # trimesh gives the tensor per unit density about the part's own centre of mass;
        # the parallel-axis theorem moves it to the link's centre of mass.
        about_own = solid.moment_inertia * density
        d = solid.center_mass - com
        inertia += about_own + part_mass * (np.dot(d, d) * np.eye(3) - np.outer(d, d))
    return Inertial(mass_kg=mass, com_m=com, inertia_kgm2=(inertia + inertia.T) / 2)


@dataclass(kw_only=True)
class LinkMass:
    inertial: Inertial
    method: str  # how the volume was had, said in the repair's line
    volume_m3: float


def _surface_points(triangles: np.ndarray, spacing_m: float) -> np.ndarray:
    """Points on every triangle on a barycentric grid no coarser than `spacing_m` along any
    edge, so neighbouring points are less than a voxel apart and the voxels they fall in
    make a shell with no gaps."""
    edges = np.linalg.norm(triangles - np.roll(triangles, 1, axis=1), axis=2).max(axis=1)
    steps = np.maximum(1, np.ceil(edges / spacing_m)).astype(int)
    points = []
    for n in np.unique(steps):
        i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
        keep = i + j <= n
        a, b = i[keep] / n, j[keep] / n
        weights = np.stack([1 - a - b, a, b], axis=1)  # (K, 3)
        points.append(np.einsum("kv,tvd->tkd", weights, triangles[steps == n]).reshape(-1, 3))
    return np.vstack(points)


def _voxel_fill(mesh: trimesh.Trimesh, pitch_m: float) -> np.ndarray:
    """Centres of the voxels the surface passes through plus those it closes off."""
    from scipy import ndimage

    points = _surface_points(mesh.triangles, pitch_m / 2)
    # Voxel centres on the bounds' centre: a symmetric link fills symmetrically (else its
    # centre of mass moves by half a voxel).
    centre = mesh.bounds.mean(axis=0)
    low = centre - (np.ceil(mesh.extents / 2 / pitch_m) + 1.5) * pitch_m
    index = np.floor((points - low) / pitch_m).astype(np.int64)
    grid = np.zeros(index.max(axis=0) + 2, dtype=bool)
    grid[tuple(index.T)] = True
    # A 26-connected shell closes a region against the 6-connected flood of the fill.
    filled = ndimage.binary_fill_holes(grid)
    return low + (np.argwhere(filled) + 0.5) * pitch_m


def _inertial_of_points(centres: np.ndarray, cell_mass_kg: float, cell_inertia: float) -> Inertial:
    com = centres.mean(axis=0)
    r = centres - com
    inertia = cell_mass_kg * (np.sum(r * r) * np.eye(3) - r.T @ r) + len(centres) * cell_inertia * np.eye(3)
    return Inertial(mass_kg=cell_mass_kg * len(centres), com_m=com, inertia_kgm2=(inertia + inertia.T) / 2)


def default_inertial(mass_kg: float, size_m: float, centre: np.ndarray) -> Inertial:
    """A solid cube of `size_m` and `mass_kg` centred on `centre`."""
    moment = mass_kg * size_m**2 / 6.0
    return Inertial(mass_kg=mass_kg, com_m=centre, inertia_kgm2=np.eye(3) * moment)


def link_mass(
    meshes: Sequence[trimesh.Trimesh],
    *,
    density_kg_m3: float,
    voxel_size_m: float,
    default_mass_kg: float,
    default_size_m: float,
) -> LinkMass:
    """Mass properties of a link's meshes (in the link frame) at `density_kg_m3`, never NaN:
    closed meshes by their volume, open sheets by a voxel fill at up to `voxel_size_m`, else
    the convex hull, else a cube of `default_size_m` and `default_mass_kg`."""
    import trimesh

    parts = [m.copy() for m in meshes if len(m.faces) and np.all(np.isfinite(m.vertices)) and m.area > 0]
    for part in parts:
        part.merge_vertices()  # an STL repeats each corner per triangle: closed only once merged
    if not parts:
        centre = np.zeros(3)
        if meshes and all(np.all(np.isfinite(m.vertices)) and len(m.vertices) for m in meshes):
            centre = trimesh.util.concatenate(list(meshes)).bounds.mean(axis=0)
        return LinkMass(
            inertial=default_inertial(default_mass_kg, default_size_m, centre),
            method=f"no surface to measure: the stated default {default_mass_kg:g} kg, a {default_size_m:g} m cube",
            volume_m3=0.0,
        )
    if all(m.is_volume and m.volume > _MIN_VOLUME_M3 for m in parts):
        inertial = inertial_from_meshes(parts, density_kg_m3=density_kg_m3)
        volume = inertial.mass_kg / density_kg_m3
        return LinkMass(inertial=inertial, method=f"its closed meshes' volume ({volume:.4g} m^3)", volume_m3=volume)
    whole = trimesh.util.concatenate(parts)
    extent = float(np.max(whole.extents))
    pitch = min(voxel_size_m, extent / MIN_VOXELS_ACROSS)
    pitch = max(pitch, extent / MAX_VOXELS_ACROSS)
    if pitch > 0 and math.isfinite(pitch):
        centres = _voxel_fill(whole, pitch)
        cell_mass = density_kg_m3 * pitch**3
        volume = len(centres) * pitch**3
        return LinkMass(
            inertial=_inertial_of_points(centres, cell_mass, cell_mass * pitch**2 / 6.0),
            method=f"a voxel fill of its open meshes at {pitch * 1000:.3g} mm (the sheets that thick, "
            f"what they close off filled: {volume:.4g} m^3)",
            volume_m3=volume,
        )
    hull = whole.convex_hull
    if hull.volume > _MIN_VOLUME_M3:
        inertial = inertial_from_meshes([hull], density_kg_m3=density_kg_m3)
        return LinkMass(inertial=inertial, method=f"its convex hull ({hull.volume:.4g} m^3)", volume_m3=float(hull.volume))
    centre = whole.bounds.mean(axis=0)
    return LinkMass(
        inertial=default_inertial(default_mass_kg, default_size_m, centre),
        method=f"no volume to measure: the stated default {default_mass_kg:g} kg, a {default_size_m:g} m cube",
        volume_m3=0.0,
    )
