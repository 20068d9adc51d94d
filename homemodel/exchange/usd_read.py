"""Read a USD stage with UsdPhysics (ours, `usd.py`'s, or one another tool authored) back into a
scene.

- The rigid bodies joined by joints form an object; its prim is the bodies' common parent
  (our `/World/<id>`), else the root body. A fixed joint with no body0 holds it to the world;
  without one it is free.
- A joint's local frames give the model's joint: `parent_from_joint = local0 · local1⁻¹` (the
  child's frame at position zero) and the axis is local1's turn of the joint's axis token; the
  scene's joint position is what the bodies' poses show (the frames' offset about the axis).
- Meshes, cubes, spheres and cylinders under a body are its visuals; those with the
  CollisionAPI are its collisions (and visuals too unless their purpose is "guide").
- Damping and friction are our `homemodel:damping`/`homemodel:friction`, else the drive's
  damping; the drive's maxForce is the effort limit.
- Layers the stage composes must lie in the stage's folder.
- A stage in other units (metersPerUnit, kilogramsPerUnit) or y up is converted.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from articulation.model import (
    Box,
    Collision,
    Cylinder,
    Inertial,
    Joint,
    JointDynamics,
    JointLimits,
    Link,
    Material,
    MeshGeometry,
    Sphere,
)
from articulation.scene import Scene
from homemodel.core.c_stdio_capture import captured_c_output
from homemodel.core.errors import InputError, ModelError
from homemodel.core.limits import MESH_TRIANGLES, URDF_LINKS
from homemodel.core.transforms import Y_UP_FROM_Z_UP, translation_transform
from homemodel.exchange.scene_read import (
    ObjectParts,
    joint_motion_position,
    object_prefix,
    part_name,
    read_visual,
    tree_depth,
    reanchor,
    texture_file,
    wall_from_box,
)
from homemodel.geometry.mesh_io import MAX_MESH_BYTES

_AXES = {"X": np.array([1.0, 0.0, 0.0]), "Y": np.array([0.0, 1.0, 0.0]), "Z": np.array([0.0, 0.0, 1.0])}
_GPRIMS = ("Mesh", "Cube", "Sphere", "Cylinder")


def _polar(a_from_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rigid transform, 3x3 stretch) with a_from_b = rigid · stretch: a prim's scale."""
    u, s, vt = np.linalg.svd(a_from_b[:3, :3])
    rotation = u @ vt
    if np.linalg.det(rotation) < 0:
        raise ValueError("a mirroring transform")
    rigid = np.eye(4)
    rigid[:3, :3], rigid[:3, 3] = rotation, a_from_b[:3, 3]
    return rigid, rotation.T @ a_from_b[:3, :3]


class _Stage:
    def __init__(self, path: Path) -> None:
        from pxr import Usd, UsdGeom, UsdPhysics, UsdShade

        self.path = path
        self.Usd, self.UsdGeom, self.UsdPhysics, self.UsdShade = Usd, UsdGeom, UsdPhysics, UsdShade
        if not path.is_file():
            raise InputError(f"{path}: {'not a regular file' if path.exists() else 'no such file'}")
        if path.stat().st_size > MAX_MESH_BYTES:
            raise InputError(f"{path}: larger than the {MAX_MESH_BYTES}-byte bound for a USD stage")
        with captured_c_output((2,)) as said:
            try:
                stage = Usd.Stage.Open(str(path))
            except Exception as exc:  # pxr raises Tf.ErrorException with the parser's report
                first = str(exc).strip().splitlines()
                raise InputError(f"{path}: not a readable USD stage: {first[-1] if first else type(exc).__name__}") from None
        if stage is None:
            raise InputError(f"{path}: not a readable USD stage: {said[-1] if said else 'no stage'}")
        folder = path.parent.resolve()
        for layer in stage.GetUsedLayers():
            real = layer.realPath
            if real and not Path(real).resolve().is_relative_to(folder):
                raise InputError(f"{path}: composes {real}, outside the stage's folder")
        self.stage = stage
        self.metres = float(UsdGeom.GetStageMetersPerUnit(stage))
        kilograms = float(UsdPhysics.GetStageKilogramsPerUnit(stage))
        if not (np.isfinite(self.metres) and self.metres > 0 and np.isfinite(kilograms) and kilograms > 0):
            raise InputError(f"{path}: metersPerUnit {self.metres} or kilogramsPerUnit {kilograms} is not positive")
        self.kilograms = kilograms
        self.world_from_stage = Y_UP_FROM_Z_UP.T if UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y else np.eye(4)
        self.cache = UsdGeom.XformCache(Usd.TimeCode.Default())

    def world_from(self, prim) -> np.ndarray:
        """`world_from_prim` in metres (rotation and scale untouched, translation scaled)."""
        m = np.array(self.cache.GetLocalToWorldTransform(prim), dtype=np.float64).T  # USD is row-vector
        if not np.all(np.isfinite(m)):
            raise InputError(f"{self.path}: prim {prim.GetPath()} has a non-finite transform")
        m[:3, 3] *= self.metres
        return self.world_from_stage @ m

    def attribute(self, prim, name: str, default=None):
        attr = prim.GetAttribute(name)
        value = attr.Get() if attr and attr.HasAuthoredValue() else None
        return default if value is None else value

    def number(self, prim, name: str, default: float) -> float:
        value = float(self.attribute(prim, name, default))
        if not np.isfinite(value) and not np.isinf(default):
            raise InputError(f"{self.path}: {prim.GetPath()}.{name} = {value} is not finite")
        return value

    def vector(self, value, count: int, what: str) -> np.ndarray:
        v = np.array(list(value), dtype=np.float64)
        if v.shape != (count,) or not np.all(np.isfinite(v)):
            raise InputError(f"{self.path}: {what} needs {count} finite numbers")
        return v

    def quat_rotation(self, quat, what: str) -> np.ndarray:
        q = self.vector([quat.GetReal(), *quat.GetImaginary()], 4, what)
        if np.linalg.norm(q) < 1e-12:
            return np.eye(3)
        return trimesh.transformations.quaternion_matrix(q / np.linalg.norm(q))[:3, :3]


class _Reader:
    def __init__(self, stage: _Stage) -> None:
        self.s = stage

    def mesh(self, prim, stretch: np.ndarray) -> tuple[trimesh.Trimesh, np.ndarray | None]:
        s, UsdGeom = self.s, self.s.UsdGeom
        geom = UsdGeom.Mesh(prim)
        points = np.array(geom.GetPointsAttr().Get() or [], dtype=np.float64).reshape(-1, 3)
        counts = np.array(geom.GetFaceVertexCountsAttr().Get() or [], dtype=np.int64)
        indices = np.array(geom.GetFaceVertexIndicesAttr().Get() or [], dtype=np.int64)
        where = f"{s.path}: mesh {prim.GetPath()}"
        if counts.sum() != len(indices) or np.any(counts < 3):
            raise InputError(f"{where}: face counts and indices disagree")
        MESH_TRIANGLES.check(where, int(np.sum(counts - 2)))
        if len(indices) and (indices.min() < 0 or indices.max() >= len(points)):
            raise InputError(f"{where}: a face index is out of range")
        if not np.all(np.isfinite(points)):
            raise InputError(f"{where}: has non-finite points")
        if np.all(counts == 3):
            faces = indices.reshape(-1, 3)
        else:  # polygons as triangle fans
            starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
            faces = np.array([[indices[st], indices[st + k], indices[st + k + 1]] for st, n in zip(starts, counts)
                              for k in range(1, n - 1)], dtype=np.int64).reshape(-1, 3)
        mesh = trimesh.Trimesh(vertices=points @ stretch.T * s.metres, faces=faces, process=False)
        uv = None
        primvar = UsdGeom.PrimvarsAPI(prim).GetPrimvar("st")
        if primvar and primvar.HasValue() and primvar.GetInterpolation() in (UsdGeom.Tokens.vertex, UsdGeom.Tokens.varying):
            values = np.array(primvar.ComputeFlattened() or [], dtype=np.float64).reshape(-1, 2)
            uv = values if len(values) == len(points) and np.all(np.isfinite(values)) else None
        return mesh, uv

    def shape(self, prim, stretch: np.ndarray):
        """(primitive shape or None, mesh or None, uv) of a gprim with `stretch` (its scale) applied."""
        s, UsdGeom = self.s, self.s.UsdGeom
        kind = prim.GetTypeName()
        if kind == "Mesh":
            mesh, uv = self.mesh(prim, stretch)
            return None, mesh, uv
        scale = np.sqrt(np.sum(stretch**2, axis=0)) * s.metres
        if kind == "Cube":
            size = s.number(prim, "size", 2.0)
            if not np.allclose(stretch, np.diag(np.diag(stretch)), atol=1e-9):
                raise InputError(f"{s.path}: cube {prim.GetPath()} is sheared")
            return Box(size_m=tuple(float(v) for v in size * scale)), None, None
        radius = s.number(prim, "radius", 1.0)
        if kind == "Sphere":
            if not np.allclose(scale, scale[0]):
                raise InputError(f"{s.path}: sphere {prim.GetPath()} is scaled unevenly")
            return Sphere(radius_m=float(radius * scale[0])), None, None
        axis = str(UsdGeom.Cylinder(prim).GetAxisAttr().Get() or "Z")
        if axis != "Z" or not np.isclose(scale[0], scale[1]):
            raise InputError(f"{s.path}: cylinder {prim.GetPath()} is not along z with a round section")
        return Cylinder(radius_m=float(radius * scale[0]), length_m=float(s.number(prim, "height", 2.0) * scale[2])), None, None

    def material(self, prim, name: str) -> tuple[Material, bool]:
        """The bound UsdPreviewSurface's colour (or texture), else the display colour."""
        s = self.s
        bound = s.UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()[0]
        rgba = list(s.attribute(prim, "primvars:displayColor", [(0.8, 0.8, 0.8)])[0]) + [
            float(s.attribute(prim, "primvars:displayOpacity", [1.0])[0])]
        if not bound:
            return Material(name=name, rgba=tuple(float(c) for c in rgba)), False
        shader = bound.ComputeSurfaceSource()[0]
        texture = None
        if shader:
            colour = shader.GetInput("diffuseColor")
            if colour and colour.HasConnectedSource():
                source = colour.GetConnectedSource()[0].GetPrim()
                asset = s.attribute(source, "inputs:file")
                if asset is not None:
                    texture = texture_file(s.path, asset.path, f"material {bound.GetPath()}")
            elif colour and colour.Get() is not None:
                rgba[:3] = list(colour.Get())
            opacity = shader.GetInput("opacity")
            if opacity and opacity.Get() is not None:
                rgba[3] = float(opacity.Get())
        material = Material(name=bound.GetPrim().GetName(), rgba=tuple(float(c) for c in rgba), texture=texture)
        return material, texture is not None

    def link(self, body, prefix: str) -> Link:
        s, UsdPhysics = self.s, self.s.UsdPhysics
        link = Link(name=body.GetName().removeprefix(prefix))
        world_from_body = s.world_from(body)
        body_from_world = np.linalg.inv(world_from_body)
        if body.HasAPI(UsdPhysics.MassAPI) and s.number(body, "physics:mass", 0.0) > 0:
            mass = s.number(body, "physics:mass", 0.0) * s.kilograms
            com = s.vector(s.attribute(body, "physics:centerOfMass", (0.0, 0.0, 0.0)), 3, f"{body.GetPath()} centre of mass")
            if np.any(np.abs(com) > 1e30):  # UsdPhysics's "not given" sentinel
                com = np.zeros(3)
            moments = s.vector(s.attribute(body, "physics:diagonalInertia", (0.0, 0.0, 0.0)), 3, f"{body.GetPath()} inertia")
            quat = s.attribute(body, "physics:principalAxes")
            axes = np.eye(3) if quat is None else s.quat_rotation(quat, f"{body.GetPath()} principal axes")
            link.inertial = Inertial(mass_kg=mass, com_m=com * s.metres,
                                     inertia_kgm2=axes @ np.diag(moments) @ axes.T * s.kilograms * s.metres**2)
        prims = iter(self.s.Usd.PrimRange(body))
        for prim in prims:
            if prim != body and prim.HasAPI(UsdPhysics.RigidBodyAPI):
                prims.PruneChildren()  # a nested body is a link of its own
                continue
            if prim.GetTypeName() not in _GPRIMS:
                continue
            try:
                body_from_prim, stretch = _polar(body_from_world @ s.world_from(prim))
            except ValueError:
                raise InputError(f"{s.path}: prim {prim.GetPath()} is mirrored") from None
            shape, mesh, uv = self.shape(prim, stretch)
            purpose = s.UsdGeom.Imageable(prim).ComputePurpose()
            is_collider = prim.HasAPI(UsdPhysics.CollisionAPI)
            if is_collider:
                name = part_name(prim.GetName(), prefix, link.name)
                geometry = shape if shape is not None else MeshGeometry(mesh=mesh)
                link.collisions.append(Collision(name=name, geometry=geometry, link_from_collision=body_from_prim))
            if not is_collider or purpose not in (s.UsdGeom.Tokens.guide, s.UsdGeom.Tokens.proxy):
                name = part_name(prim.GetName(), prefix, link.name)
                material, textured = self.material(prim, name)
                link.visuals.append(read_visual(name, shape, mesh, uv, material, textured, body_from_prim))
        return link

    def joint(self, prim, parts: ObjectParts, prefix: str, bodies: dict[str, object]) -> None:
        """One UsdPhysics joint between two of the object's bodies, as a model's joint."""
        s, UsdPhysics = self.s, self.s.UsdPhysics
        base = UsdPhysics.Joint(prim)
        targets = [base.GetBody0Rel().GetTargets(), base.GetBody1Rel().GetTargets()]
        body0, body1 = (str(t[0]) if t else "" for t in targets)
        name = prim.GetName().removeprefix(prefix)
        kind = prim.GetTypeName()
        types = {"PhysicsRevoluteJoint": "revolute", "PhysicsPrismaticJoint": "prismatic", "PhysicsFixedJoint": "fixed"}
        if kind not in types:
            raise InputError(f"{s.path}: joint {prim.GetPath()}: {kind or 'an untyped joint'} is not read (revolute, prismatic, fixed)")
        local = []
        for index in (0, 1):
            pos = s.vector(s.attribute(prim, f"physics:localPos{index}", (0.0, 0.0, 0.0)), 3, f"{prim.GetPath()} localPos{index}")
            m = np.eye(4)
            m[:3, 3] = pos * s.metres
            quat = s.attribute(prim, f"physics:localRot{index}")
            if quat is not None:
                m[:3, :3] = s.quat_rotation(quat, f"{prim.GetPath()} localRot{index}")
            local.append(m)
        parent, child = (bodies[b].name for b in (body0, body1))
        child_link = next(link for link in parts.links if link.name == child)
        axis_token = str(s.attribute(prim, "physics:axis", "X"))
        unit = _AXES.get(axis_token)
        if unit is None:
            raise InputError(f"{s.path}: joint {prim.GetPath()}: axis {axis_token!r} is not X, Y or Z")
        world_from_parent, world_from_child = (s.world_from(s.stage.GetPrimAtPath(b)) for b in (body0, body1))
        motion = np.linalg.inv(world_from_parent @ local[0]) @ world_from_child @ local[1]
        joint_type = types[kind]
        if joint_type == "revolute":
            # The model's joint turns about an axis through its child's frame: move the link there.
            reanchor(child_link, parts.joints, translation_transform(local[1][:3, 3]))
            local[1][:3, 3] = 0.0
        parent_from_joint = local[0] @ np.linalg.inv(local[1])
        if joint_type == "fixed":
            parts.joints.append(Joint(name=name, type="fixed", parent=parent, child=child, parent_from_joint=parent_from_joint))
            return
        scale = np.pi / 180.0 if joint_type == "revolute" else s.metres
        lower = s.number(prim, "physics:lowerLimit", -np.inf) * scale
        upper = s.number(prim, "physics:upperLimit", np.inf) * scale
        drive_kind = "angular" if joint_type == "revolute" else "linear"
        drive = UsdPhysics.DriveAPI.Get(prim, drive_kind) if prim.HasAPI(UsdPhysics.DriveAPI, drive_kind) else None
        effort = None if drive is None else drive.GetMaxForceAttr().Get()
        limited = bool(np.isfinite(lower) and np.isfinite(upper))
        limits = None
        if limited or effort is not None:
            limits = JointLimits(lower=lower if limited else 0.0, upper=upper if limited else 0.0)
            if effort is not None and np.isfinite(effort):
                limits.effort = float(effort)
        damping = s.attribute(prim, "homemodel:damping", None if drive is None else drive.GetDampingAttr().Get())
        friction = s.attribute(prim, "homemodel:friction", 0.0)
        dynamics = None if damping is None else JointDynamics(damping=float(damping), friction=float(friction))
        if joint_type == "revolute" and not limited:
            joint_type = "continuous"
            limits = None if effort is None else limits
        axis = local[1][:3, :3] @ unit
        joint = Joint(name=name, type=joint_type, parent=parent, child=child, parent_from_joint=parent_from_joint,
                      axis=axis, limits=limits, dynamics=dynamics)
        parts.joints.append(joint)
        parts.joint_positions[name] = joint_motion_position(joint_type, unit, motion)

    def objects(self) -> tuple[list[ObjectParts], bool, list]:
        s, UsdPhysics = self.s, self.s.UsdPhysics
        prims = list(s.stage.Traverse())
        bodies = [p for p in prims if p.HasAPI(UsdPhysics.RigidBodyAPI)]
        URDF_LINKS.check(s.path, len(bodies))
        joints = [p for p in prims if p.IsA(UsdPhysics.Joint)]
        body_paths = {str(b.GetPath()): b for b in bodies}
        group = {path: path for path in body_paths}  # union-find over the joints

        def find(path: str) -> str:
            while group[path] != path:
                path = group[path]
            return path

        world_joints, inner_joints = [], []
        for joint in joints:
            base = UsdPhysics.Joint(joint)
            ends = [str(t[0]) if t else "" for t in (base.GetBody0Rel().GetTargets(), base.GetBody1Rel().GetTargets())]
            for end in ends:
                if end and end not in body_paths:
                    raise InputError(f"{s.path}: joint {joint.GetPath()} joins {end}, which is not a rigid body")
            if all(ends):
                group[find(ends[1])] = find(ends[0])
                inner_joints.append((joint, ends))
            elif any(ends):
                world_joints.append((joint, ends))
        members: dict[str, list[str]] = {}
        for path in body_paths:
            members.setdefault(find(path), []).append(path)
        objects = []
        for paths in members.values():
            objects.append(self.object(paths, body_paths, inner_joints, world_joints))
        floor, walls = self.statics(set(body_paths))
        return objects, floor, walls

    def object(self, paths: list[str], body_paths: dict, inner_joints: list, world_joints: list) -> ObjectParts:
        s = self.s
        prims = [body_paths[p] for p in paths]
        parents = {p.GetParent().GetPath() for p in prims}
        holder = prims[0].GetParent() if len(parents) == 1 else None
        default = s.stage.GetDefaultPrim()
        if holder is not None and (holder.IsPseudoRoot() or holder == default):
            holder = None
        own = set(paths)
        joints = [(j, ends) for j, ends in inner_joints if ends[0] in own]
        children = {ends[1] for _, ends in joints}
        roots = [p for p in paths if p not in children]
        root = body_paths[roots[0]] if roots else prims[0]
        names = [p.GetName() for p in prims] + [j.GetName() for j, _ in joints]
        prefix = object_prefix(root.GetName(), names)
        object_id = holder.GetName() if holder is not None else (prefix[:-2] or root.GetName())
        world_from_model = s.world_from(root)
        parts = ObjectParts(id=object_id, world_from_model=world_from_model)
        links = {}
        for prim in prims:
            link = self.link(prim, prefix)
            links[str(prim.GetPath())] = link
            parts.links.append(link)
        held = [(j, ends) for j, ends in world_joints if ends[1] in own or ends[0] in own]
        for joint, _ in held:
            if joint.GetTypeName() != "PhysicsFixedJoint":
                raise InputError(f"{s.path}: joint {joint.GetPath()}: only a fixed joint holds an object to the world")
        parts.free = not held
        parent_of = {ends[1]: ends[0] for _, ends in joints}
        for joint, _ in sorted(joints, key=lambda item: -tree_depth(item[1][1], parent_of, s.path)):
            self.joint(joint, parts, prefix, links)
        return parts

    def statics(self, bodies: set[str]) -> tuple[bool, list]:
        """Our floor and walls: cubes with colliders outside any rigid body, under the default prim."""
        s = self.s
        default = s.stage.GetDefaultPrim()
        floor, walls = False, []
        if not default:
            return floor, walls
        for prim in default.GetChildren():
            if prim.GetTypeName() != "Cube" or not prim.HasAPI(s.UsdPhysics.CollisionAPI):
                continue
            world_from_cube, stretch = _polar(s.world_from(prim))
            size = np.sqrt(np.sum(stretch**2, axis=0)) * s.number(prim, "size", 2.0) * s.metres
            if prim.GetName() == "floor":
                floor = True
            elif (wall := wall_from_box(prim.GetName(), world_from_cube, size)) is not None:
                walls.append(wall)
        return floor, walls


def read_usd(path: Path) -> Scene:
    """The scene of a USD stage: its articulated objects, floor and walls; InputError naming
    the file for a stage that cannot be read or uses what a model cannot hold."""
    from pxr import Tf

    path = Path(path)
    stage = _Stage(path)
    # pxr reports a malformed value (an unknown xformOp, a string where a number belongs) as it
    # is read, by an exception or a diagnostic on stderr.
    with captured_c_output((2,)):
        try:
            objects, floor, walls = _Reader(stage).objects()
        except (Tf.ErrorException, ValueError, TypeError) as exc:
            said = str(exc).strip().splitlines()
            raise InputError(f"{path}: cannot be read: {said[-1].strip() if said else type(exc).__name__}") from None
    if not objects:
        raise InputError(f"{path}: has no rigid bodies (UsdPhysics.RigidBodyAPI)")
    default = stage.stage.GetDefaultPrim()
    try:
        return Scene(name=default.GetName() if default else path.stem, objects=[o.scene_object(path) for o in objects],
                     floor=floor, walls=walls)
    except ModelError as exc:
        raise InputError(f"{path}: {exc}") from None
