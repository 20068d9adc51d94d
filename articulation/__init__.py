"""The articulated model every pipeline produces (links, joints and their types, inertials),
posing at a joint configuration, scenes of placed models, and the simulator decisions the
writers consume (joint dynamics). Its files are `homemodel.exchange`'s (URDF, glTF, MJCF, SDF,
USD); the validation gate and the model folder are `homemodel.model_folder`'s."""

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
