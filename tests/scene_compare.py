"""What a format carries of a model or scene, compared after a write and a read: the readers'
round trips (test_exchange_readers) and every catalogue model's exports (test_simulator_export)."""

from __future__ import annotations

import numpy as np

from articulation.export_dynamics import export_dynamics
from articulation.model import Box
from articulation.scene import Scene, SceneObject

# Our writers keep 6 decimals (MJCF, SDF) or float32 (USD); the real clients' files 6 digits.
TOLERANCE = {"mjcf": 2e-6, "sdf": 2e-6, "usd": 2e-5, "saved": 2e-4}
# Masses, inertias, efforts, damping and friction are written to 6 significant digits.
SIGNIFICANT = 1e-5


def near(a, b, tolerance: float, what: str) -> None:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape and np.allclose(a, b, atol=tolerance, rtol=tolerance), f"{what}: {a} != {b}"


def assert_same_model(original: SceneObject, read: SceneObject, fmt: str, tolerance: float) -> None:
    """What the format carries of `original` is in `read`, within `tolerance`."""
    model, back = original.model, read.model
    assert {link.name for link in back.links} == {link.name for link in model.links}
    assert len(back.joints) == len(model.joints)
    for joint in model.joints:
        if not joint.is_movable:  # MJCF has no name for a fixed joint
            match = [j for j in back.joints if j.child == joint.child]
            assert len(match) == 1 and match[0].type == "fixed" and match[0].parent == joint.parent, joint.name
            near(match[0].parent_from_joint, joint.parent_from_joint, tolerance, f"{joint.name} origin")
            continue
        other = back.joint(joint.name)
        assert (other.type, other.parent, other.child) == (joint.type, joint.parent, joint.child), joint.name
        near(other.axis / np.linalg.norm(other.axis), joint.axis / np.linalg.norm(joint.axis), tolerance, f"{joint.name} axis")
        near(other.parent_from_joint, joint.parent_from_joint, tolerance, f"{joint.name} origin")
        if joint.type != "continuous":
            near([other.limits.lower, other.limits.upper], [joint.limits.lower, joint.limits.upper], tolerance, f"{joint.name} limits")
            if fmt != "mjcf":  # MJCF has no effort limit
                near(other.limits.effort, joint.limits.effort, max(tolerance, SIGNIFICANT), f"{joint.name} effort")
        written = export_dynamics(model, joint, gravity_model=original.gravity_model)
        near([other.dynamics.damping, other.dynamics.friction], [written.damping, written.friction], max(tolerance, SIGNIFICANT), f"{joint.name} dynamics")
        if fmt != "usd":  # USD has no named states
            assert [s.name for s in other.states] == [s.name for s in joint.states], joint.name
            near([s.position for s in other.states], [s.position for s in joint.states], tolerance, f"{joint.name} states")
        near(read.position(joint.name), original.position(joint.name), tolerance, f"{joint.name} position")
    for link in model.links:
        other = back.link(link.name)
        assert (len(other.visuals), len(other.collisions)) == (len(link.visuals), len(link.collisions)), link.name
        if link.inertial is not None:
            near(other.inertial.mass_kg, link.inertial.mass_kg, max(tolerance, SIGNIFICANT), f"{link.name} mass")
            near(other.inertial.com_m, link.inertial.com_m, tolerance, f"{link.name} centre of mass")
            near(other.inertial.inertia_kgm2, link.inertial.inertia_kgm2, max(tolerance, SIGNIFICANT), f"{link.name} inertia")
        for mine, theirs in zip(link.collisions, other.collisions):
            assert type(theirs.geometry) is type(mine.geometry), link.name
            if isinstance(mine.geometry, Box):
                near(theirs.geometry.size_m, mine.geometry.size_m, tolerance, f"{link.name} box")
            near(theirs.link_from_collision, mine.link_from_collision, tolerance, f"{link.name} collision origin")
        for mine, theirs in zip(link.visuals, other.visuals):
            near(theirs.mesh.bounds, mine.mesh.bounds, tolerance, f"{link.name} visual bounds")
            near(theirs.material.rgba, mine.material.rgba, 1e-6, f"{link.name} colour")
    near(read.world_from_model, original.world_from_model, tolerance, f"{original.id} placement")
    assert read.free == original.free, original.id
    positions = {j.name: original.position(j.name) for j in model.movable_joints}
    near(back.world_mesh(positions).bounds, model.world_mesh(positions).bounds, tolerance, f"{original.id} bounds")


def assert_same_scene(scene: Scene, back: Scene, fmt: str, tolerance: float) -> None:
    by_id = {o.id: o for o in back.objects}
    assert set(by_id) == {o.safe_id for o in scene.objects}
    for obj in scene.objects:
        assert_same_model(obj, by_id[obj.safe_id], fmt, tolerance)
    assert back.floor == scene.floor
    assert sorted(w.name for w in back.walls) == sorted(w.name for w in scene.walls)
    for wall in scene.walls:
        other = next(w for w in back.walls if w.name == wall.name)
        near([*other.start_xy, *other.end_xy, other.height_m, other.thickness_m],
              [*wall.start_xy, *wall.end_xy, wall.height_m, wall.thickness_m], tolerance, wall.name)
