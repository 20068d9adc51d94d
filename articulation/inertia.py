"""Inertial properties of a link from its meshes: by a density, or scaled to a given mass."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import trimesh

from articulation.model import Inertial
from homemodel.core.errors import ModelError

# Thin or open meshes (a sheet, an unclosed scan) have no trustworthy volume; their
# convex hull is used instead so every link still gets a physically plausible inertia.
_MIN_VOLUME_M3 = 1e-12


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
    solids = [_solid(m) for m in meshes]
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
