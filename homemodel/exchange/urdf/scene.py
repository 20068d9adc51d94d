"""A scene as one URDF (`scene.urdf`) or one glTF (`scene.glb`): every object's links,
joints, grasp points and materials renamed by its object id, under a root link `world` with
the floor and walls.

URDF has one root and no free bodies, so here small objects are fixed where the map puts
them (MJCF, SDF and USD make them free), and URDF has no initial joint position, so the
scene's joint positions go into the `<homemodel>` extension as `initial_position`
elements. The glTF shows the scene's state: each joint's position is baked into its node
transform (its origin moves by the position and its limits shift by it).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import trimesh
from lxml import etree

from articulation.model import Box, Collision, GraspPoint, Joint, JointState, Link, Material, Model, Visual
from articulation.scene import Scene, SceneObject
from homemodel.core.atomic import write_bytes_atomic, write_text_atomic
from homemodel.exchange.gltf import glb_bytes
from homemodel.exchange.numbers import fixed
from homemodel.exchange.urdf.write import urdf_bytes

WORLD_LINK = "world"
FLOOR_THICKNESS_M = 0.05
FLOOR_MARGIN_M = 1.0
FLOOR_MATERIAL = Material(name="floor", rgba=(0.76, 0.72, 0.66, 1.0))
WALL_MATERIAL = Material(name="wall", rgba=(0.93, 0.92, 0.88, 1.0))


def floor_box(scene: Scene) -> tuple[np.ndarray, tuple[float, float, float]]:
    """`world_from_floor` and the size of a floor slab under the whole scene, top at z = 0."""
    points = [obj.world_from_model[:2, 3] for obj in scene.objects]
    for obj in scene.objects:
        bounds = obj.model.world_mesh().bounds
        corners = np.array([[x, y, 0, 1] for x in bounds[:, 0] for y in bounds[:, 1]])
        points.extend((corners @ obj.world_from_model.T)[:, :2])
    for wall in scene.walls:
        points.extend([wall.start_xy, wall.end_xy])
    low, high = np.min(points, axis=0) - FLOOR_MARGIN_M, np.max(points, axis=0) + FLOOR_MARGIN_M
    world_from_floor = np.eye(4)
    world_from_floor[:3, 3] = [*((low + high) / 2), -FLOOR_THICKNESS_M / 2]
    return world_from_floor, (float(high[0] - low[0]), float(high[1] - low[1]), FLOOR_THICKNESS_M)


def _box_link(name: str, size: tuple[float, float, float], material: Material) -> Link:
    mesh = trimesh.creation.box(extents=size)
    return Link(
        name=name,
        visuals=[Visual(name=name, mesh=mesh, material=material)],
        collisions=[Collision(name=name, geometry=Box(size_m=size))],
    )


def _renamed(obj: SceneObject, *, bake_states: bool) -> tuple[list[Link], list[Joint], list[GraspPoint]]:
    links = [
        dataclasses.replace(
            link,
            name=obj.name(link.name),
            visuals=[
                dataclasses.replace(v, material=dataclasses.replace(v.material, name=obj.name(v.material.name)))
                for v in link.visuals
            ],
        )
        for link in obj.model.links
    ]
    joints = []
    for j in obj.model.joints:
        q = obj.position(j.name) if bake_states and j.is_movable else 0.0
        limits = j.limits
        if q and limits is not None:
            limits = dataclasses.replace(limits, lower=limits.lower - q, upper=limits.upper - q)
        joints.append(
            dataclasses.replace(
                j,
                name=obj.name(j.name),
                parent=obj.name(j.parent),
                child=obj.name(j.child),
                parent_from_joint=j.parent_from_joint @ j.joint_from_child(q),
                limits=limits,
                states=[JointState(name=s.name, position=s.position - q) for s in j.states],
            )
        )
    grasps = [dataclasses.replace(g, name=obj.name(g.name), link=obj.name(g.link)) for g in obj.model.grasp_points]
    return links, joints, grasps


def combined_model(scene: Scene, *, bake_states: bool = False) -> Model:
    """The scene as one model rooted at `world` (see the module's note)."""
    world_from_floor, floor_size = floor_box(scene)
    links: list[Link] = [Link(name=WORLD_LINK)]
    joints: list[Joint] = []
    grasps: list[GraspPoint] = []
    statics = [("floor", world_from_floor, floor_size, FLOOR_MATERIAL)] if scene.floor else []
    statics += [(w.name, w.world_from_wall(), w.size_m, WALL_MATERIAL) for w in scene.walls]
    for name, world_from_static, size, material in statics:
        links.append(_box_link(name, size, material))
        joints.append(Joint(name=f"{name}_fixed", type="fixed", parent=WORLD_LINK, child=name, parent_from_joint=world_from_static))
    for obj in scene.objects:
        obj_links, obj_joints, obj_grasps = _renamed(obj, bake_states=bake_states)
        links += obj_links
        joints += obj_joints
        grasps += obj_grasps
        joints.append(
            Joint(
                name=obj.name("placed"),
                type="fixed",
                parent=WORLD_LINK,
                child=obj.name(obj.model.root_link),
                parent_from_joint=obj.world_from_model,
            )
        )
    return Model(name=scene.name, links=links, joints=joints, grasp_points=grasps, category="scene")


def write_scene_urdf(scene: Scene, folder: Path) -> Path:
    folder = Path(folder)
    robot = etree.fromstring(urdf_bytes(combined_model(scene), folder))
    extension = robot.find("homemodel")
    for obj in scene.objects:
        for j in obj.model.movable_joints:
            etree.SubElement(extension, "initial_position", joint=obj.name(j.name), position=fixed(obj.position(j.name)))
    path = folder / "scene.urdf"
    text = etree.tostring(robot, pretty_print=True, xml_declaration=True, encoding="utf-8").decode("utf-8")
    write_text_atomic(path, text)
    return path


def write_scene_glb(scene: Scene, folder: Path) -> Path:
    path = Path(folder) / "scene.glb"
    write_bytes_atomic(path, glb_bytes(combined_model(scene, bake_states=True)))
    return path

