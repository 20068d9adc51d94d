"""The URDF document, opened and walked in one place: the importer, the validation gate and
the asset repair read `<robot>` through these, and never parse or search it themselves.

`lxml` elements are what every reader keeps (line numbers for messages, unknown elements
left alone); what a URDF means as a model is `homemodel.exchange.urdf.read`'s.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

from lxml import etree

from homemodel.core.errors import InputError
from homemodel.core.limits import URDF_JOINTS, URDF_LINKS
from homemodel.core.safe_xml import parse_xml_file

PART_ROLES = ("visual", "collision")
# What the walk hands out, named here so its readers (the gate, the repair) need no XML library.
Element = etree._Element


def read_urdf_robot(path: Path) -> etree._Element:
    """The `<robot>` element of the URDF at `path`, parsed without entities or network and
    bounded in links and joints (every later step, the gate's clients among them, grows with
    them); InputError naming the file otherwise."""
    path = Path(path)
    robot = parse_xml_file(path).getroot()
    if robot.tag != "robot":
        raise InputError(f"{path}: root element is <{robot.tag}>, expected <robot>")
    URDF_LINKS.check(path, len(links(robot)))
    URDF_JOINTS.check(path, len(joints(robot)))
    return robot


def links(robot: etree._Element) -> list[etree._Element]:
    return robot.findall("link")


def joints(robot: etree._Element) -> list[etree._Element]:
    return robot.findall("joint")


def link_parts(link: etree._Element, roles: tuple[str, ...] = PART_ROLES) -> Iterator[tuple[str, etree._Element]]:
    """(role, element) of a link's visuals and then its collisions (or only `roles`)."""
    for role in roles:
        for part in link.findall(role):
            yield role, part


def mesh_elements(robot: etree._Element, roles: tuple[str, ...] = PART_ROLES) -> Iterator[tuple[etree._Element, str, etree._Element]]:
    """(link, role, `<mesh>`) of every mesh a link's visuals or collisions name."""
    for link in links(robot):
        for role, part in link_parts(link, roles):
            for mesh in part.findall("geometry/mesh"):
                yield link, role, mesh
