"""The gate's check that every number in the URDF is finite: an origin, axis, limit,
inertial, scale, colour or extension value of NaN or infinity reaches the clients as
"valid" (pybullet, check_urdf and yourdfpy read `nan` as a number) and poisons every pose
computed from it. Mesh vertices are the mesh geometry check's."""

from __future__ import annotations

import math

from homemodel.exchange.urdf import Element
from homemodel.model_folder.gate.report import Check, check_from_problems

# Attributes that hold names or paths, never numbers (a link named "inf" is fine).
_TEXT_ATTRIBUTES = frozenset({"name", "type", "link", "joint", "filename", "kind", "category", "value"})


def _non_finite(text: str) -> bool:
    for token in text.replace(",", " ").split():
        try:
            value = float(token)
        except ValueError:
            return False  # not a number list: a text attribute
        if not math.isfinite(value):
            return True
    return False


def _where(element: Element) -> str:
    for ancestor in (element, *element.iterancestors()):
        if ancestor.tag in ("link", "joint") and ancestor.get("name") is not None:
            return f"{ancestor.tag} {ancestor.get('name')!r}: line {element.sourceline}"
    return f"line {element.sourceline}"


def finite_numbers_check(robot: Element) -> Check:
    """Every numeric attribute of every element (a mass's `value` included) is finite."""
    problems: list[str] = []
    numbers = 0
    for element in robot.iter():
        if not isinstance(element.tag, str):
            continue  # comments and processing instructions
        for attribute, text in element.attrib.items():
            # <mass value> is a number; the extension's <property value> is text.
            if attribute in _TEXT_ATTRIBUTES and not (attribute == "value" and element.tag == "mass"):
                continue
            numbers += 1
            if _non_finite(text):
                problems.append(f"{_where(element)}: <{element.tag} {attribute}={text!r}> is not finite")
    return check_from_problems("finite numbers", problems, f"{numbers} numeric attributes, none NaN or infinite")
