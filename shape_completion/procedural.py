"""A procedural class library: varied cups and mugs, bottles, glasses, bowls and spoons.

Every instance is a triangle mesh in metres, z up, standing on z = 0 and centred on the
z axis, so the completion pipeline works out of the box. Vessels are revolved profiles
with real wall thickness (an open cup has a cavity, as in Rock et al.'s data); a mug adds a
swept handle; a spoon is a flat ellipsoid bowl on a bent handle.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import trimesh

SECTIONS = 40


def _revolved(profile_rz: list[tuple[float, float]]) -> trimesh.Trimesh:
    """The solid of revolution of a closed (radius, z) profile about the z axis."""
    points = np.asarray(profile_rz + [profile_rz[0]], dtype=np.float64)
    mesh = trimesh.creation.revolve(points, sections=SECTIONS)
    if mesh.volume < 0:
        mesh.invert()
    return mesh


def _vessel(*, radius_bottom: float, radius_top: float, height: float, wall: float, base: float) -> trimesh.Trimesh:
    """An open vessel: a tapered wall of thickness `wall` on a base of thickness `base`."""
    return _revolved(
        [
            (0.0, 0.0),
            (radius_bottom, 0.0),
            (radius_top, height),
            (radius_top - wall, height),
            (radius_bottom - wall, base),
            (0.0, base),
        ]
    )


def _tube_along(path: np.ndarray, radius: float, sides: int = 12) -> trimesh.Trimesh:
    """A closed tube of circular section swept along a polyline in the xz plane."""
    tangents = np.gradient(path, axis=0)
    tangents /= np.linalg.norm(tangents, axis=1, keepdims=True)
    binormal = np.array([0.0, 1.0, 0.0])
    normals = np.cross(binormal, tangents)
    angles = np.linspace(0, 2 * np.pi, sides, endpoint=False)
    rings = path[:, None, :] + radius * (
        np.cos(angles)[None, :, None] * normals[:, None, :] + np.sin(angles)[None, :, None] * binormal
    )
    vertices = np.concatenate([rings.reshape(-1, 3), path[[0, -1]]])
    faces = []
    n = len(path)
    for i in range(n - 1):
        for j in range(sides):
            a, b = i * sides + j, i * sides + (j + 1) % sides
            faces += [[a, b, b + sides], [a, b + sides, a + sides]]
    start, end = len(vertices) - 2, len(vertices) - 1
    for j in range(sides):
        faces.append([start, (j + 1) % sides, j])
        faces.append([end, (n - 1) * sides + j, (n - 1) * sides + (j + 1) % sides])
    mesh = trimesh.Trimesh(vertices, np.asarray(faces), process=True)
    if mesh.volume < 0:
        mesh.invert()
    return mesh


def cup(rng: np.random.Generator) -> trimesh.Trimesh:
    """A cup or a mug: a slightly tapered open cylinder, with a handle three times in four."""
    height = rng.uniform(0.07, 0.12)
    radius_bottom = rng.uniform(0.028, 0.042)
    radius_top = radius_bottom * rng.uniform(1.0, 1.25)
    wall = rng.uniform(0.003, 0.006)
    body = _vessel(radius_bottom=radius_bottom, radius_top=radius_top, height=height, wall=wall, base=0.006)
    if rng.uniform() < 0.25:
        return body
    # The handle: a D-shaped arc from near the rim to near the base, out of the wall at +x.
    span = height * rng.uniform(0.5, 0.75)
    reach = rng.uniform(0.018, 0.03)
    centre_z = height * rng.uniform(0.45, 0.55)
    t = np.linspace(-np.pi / 2, np.pi / 2, 16)
    wall_radius = 0.5 * (radius_bottom + radius_top) - 0.5 * wall
    path = np.stack([wall_radius + reach * np.cos(t), np.zeros_like(t), centre_z + 0.5 * span * np.sin(t)], axis=1)
    handle = _tube_along(path, radius=rng.uniform(0.004, 0.007))
    return trimesh.util.concatenate([body, handle])


def glass(rng: np.random.Generator) -> trimesh.Trimesh:
    """A drinking glass: tall, thin-walled, wider at the top, on a thick base."""
    height = rng.uniform(0.09, 0.15)
    radius_bottom = rng.uniform(0.022, 0.032)
    radius_top = radius_bottom * rng.uniform(1.1, 1.4)
    return _vessel(
        radius_bottom=radius_bottom,
        radius_top=radius_top,
        height=height,
        wall=rng.uniform(0.002, 0.003),
        base=rng.uniform(0.008, 0.02),
    )


def bowl(rng: np.random.Generator) -> trimesh.Trimesh:
    """A bowl: a curved open profile from a foot to a wide rim."""
    radius = rng.uniform(0.06, 0.09)
    height = radius * rng.uniform(0.45, 0.7)
    foot = radius * rng.uniform(0.35, 0.5)
    wall = rng.uniform(0.003, 0.006)
    exponent = rng.uniform(0.45, 0.7)  # how round the side is: 0.5 is close to a sphere
    s = np.linspace(0.0, 1.0, 12)
    outer = [(foot + (radius - foot) * si**exponent, height * si) for si in s]
    inner = [(max(r - wall, 0.0), max(z, wall)) for r, z in reversed(outer)]
    return _revolved([(0.0, 0.0)] + outer + inner + [(0.0, wall)])


def bottle(rng: np.random.Generator) -> trimesh.Trimesh:
    """A closed bottle: a cylindrical body, a shoulder, a neck and a cap."""
    radius = rng.uniform(0.025, 0.045)
    body = rng.uniform(0.12, 0.2)
    shoulder = rng.uniform(0.03, 0.06)
    neck_radius = rng.uniform(0.011, 0.016)
    neck = rng.uniform(0.025, 0.05)
    s = np.linspace(0.0, 1.0, 8)[1:]
    shoulder_curve = [
        (neck_radius + (radius - neck_radius) * np.cos(0.5 * np.pi * si), body + shoulder * si) for si in s
    ]
    top = body + shoulder + neck
    return _revolved([(0.0, 0.0), (radius, 0.0), (radius, body)] + shoulder_curve + [(neck_radius, top), (0.0, top)])


def spoon(rng: np.random.Generator) -> trimesh.Trimesh:
    """A spoon lying on the table: a flat ellipsoid bowl and a handle bent up to its end."""
    bowl_length = rng.uniform(0.035, 0.06)
    bowl_width = bowl_length * rng.uniform(0.55, 0.75)
    thickness = rng.uniform(0.008, 0.014)
    head = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    head.apply_scale([bowl_length / 2, bowl_width / 2, thickness / 2])
    head.apply_translation([0.0, 0.0, thickness / 2])
    handle_length = rng.uniform(0.1, 0.15)
    lift = rng.uniform(0.005, 0.02)
    t = np.linspace(0.0, 1.0, 10)
    path = np.stack([bowl_length * 0.4 + handle_length * t, np.zeros_like(t), thickness / 2 + lift * t**2], axis=1)
    handle = _tube_along(path, radius=rng.uniform(0.003, 0.005), sides=8)
    handle.apply_scale([1.0, 2.0, 0.8])  # a flat handle
    handle.apply_translation([0.0, 0.0, thickness / 2 * 0.2])
    mesh = trimesh.util.concatenate([head, handle])
    mesh.apply_translation([-mesh.bounds.mean(axis=0)[0], 0.0, -mesh.bounds[0, 2]])
    return mesh


GENERATORS: dict[str, Callable[[np.random.Generator], trimesh.Trimesh]] = {
    "cup": cup,
    "bottle": bottle,
    "glass": glass,
    "bowl": bowl,
    "spoon": spoon,
}


def generate_instances(class_name: str, count: int, *, seed: int = 0) -> list[trimesh.Trimesh]:
    """`count` varied instances of a class of `GENERATORS`, reproducible with `seed`."""
    if class_name not in GENERATORS:
        raise ValueError(f"{class_name=} but expected one of {sorted(GENERATORS)}")
    # Each class has its own stream, so adding a class never changes another's instances.
    rng = np.random.default_rng([seed, sorted(GENERATORS).index(class_name)])
    return [GENERATORS[class_name](rng) for _ in range(count)]
