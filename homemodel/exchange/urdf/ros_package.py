"""A model as a ROS 2 package (ament_cmake) that RViz shows with one launch command.

    NAME/package.xml                 format 3, ament_cmake; runs robot_state_publisher,
                                     joint_state_publisher_gui, xacro-free
    NAME/CMakeLists.txt              installs urdf/, meshes/ and launch/ into share/NAME
    NAME/urdf/NAME.urdf              mesh URIs `package://NAME/meshes/...` (RViz's resource
                                     retriever resolves these, not relative paths)
    NAME/meshes/                     OBJ/MTL (and textures)
    NAME/launch/display.launch.py    robot_state_publisher with `frame_prefix` (default
                                     "<model name>/", so two models' `body` frames differ)
                                     and joint_state_publisher_gui
"""

from __future__ import annotations

import re
from pathlib import Path

from lxml import etree

from articulation.model import Model
from homemodel.core.atomic import write_text_atomic
from homemodel.core.errors import InputError
from homemodel.exchange import urdf as urdf_doc
from homemodel.exchange.urdf.write import MESH_DIR, urdf_bytes

# REP 144: lower case letters, digits and underscores, starting with a letter.
_PACKAGE_NAME = re.compile(r"^[a-z][a-z0-9_]*$")

_PACKAGE_XML = """<?xml version="1.0"?>
<?xml-model href="http://download.ros.org/schema/package_format3.xsd" schematypens="http://www.w3.org/2001/XMLSchema"?>
<package format="3">
  <name>{name}</name>
  <version>0.1.0</version>
  <description>{description}</description>
  <maintainer email="installer@example.com">homemodel</maintainer>
  <license>Apache-2.0</license>

  <buildtool_depend>ament_cmake</buildtool_depend>

  <exec_depend>joint_state_publisher_gui</exec_depend>
  <exec_depend>launch</exec_depend>
  <exec_depend>launch_ros</exec_depend>
  <exec_depend>robot_state_publisher</exec_depend>
  <exec_depend>rviz2</exec_depend>

  <export>
    <build_type>ament_cmake</build_type>
  </export>
</package>
"""

_CMAKE = """cmake_minimum_required(VERSION 3.8)
project({name})

find_package(ament_cmake REQUIRED)

install(DIRECTORY urdf meshes launch DESTINATION share/${{PROJECT_NAME}})

ament_package()
"""

_LAUNCH = '''"""Publish {model}'s TF frames and move its joints with sliders:
ros2 launch {name} display.launch.py [frame_prefix:=kitchen/oven_1/]"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def generate_launch_description():
    urdf = os.path.join(get_package_share_directory("{name}"), "urdf", "{name}.urdf")
    with open(urdf) as f:
        description = f.read()
    prefix = LaunchConfiguration("frame_prefix")
    return LaunchDescription([
        DeclareLaunchArgument("frame_prefix", default_value="{model}/",
                              description="prepended to every TF frame, so several models can share one tree"),
        Node(package="robot_state_publisher", executable="robot_state_publisher",
             parameters=[{{"robot_description": description, "frame_prefix": prefix}}]),
        Node(package="joint_state_publisher_gui", executable="joint_state_publisher_gui"),
    ])
'''


def check_package_name(name: str) -> str:
    if not _PACKAGE_NAME.match(name or ""):
        raise InputError(f"--package {name!r}: a ROS package name is lower case letters, digits and underscores, starting with a letter")
    return name


def write_ros_package(model: Model, folder: Path, name: str) -> Path:
    """Write the package into the existing (empty) `folder`; returns the URDF's path."""
    check_package_name(name)
    folder = Path(folder)
    robot = etree.fromstring(urdf_bytes(model, folder))
    for _, _, mesh in urdf_doc.mesh_elements(robot):
        mesh.set("filename", f"package://{name}/{mesh.get('filename')}")
    urdf = folder / "urdf" / f"{name}.urdf"
    write_text_atomic(urdf, etree.tostring(robot, pretty_print=True, xml_declaration=True, encoding="utf-8").decode("utf-8"))
    (folder / MESH_DIR).mkdir(exist_ok=True)
    description = f"The {model.category} {model.name}, made with homemodel."
    write_text_atomic(folder / "package.xml", _PACKAGE_XML.format(name=name, description=description))
    write_text_atomic(folder / "CMakeLists.txt", _CMAKE.format(name=name))
    write_text_atomic(folder / "launch" / "display.launch.py", _LAUNCH.format(name=name, model=model.name))
    return urdf
