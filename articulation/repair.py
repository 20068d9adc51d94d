"""Repair an imported asset that fails the validation gate only for want of what the gate
needs, and say what was repaired: inertials computed from the meshes at a stated density,
and the `effort` and `velocity` a `<limit>` must have (check_urdf refuses one without them)
set to stated defaults. Nothing else is ever changed."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

from lxml import etree

from articulation.inertia import inertial_from_meshes
from articulation.model import Model
from homemodel.core.checks import require_positive
from homemodel.core.safe_xml import parse_xml_file

LIMITED_TYPES = ("revolute", "prismatic")


@dataclass(kw_only=True)
class RepairOptions:
    density_kg_m3: float = 500.0  # for links without an inertial: about that of furniture board
    effort: float = 10.0  # N m (revolute) or N (prismatic), for a <limit> without one
    velocity: float = 1.0  # rad/s or m/s, for a <limit> without one

    def check(self) -> None:
        require_positive("density_kg_m3", self.density_kg_m3)
        require_positive("effort", self.effort)
        require_positive("velocity", self.velocity)


@dataclass(kw_only=True)
class AssetGaps:
    """What a URDF lacks that the gate needs: links with geometry but no inertial, and the
    joints whose <limit> has no effort or no velocity."""

    links_without_inertial: list[str]
    limits_without_effort: list[str]
    limits_without_velocity: list[str]

    def __bool__(self) -> bool:
        return bool(self.links_without_inertial or self.limits_without_effort or self.limits_without_velocity)

    def describe(self) -> list[str]:
        said = []
        if self.links_without_inertial:
            said.append(f"links without <inertial>: {', '.join(self.links_without_inertial)}")
        if self.limits_without_effort:
            said.append(f"<limit> without effort on joints: {', '.join(self.limits_without_effort)}")
        if self.limits_without_velocity:
            said.append(f"<limit> without velocity on joints: {', '.join(self.limits_without_velocity)}")
        return said


def find_gaps(urdf: Path) -> AssetGaps:
    robot = parse_xml_file(Path(urdf)).getroot()
    no_inertial = [
        link.get("name")
        for link in robot.findall("link")
        if link.find("inertial") is None and (link.find("visual") is not None or link.find("collision") is not None)
    ]
    limits: list[tuple[str, etree._Element]] = [
        (j.get("name"), j.find("limit")) for j in robot.findall("joint") if j.find("limit") is not None
    ]
    return AssetGaps(
        links_without_inertial=no_inertial,
        limits_without_effort=[name for name, el in limits if el.get("effort") is None],
        limits_without_velocity=[name for name, el in limits if el.get("velocity") is None],
    )


def repair(model: Model, gaps: AssetGaps, options: RepairOptions) -> tuple[Model, list[str]]:
    """The model with the gaps filled, and one line per repair."""
    options.check()
    done: list[str] = []
    links = []
    for link in model.links:
        if link.name in gaps.links_without_inertial:
            meshes = [v.mesh.copy().apply_transform(v.link_from_visual) for v in link.visuals]
            inertial = inertial_from_meshes(meshes, density_kg_m3=options.density_kg_m3)
            link = dataclasses.replace(link, inertial=inertial)
            done.append(
                f"link {link.name!r}: inertial computed from its meshes at {options.density_kg_m3:g} kg/m^3 "
                f"({inertial.mass_kg:.3g} kg)"
            )
        links.append(link)
    joints = []
    for joint in model.joints:
        changes = {}
        if joint.name in gaps.limits_without_effort and joint.limits is not None:
            changes["effort"] = options.effort
        if joint.name in gaps.limits_without_velocity and joint.limits is not None:
            changes["velocity"] = options.velocity
        if changes:
            joint = dataclasses.replace(joint, limits=dataclasses.replace(joint.limits, **changes))
            done.append(f"joint {joint.name!r}: " + ", ".join(f"{k} set to {v:g}" for k, v in changes.items()))
        joints.append(joint)
    return dataclasses.replace(model, links=links, joints=joints), done
