"""Write a scene as a USD stage (`scene.usda`) with UsdPhysics, for Isaac Sim and other USD
simulators.

Layout: `/World` (the default prim, z up, metres, kilograms) holds a physics scene, the
floor and walls as static colliders, and one Xform per object. Under an object, its links
are sibling rigid bodies (USD physics does not nest rigid bodies), each with its mass,
centre of mass and principal inertia, visual meshes (bound to a UsdPreviewSurface material
in the object's `Looks` scope, named by object id, and with a display colour) and
colliders (boxes, cylinders and spheres as such, meshes with a convex-hull approximation,
purpose "guide" so they do not render). Joints live in the object's `joints` scope:

- a UsdPhysics revolute or prismatic joint per movable joint, its frames turned so that the
  joint's X axis is the model's axis; the child's frame is written at the scene's joint
  position, so the joint starts there and its limits (degrees for revolute joints, as
  UsdPhysics asks) are the model's own;
- a fixed joint to the world for furniture; free objects have none;
- a drive with zero stiffness carries the joint's damping; USD physics has no joint
  friction, so it goes into the custom attribute `homemodel:friction` (N·m or N), beside
  `homemodel:damping`, for a reader to apply.

Objects with movable joints carry the ArticulationRootAPI.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from articulation.export_dynamics import export_dynamics
from articulation.joint_loads import STANDARD_GRAVITY_M_S2
from articulation.model import (
    Box,
    Collision,
    Cylinder,
    Joint,
    Link,
    Material,
    MeshGeometry,
    Sphere,
)
from articulation.naming import unique
from articulation.scene import Scene, SceneObject
from homemodel.core.errors import ModelError
from homemodel.exchange.scene_meshes import SceneMeshes
from homemodel.exchange.urdf.scene import FLOOR_MATERIAL, WALL_MATERIAL, floor_box

SCENE_FILE = "scene.usda"


def _rotation_x_to(axis: np.ndarray) -> np.ndarray:
    """A rotation taking the x axis to the unit vector `axis` (the shortest such turn)."""
    a = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
    x = np.array([1.0, 0.0, 0.0])
    v, c = np.cross(x, a), float(np.dot(x, a))
    if c < -1 + 1e-12:  # opposite: half a turn about z
        return np.diag([-1.0, -1.0, 1.0])
    k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + k + k @ k / (1 + c)


class _StageWriter:
    def __init__(self, stage, meshes: SceneMeshes) -> None:
        from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics, UsdShade

        self.stage = stage
        self.meshes = meshes
        self.Gf, self.Sdf, self.Usd, self.UsdGeom, self.UsdPhysics, self.UsdShade = Gf, Sdf, Usd, UsdGeom, UsdPhysics, UsdShade
        self.materials: dict[tuple, object] = {}
        self.material_names: set[str] = set()

    def matrix(self, a_from_b: np.ndarray):
        # USD matrices are row-vector: the transpose of ours.
        return self.Gf.Matrix4d(*np.asarray(a_from_b, dtype=np.float64).T.flatten().tolist())

    def xform(self, path: str, a_from_b: np.ndarray | None = None):
        prim = self.UsdGeom.Xform.Define(self.stage, path)
        if a_from_b is not None:
            prim.AddTransformOp().Set(self.matrix(a_from_b))
        return prim

    def quat(self, rotation: np.ndarray):
        from homemodel.exchange.gltf import quaternion_xyzw

        x, y, z, w = quaternion_xyzw(rotation)
        return self.Gf.Quatf(float(w), self.Gf.Vec3f(float(x), float(y), float(z)))

    def mesh(self, path: str, mesh: trimesh.Trimesh, a_from_mesh: np.ndarray, rgba=None):
        prim = self.UsdGeom.Mesh.Define(self.stage, path)
        prim.CreatePointsAttr([self.Gf.Vec3f(*map(float, v)) for v in mesh.vertices])
        prim.CreateFaceVertexCountsAttr([3] * len(mesh.faces))
        prim.CreateFaceVertexIndicesAttr([int(i) for i in np.asarray(mesh.faces).flatten()])
        prim.CreateSubdivisionSchemeAttr("none")
        lo, hi = mesh.bounds
        prim.CreateExtentAttr([self.Gf.Vec3f(*map(float, lo)), self.Gf.Vec3f(*map(float, hi))])
        if rgba is not None:
            prim.CreateDisplayColorAttr([self.Gf.Vec3f(*map(float, rgba[:3]))])
            prim.CreateDisplayOpacityAttr([float(rgba[3])])
        prim.AddTransformOp().Set(self.matrix(a_from_mesh))
        return prim

    def material(self, obj: SceneObject, material: Material, textured: bool):
        """A UsdPreviewSurface material per object and look, in the object's `Looks` scope; a
        photo texture (a PNG under `meshes/`) read through the mesh's `st` coordinates."""
        key = (obj.id, material.name, tuple(material.rgba), material.texture if textured else None)
        if key in self.materials:
            return self.materials[key]
        Sdf, UsdShade = self.Sdf, self.UsdShade
        looks = f"/World/{obj.safe_id}/Looks/{unique(obj.name(material.name), self.material_names)}"
        usd_material = UsdShade.Material.Define(self.stage, looks)
        shader = UsdShade.Shader.Define(self.stage, f"{looks}/surface")
        shader.CreateIdAttr("UsdPreviewSurface")
        r, g, b, a = (float(c) for c in material.rgba)
        colour = shader.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f)
        shader.CreateInput("opacity", Sdf.ValueTypeNames.Float).Set(a)
        shader.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(0.8)
        usd_material.CreateSurfaceOutput().ConnectToSource(shader.ConnectableAPI(), "surface")
        if textured:
            reader = UsdShade.Shader.Define(self.stage, f"{looks}/st_reader")
            reader.CreateIdAttr("UsdPrimvarReader_float2")
            reader.CreateInput("varname", Sdf.ValueTypeNames.String).Set("st")
            image = UsdShade.Shader.Define(self.stage, f"{looks}/photo")
            image.CreateIdAttr("UsdUVTexture")
            image.CreateInput("file", Sdf.ValueTypeNames.Asset).Set(f"./{self.meshes.texture(obj, material.texture)[1]}")
            image.CreateInput("st", Sdf.ValueTypeNames.Float2).ConnectToSource(reader.ConnectableAPI(), "result")
            colour.ConnectToSource(image.ConnectableAPI(), "rgb")
        else:
            colour.Set(self.Gf.Vec3f(r, g, b))
        self.materials[key] = usd_material
        return usd_material

    def collider(self, path: str, collision: Collision):
        UsdGeom, UsdPhysics = self.UsdGeom, self.UsdPhysics
        shape = collision.geometry
        if isinstance(shape, Box):
            prim = UsdGeom.Cube.Define(self.stage, path)
            prim.CreateSizeAttr(1.0)
            prim.AddTransformOp().Set(self.matrix(collision.link_from_collision @ np.diag([*shape.size_m, 1.0])))
        elif isinstance(shape, Cylinder):
            prim = UsdGeom.Cylinder.Define(self.stage, path)
            prim.CreateRadiusAttr(float(shape.radius_m))
            prim.CreateHeightAttr(float(shape.length_m))
            prim.CreateAxisAttr("Z")
            prim.AddTransformOp().Set(self.matrix(collision.link_from_collision))
        elif isinstance(shape, Sphere):
            prim = UsdGeom.Sphere.Define(self.stage, path)
            prim.CreateRadiusAttr(float(shape.radius_m))
            prim.AddTransformOp().Set(self.matrix(collision.link_from_collision))
        elif isinstance(shape, MeshGeometry):
            prim = self.mesh(path, shape.mesh, collision.link_from_collision)
            UsdPhysics.MeshCollisionAPI.Apply(prim.GetPrim()).CreateApproximationAttr(UsdPhysics.Tokens.convexHull)
        else:
            raise ModelError(f"collision {collision.name!r}: unknown geometry {type(shape).__name__}")
        prim.CreatePurposeAttr(UsdGeom.Tokens.guide)
        UsdPhysics.CollisionAPI.Apply(prim.GetPrim())

    def link(self, path: str, obj: SceneObject, link: Link, model_from_link: np.ndarray) -> None:
        prim = self.xform(path, model_from_link).GetPrim()
        self.UsdPhysics.RigidBodyAPI.Apply(prim)
        if link.inertial is not None:
            mass = self.UsdPhysics.MassAPI.Apply(prim)
            mass.CreateMassAttr(float(link.inertial.mass_kg))
            mass.CreateCenterOfMassAttr(self.Gf.Vec3f(*map(float, link.inertial.com_m)))
            moments, axes = np.linalg.eigh(link.inertial.inertia_kgm2)
            if np.linalg.det(axes) < 0:
                axes[:, 2] *= -1
            mass.CreateDiagonalInertiaAttr(self.Gf.Vec3f(*map(float, np.maximum(moments, 0.0))))
            mass.CreatePrincipalAxesAttr(self.quat(axes))
        names: set[str] = set()
        for visual in link.visuals:
            prim = self.mesh(
                f"{path}/visuals/{unique(obj.name(visual.name), names)}", visual.mesh, visual.link_from_visual, visual.material.rgba
            )
            textured = visual.material.texture is not None and visual.uv is not None
            if textured:
                st = self.UsdGeom.PrimvarsAPI(prim).CreatePrimvar(
                    "st", self.Sdf.ValueTypeNames.TexCoord2fArray, self.UsdGeom.Tokens.vertex
                )
                st.Set([self.Gf.Vec2f(float(u), float(v)) for u, v in visual.uv])
            self.UsdShade.MaterialBindingAPI.Apply(prim.GetPrim()).Bind(self.material(obj, visual.material, textured))
        for collision in link.collisions:
            self.collider(f"{path}/collisions/{unique(obj.name(collision.name), names)}", collision)

    def joint(self, scope: str, object_path: str, obj: SceneObject, joint: Joint) -> None:
        UsdPhysics = self.UsdPhysics
        path = f"{scope}/{obj.name(joint.name)}"
        q = obj.position(joint.name)
        if joint.type == "prismatic":
            usd_joint = UsdPhysics.PrismaticJoint.Define(self.stage, path)
        elif joint.is_movable:
            usd_joint = UsdPhysics.RevoluteJoint.Define(self.stage, path)
        else:
            usd_joint = UsdPhysics.FixedJoint.Define(self.stage, path)
        usd_joint.CreateBody0Rel().SetTargets([f"{object_path}/{obj.name(joint.parent)}"])
        usd_joint.CreateBody1Rel().SetTargets([f"{object_path}/{obj.name(joint.child)}"])
        turn = _rotation_x_to(joint.axis) if joint.is_movable else np.eye(3)
        # The joint frame in the child is the child's own frame (as at position zero), so the
        # bodies, written at the scene's position q, put the joint at q within its own limits.
        usd_joint.CreateLocalPos0Attr(self.Gf.Vec3f(*map(float, joint.parent_from_joint[:3, 3])))
        usd_joint.CreateLocalRot0Attr(self.quat(joint.parent_from_joint[:3, :3] @ turn))
        usd_joint.CreateLocalPos1Attr(self.Gf.Vec3f(0.0, 0.0, 0.0))
        usd_joint.CreateLocalRot1Attr(self.quat(turn))
        if not joint.is_movable:
            return
        usd_joint.CreateAxisAttr("X")
        if joint.type != "continuous" and joint.limits is not None:
            scale = 1.0 if joint.type == "prismatic" else 180.0 / np.pi
            usd_joint.CreateLowerLimitAttr(float(joint.limits.lower * scale))
            usd_joint.CreateUpperLimitAttr(float(joint.limits.upper * scale))
        dynamics = export_dynamics(obj.model, joint, gravity_model=obj.gravity_model)
        kind = "linear" if joint.type == "prismatic" else "angular"
        drive = UsdPhysics.DriveAPI.Apply(usd_joint.GetPrim(), kind)
        drive.CreateTypeAttr("force")
        drive.CreateStiffnessAttr(0.0)
        drive.CreateDampingAttr(float(dynamics.damping))
        if joint.limits is not None:
            drive.CreateMaxForceAttr(float(joint.limits.effort))
        prim = usd_joint.GetPrim()
        prim.CreateAttribute("homemodel:damping", self.Sdf.ValueTypeNames.Float, custom=True).Set(float(dynamics.damping))
        prim.CreateAttribute("homemodel:friction", self.Sdf.ValueTypeNames.Float, custom=True).Set(float(dynamics.friction))
        prim.CreateAttribute("homemodel:initialPosition", self.Sdf.ValueTypeNames.Float, custom=True).Set(float(q))

    def object(self, obj: SceneObject) -> None:
        path = f"/World/{obj.safe_id}"
        object_prim = self.xform(path, obj.world_from_model).GetPrim()
        frames = obj.model.world_from_links(obj.joint_positions)
        for link in obj.model.links:
            self.link(f"{path}/{obj.name(link.name)}", obj, link, frames[link.name])
        scope = f"{path}/joints"
        self.UsdGeom.Scope.Define(self.stage, scope)
        for joint in obj.model.joints:
            self.joint(scope, path, obj, joint)
        if not obj.free:
            fixed = self.UsdPhysics.FixedJoint.Define(self.stage, f"{scope}/{obj.name('placed')}")
            fixed.CreateBody1Rel().SetTargets([f"{path}/{obj.name(obj.model.root_link)}"])
            fixed.CreateLocalPos0Attr(self.Gf.Vec3f(*map(float, obj.world_from_model[:3, 3])))
            fixed.CreateLocalRot0Attr(self.quat(obj.world_from_model[:3, :3]))
            fixed.CreateLocalPos1Attr(self.Gf.Vec3f(0.0, 0.0, 0.0))
            fixed.CreateLocalRot1Attr(self.Gf.Quatf(1.0))
        if obj.model.movable_joints:
            self.UsdPhysics.ArticulationRootAPI.Apply(object_prim)

    def static_box(self, path: str, world_from_box: np.ndarray, size, rgba) -> None:
        cube = self.UsdGeom.Cube.Define(self.stage, path)
        cube.CreateSizeAttr(1.0)
        cube.CreateDisplayColorAttr([self.Gf.Vec3f(*map(float, rgba[:3]))])
        cube.AddTransformOp().Set(self.matrix(world_from_box @ np.diag([*size, 1.0])))
        self.UsdPhysics.CollisionAPI.Apply(cube.GetPrim())


def write_usd(scene: Scene, folder: Path) -> Path:
    from pxr import Gf, Usd, UsdGeom, UsdPhysics

    path = Path(folder) / SCENE_FILE
    tmp = path.with_name(f".{path.name}.tmp.usda")
    stage = Usd.Stage.CreateNew(str(tmp))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdPhysics.SetStageKilogramsPerUnit(stage, 1.0)
    world = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(world.GetPrim())
    physics = UsdPhysics.Scene.Define(stage, "/World/physicsScene")
    physics.CreateGravityDirectionAttr(Gf.Vec3f(0.0, 0.0, -1.0))
    physics.CreateGravityMagnitudeAttr(STANDARD_GRAVITY_M_S2)
    writer = _StageWriter(stage, SceneMeshes(folder))
    if scene.floor:
        world_from_floor, size = floor_box(scene)
        writer.static_box("/World/floor", world_from_floor, size, FLOOR_MATERIAL.rgba)
    for wall in scene.walls:
        writer.static_box(f"/World/{wall.name}", wall.world_from_wall(), wall.size_m, WALL_MATERIAL.rgba)
    for obj in scene.objects:
        writer.object(obj)
    stage.GetRootLayer().Save()
    tmp.replace(path)  # atomic: a reader never sees a half-written stage
    return path
