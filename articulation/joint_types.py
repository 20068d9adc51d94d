"""The joint types of the articulated model (in URDF's words), listed once: the model, the map and
every format's reader and writer use these.

The Blender add-on (`blender_addons/rig.py`) may not import homemodel; a test checks that its
list is this one.
"""

from __future__ import annotations

from typing import Literal

JointType = Literal["revolute", "prismatic", "continuous", "fixed"]
JOINT_TYPES: tuple[JointType, ...] = ("revolute", "prismatic", "continuous", "fixed")
MovableJointType = Literal["revolute", "prismatic", "continuous"]
MOVABLE_JOINT_TYPES: tuple[MovableJointType, ...] = ("revolute", "prismatic", "continuous")
# The ones with a <limit lower upper>; a continuous joint turns without end.
LIMITED_JOINT_TYPES: tuple[JointType, ...] = ("revolute", "prismatic")
ROTATING_JOINT_TYPES: tuple[JointType, ...] = ("revolute", "continuous")
# URDF itself has two more, which homemodel never writes and does not read into a model.
URDF_JOINT_TYPES: tuple[str, ...] = (*JOINT_TYPES, "floating", "planar")
