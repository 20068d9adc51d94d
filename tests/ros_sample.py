"""A ROS workspace made here (none can be downloaded): src/arm_description, a description
package whose URDF names its meshes by `package://` (an STL, and a DAE in millimetres placed by
its node), and src/shared_meshes, another package holding a DAE the URDF also names."""

from __future__ import annotations

from pathlib import Path

import trimesh

# The arm link's inertial, for a URDF that passes the gate as it is (a real package's has one).
ARM_INERTIAL = '<inertial><origin xyz="0 0 0.15"/><mass value="0.8"/><inertia ixx="0.006" ixy="0" ixz="0" iyy="0.006" iyz="0" izz="0.0003"/></inertial>'


def write_dae(path: Path, mesh: trimesh.Trimesh, *, unit_m: float, node_xyz: tuple[float, float, float]) -> None:
    """A COLLADA file with one node placing `mesh` (in units of `unit_m`) at `node_xyz`."""
    positions = " ".join(f"{v:.6f}" for v in mesh.vertices.ravel())
    indices = " ".join(str(i) for i in mesh.faces.ravel())
    x, y, z = node_xyz
    path.write_text(f"""<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="unit" meter="{unit_m}"/><up_axis>Y_UP</up_axis></asset>
  <library_geometries><geometry id="g" name="part"><mesh>
    <source id="p"><float_array id="pa" count="{mesh.vertices.size}">{positions}</float_array>
      <technique_common><accessor source="#pa" count="{len(mesh.vertices)}" stride="3">
        <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
      </accessor></technique_common></source>
    <vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
    <triangles count="{len(mesh.faces)}"><input semantic="VERTEX" source="#v" offset="0"/><p>{indices}</p></triangles>
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="s"><node id="n" name="n">
    <matrix>1 0 0 {x} 0 1 0 {y} 0 0 1 {z} 0 0 0 1</matrix>
    <instance_geometry url="#g"/>
  </node></visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
""")


def _package(root: Path, name: str) -> Path:
    folder = root / name
    (folder / "meshes").mkdir(parents=True)
    (folder / "package.xml").write_text(f'<?xml version="1.0"?><package format="3"><name>{name}</name><version>1.0.0</version></package>')
    return folder


def write_ros_workspace(root: Path, *, arm_inertial: bool = False) -> Path:
    """src/arm_description (urdf/arm.urdf, meshes/base.stl, meshes/arm.dae in millimetres) and
    src/shared_meshes (meshes/knob.dae), which the URDF names by package://; returns src. The
    arm link has no inertial unless `arm_inertial` (an asset to repair)."""
    src = root / "ws" / "src"
    arm = _package(src, "arm_description")
    shared = _package(src, "shared_meshes")
    trimesh.creation.box(extents=(0.4, 0.4, 0.1)).export(arm / "meshes" / "base.stl")
    write_dae(arm / "meshes" / "arm.dae", trimesh.creation.box(extents=(50.0, 50.0, 300.0)), unit_m=0.001, node_xyz=(0, 0, 150.0))
    write_dae(shared / "meshes" / "knob.dae", trimesh.creation.icosphere(radius=0.03), unit_m=1.0, node_xyz=(0, 0, 0))
    (arm / "urdf").mkdir()
    mesh = '<geometry><mesh filename="package://{0}"/></geometry>'
    (arm / "urdf" / "arm.urdf").write_text(f"""<?xml version="1.0"?>
<robot name="arm">
  <link name="base_link">
    <visual>{mesh.format("arm_description/meshes/base.stl")}</visual>
    <collision>{mesh.format("arm_description/meshes/base.stl")}</collision>
    <inertial><mass value="2.0"/><inertia ixx="0.03" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.05"/></inertial>
  </link>
  <link name="arm_link">
    <visual>{mesh.format("arm_description/meshes/arm.dae")}</visual>
    <visual><origin xyz="0 0 0.33"/>{mesh.format("shared_meshes/meshes/knob.dae")}</visual>
    <collision>{mesh.format("arm_description/meshes/arm.dae")}</collision>
    {ARM_INERTIAL if arm_inertial else ""}
  </link>
  <joint name="shoulder" type="revolute">
    <origin xyz="0 0 0.05"/><axis xyz="0 0 1"/>
    <parent link="base_link"/><child link="arm_link"/>
    <limit lower="-1.5" upper="1.5" effort="5" velocity="1"/>
  </joint>
</robot>
""")
    return src
