"""Write a scene as MuJoCo MJCF (`scene.xml`), by our own writer rather than MuJoCo's URDF
import, whose behaviour changes between versions.

- Meshes are OBJ files under `meshes/<object id>/` (`scene_meshes`), named by their path
  relative to the XML (no `meshdir`), so the saved file loads from any working directory;
  photo textures become PNG textures and materials.
- Visual geoms (group 2) never collide; collision geoms (group 3) carry the contacts; only
  the collision group counts for inertia where a body has no `<inertial>`. The floor and
  walls (group 0) both show and collide.
- Each body is written at its joint's position and the joint's `ref` is that position, so
  `qpos0` is the scene's state (the map's joint states) and the limits keep their meaning.
- A part never collides with the rigid body it is hinged to: MuJoCo filters parent/child
  pairs only away from the world, and a fixed appliance body is welded to the world.
- Joints get damping and friction (`frictionloss`) from `joint_physics`, which hold every
  door against gravity; knobs (joints with named states that turn a knob grasp point) get a
  position actuator named after the joint, and every named state of any joint is a keyframe
  `<joint>=<state>`. The keyframe `initial` holds the scene's state with the actuators'
  targets on it.
- A free object gets a `<freejoint>`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from lxml import etree

from articulation.convex_parts import as_convex_hull
from articulation.export_dynamics import actuator_effort, export_dynamics
from articulation.joint_loads import subtree_links
from articulation.model import Box, Cylinder, Joint, JointState, Link, MeshGeometry, Model, Sphere
from articulation.scene import Scene, SceneObject
from homemodel.core.atomic import write_text_atomic
from homemodel.exchange.gltf import quaternion_xyzw
from homemodel.exchange.numbers import fixed, fixed_list, significant
from homemodel.exchange.scene_meshes import SceneMeshes

SCENE_FILE = "scene.xml"
VISUAL_GROUP, COLLISION_GROUP = 2, 3
TIMESTEP_S = 0.002
# Small rotor inertia on every joint: keeps 10 g knobs stable at a 2 ms step.
ARMATURE = {"revolute": 1e-3, "continuous": 1e-3, "prismatic": 1e-2}
FRICTION_SOLREF, FRICTION_SOLIMP = "0.004 1", "0.99 0.999 0.001"
# Position actuators reach a target within this (rad or m) against the joint's friction.
ACTUATOR_TOLERANCE = 0.005


def _pos_quat(element: etree._Element, a_from_b: np.ndarray) -> None:
    x, y, z, w = quaternion_xyzw(a_from_b[:3, :3])
    element.set("pos", fixed_list(a_from_b[:3, 3]))
    element.set("quat", fixed_list((w, x, y, z), 9))


def turns_a_knob(model: Model, joint: Joint) -> bool:
    """Whether `joint` moves a knob grasp point. Knobs get a position actuator; a door, even
    one with named states, stays passive: at a reset MuJoCo zeroes every control, and a
    position actuator would then pull the door shut."""
    moved = set(subtree_links(model, joint))
    return any(g.kind == "knob" and g.link in moved for g in model.grasp_points)


def rigid_groups(obj: SceneObject) -> dict[str, frozenset[str]]:
    """Each link's rigid group: the links joined to it by fixed joints (one MuJoCo weld)."""
    group = {link.name: {link.name} for link in obj.model.links}
    for j in obj.model.joints:
        if j.type == "fixed":
            merged = group[j.parent] | group[j.child]
            for name in merged:
                group[name] = merged
    return {name: frozenset(members) for name, members in group.items()}


class _Writer:
    """Fills the sections of one MJCF document, keeping the `qpos0` it implies (joints in
    body order, as MuJoCo numbers them) for the keyframes."""

    def __init__(self, meshes: SceneMeshes, mujoco: etree._Element) -> None:
        self.meshes = meshes
        self.asset = etree.SubElement(mujoco, "asset")
        self.world = etree.SubElement(mujoco, "worldbody")
        self.contact = etree.SubElement(mujoco, "contact")
        self.actuator = etree.SubElement(mujoco, "actuator")
        self.qpos0: list[float] = []
        # (scoped joint name, qpos index, named states) of each joint with named states, and
        # of those with a position actuator
        self.stated: list[tuple[str, int, list[JointState]]] = []
        self.actuated: list[tuple[str, int, list[JointState]]] = []

    def mesh_asset(self, obj: SceneObject, stem: str, mesh, uv=None, *, visual: bool = False) -> str:
        name, relative = self.meshes.write(obj, stem, mesh, uv)
        asset = etree.SubElement(self.asset, "mesh", name=name, file=relative)
        if visual:
            # MuJoCo computes every mesh's inertia, and refuses a flat one (a photo on a face)
            # as a solid; visuals count for no inertia here anyway (inertiagrouprange).
            asset.set("inertia", "shell")
        return name

    def textured_material(self, obj: SceneObject, visual) -> str:
        """An MJCF material showing the visual's texture image (its colour's alpha kept)."""
        texture, relative = self.meshes.texture(obj, visual.material.texture)
        if self.asset.find(f"texture[@name='{texture}']") is None:
            etree.SubElement(self.asset, "texture", name=texture, type="2d", file=relative)
            etree.SubElement(self.asset, "material", name=texture, texture=texture, rgba=f"1 1 1 {fixed(visual.material.rgba[3])}")
        return texture

    def link_geoms(self, body: etree._Element, obj: SceneObject, link: Link) -> None:
        if link.inertial is not None:
            inertia = link.inertial.inertia_kgm2
            etree.SubElement(
                body,
                "inertial",
                pos=fixed_list(link.inertial.com_m),
                mass=significant(link.inertial.mass_kg),
                fullinertia=" ".join(
                    significant(v)
                    for v in (inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2])
                ),
            )
        for visual in link.visuals:
            textured = visual.material.texture is not None and visual.uv is not None
            mesh = self.mesh_asset(obj, f"{link.name}_{visual.name}", visual.mesh, visual.uv if textured else None, visual=True)
            geom = etree.SubElement(
                body, "geom", name=mesh, type="mesh", mesh=mesh, group=str(VISUAL_GROUP), contype="0", conaffinity="0"
            )
            if textured:
                geom.set("material", self.textured_material(obj, visual))
            else:
                geom.set("rgba", fixed_list(visual.material.rgba))
            _pos_quat(geom, visual.link_from_visual)
        for collision in link.collisions:
            name = self.meshes.name(obj, f"{link.name}_{collision.name}_collision")
            geom = etree.SubElement(body, "geom", name=name, group=str(COLLISION_GROUP), rgba="0.5 0.5 0.9 0.4")
            shape = collision.geometry
            if isinstance(shape, Box):
                geom.set("type", "box")
                geom.set("size", fixed_list(np.asarray(shape.size_m) / 2))
            elif isinstance(shape, Cylinder):
                geom.set("type", "cylinder")
                geom.set("size", fixed_list((shape.radius_m, shape.length_m / 2)))
            elif isinstance(shape, Sphere):
                geom.set("type", "sphere")
                geom.set("size", fixed(shape.radius_m))
            elif isinstance(shape, MeshGeometry):
                geom.set("type", "mesh")
                geom.set("mesh", self.mesh_asset(obj, f"{link.name}_{collision.name}_hull", as_convex_hull(shape.mesh)))
            _pos_quat(geom, collision.link_from_collision)

    def joint(self, body: etree._Element, obj: SceneObject, joint: Joint) -> None:
        name = obj.name(joint.name)
        q = obj.position(joint.name)
        dynamics = export_dynamics(obj.model, joint, gravity_model=obj.gravity_model)
        el = etree.SubElement(
            body,
            "joint",
            name=name,
            type="slide" if joint.type == "prismatic" else "hinge",
            axis=fixed_list(joint.axis / np.linalg.norm(joint.axis), 9),
            ref=fixed(q, 9),
            damping=significant(dynamics.damping),
            frictionloss=significant(dynamics.friction),
            armature=significant(ARMATURE[joint.type]),
            # MuJoCo's friction is a soft constraint; at its default softness a held door creeps.
            solreffriction=FRICTION_SOLREF,
            solimpfriction=FRICTION_SOLIMP,
        )
        if joint.type != "continuous" and joint.limits is not None:
            el.set("limited", "true")
            el.set("range", fixed_list((joint.limits.lower, joint.limits.upper), 9))
        index = len(self.qpos0)
        self.qpos0.append(q)
        if joint.states:
            self.stated.append((name, index, joint.states))
        if joint.states and turns_a_knob(obj.model, joint):
            effort = actuator_effort(obj.model, joint, dynamics)
            # Stiff enough that the friction (which already holds gravity) leaves at most a
            # quarter of ACTUATOR_TOLERANCE of error; no stiffer, so a 10 g knob stays stable.
            kp = 4.0 * dynamics.friction / ACTUATOR_TOLERANCE
            actuator = etree.SubElement(
                self.actuator,
                "position",
                name=name,
                joint=name,
                kp=significant(kp),
                dampratio="1",
                forcelimited="true",
                forcerange=f"-{significant(effort + dynamics.friction)} {significant(effort + dynamics.friction)}",
            )
            if el.get("range"):
                actuator.set("ctrlrange", el.get("range"))
                actuator.set("ctrllimited", "true")
            self.actuated.append((name, index, joint.states))

    def body_tree(self, parent_el: etree._Element, obj: SceneObject, link_name: str) -> None:
        model = obj.model
        for j in (j for j in model.joints if j.parent == link_name):
            body = etree.SubElement(parent_el, "body", name=obj.name(j.child))
            _pos_quat(body, j.parent_from_joint @ j.joint_from_child(obj.position(j.name)))
            if j.is_movable:
                self.joint(body, obj, j)
            self.link_geoms(body, obj, model.link(j.child))
            self.body_tree(body, obj, j.child)

    def exclusions(self, obj: SceneObject) -> None:
        groups = rigid_groups(obj)
        for j in obj.model.movable_joints:
            for other in sorted(groups[j.parent]):
                etree.SubElement(self.contact, "exclude", body1=obj.name(other), body2=obj.name(j.child))

    def object(self, obj: SceneObject) -> None:
        model = obj.model
        root = etree.SubElement(self.world, "body", name=obj.name(model.root_link))
        _pos_quat(root, obj.world_from_model)
        if obj.free:
            etree.SubElement(root, "freejoint", name=obj.name("free"))
            x, y, z, w = quaternion_xyzw(obj.world_from_model[:3, :3])
            self.qpos0.extend([*obj.world_from_model[:3, 3], w, x, y, z])
        self.link_geoms(root, obj, model.link(model.root_link))
        self.body_tree(root, obj, model.root_link)
        self.exclusions(obj)

    def keyframes(self, mujoco: etree._Element) -> None:
        keys = etree.SubElement(mujoco, "keyframe")
        ctrl0 = [self.qpos0[index] for _, index, _ in self.actuated]

        def key(name: str, qpos: list[float], ctrl: list[float]) -> None:
            el = etree.SubElement(keys, "key", name=name, qpos=fixed_list(qpos, 9))
            if ctrl:
                el.set("ctrl", fixed_list(ctrl, 9))

        key("initial", self.qpos0, ctrl0)
        for joint_name, index, states in self.stated:
            for state in states:
                qpos = list(self.qpos0)
                qpos[index] = state.position
                ctrl = [state.position if name == joint_name else c for (name, _, _), c in zip(self.actuated, ctrl0)]
                key(f"{joint_name}={state.name}", qpos, ctrl)


def _environment(writer: _Writer, scene: Scene) -> None:
    etree.SubElement(writer.world, "light", name="sun", directional="true", pos="0 0 5", dir="-0.3 -0.2 -1", diffuse="0.7 0.7 0.7")
    etree.SubElement(writer.world, "light", name="fill", directional="true", pos="0 0 5", dir="0.3 0.4 -1", diffuse="0.3 0.3 0.3")
    if scene.floor:
        etree.SubElement(writer.asset, "texture", name="floor_tiles", type="2d", builtin="checker", width="256", height="256",
                         rgb1="0.78 0.74 0.68", rgb2="0.7 0.66 0.6")
        etree.SubElement(writer.asset, "material", name="floor", texture="floor_tiles", texrepeat="8 8", texuniform="true")
        etree.SubElement(writer.world, "geom", name="floor", type="plane", size="0 0 0.05", material="floor")
    for wall in scene.walls:
        geom = etree.SubElement(writer.world, "geom", name=wall.name, type="box", size=fixed_list(np.asarray(wall.size_m) / 2),
                                rgba="0.93 0.92 0.88 1")
        _pos_quat(geom, wall.world_from_wall())


def mjcf_bytes(scene: Scene, folder: Path) -> bytes:
    """The MJCF document of `scene`; writes its meshes under `folder/meshes/`."""
    mujoco = etree.Element("mujoco", model=scene.name)
    etree.SubElement(mujoco, "compiler", angle="radian", autolimits="true", inertiagrouprange=f"{COLLISION_GROUP} {COLLISION_GROUP}")
    option = etree.SubElement(mujoco, "option", timestep=str(TIMESTEP_S), integrator="implicitfast")
    # Several contact points between convex shapes: a cup stands on a table instead of rocking
    # on one point (MuJoCo 3.3 let the kitchen's cups creep 3 mm in 4 s without it, 0.1 mm with).
    etree.SubElement(option, "flag", multiccd="enable")
    visual = etree.SubElement(mujoco, "visual")
    etree.SubElement(visual, "global", offwidth="1280", offheight="960")
    etree.SubElement(visual, "quality", shadowsize="4096")
    writer = _Writer(SceneMeshes(folder), mujoco)
    _environment(writer, scene)
    for obj in scene.objects:
        writer.object(obj)
    writer.keyframes(mujoco)
    for section in (writer.contact, writer.actuator):
        if len(section) == 0:
            mujoco.remove(section)
    return etree.tostring(mujoco, pretty_print=True, xml_declaration=True, encoding="utf-8")


def write_mjcf(scene: Scene, folder: Path) -> Path:
    path = Path(folder) / SCENE_FILE
    write_text_atomic(path, mjcf_bytes(scene, folder).decode("utf-8"))
    return path
