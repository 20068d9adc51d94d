"""The articulated model every pipeline produces, its URDF and glTF export, URDF import,
posing at a joint configuration, and the validation gate."""

from articulation.model import (
    Box,
    Collision,
    Cylinder,
    GraspPoint,
    Inertial,
    Joint,
    JointDynamics,
    JointLimits,
    JointState,
    Link,
    Material,
    MeshGeometry,
    Model,
    Sphere,
    Visual,
)

__all__ = [
    "Box",
    "Collision",
    "Cylinder",
    "GraspPoint",
    "Inertial",
    "Joint",
    "JointDynamics",
    "JointLimits",
    "JointState",
    "Link",
    "Material",
    "MeshGeometry",
    "Model",
    "Sphere",
    "Visual",
]
