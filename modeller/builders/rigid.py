"""Helpers for the builders of furniture and small objects: box parts that are visual and
collision at once, the map properties they share, and the `Assembly` of a model whose
parts are all in one link `body` (or a few links on fixed and revolute joints).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from articulation.model import Collision, GraspPoint, Joint
from modeller.blender_scene import add_object, box_mesh, colour_material
from modeller.blender_to_model import Assembly
from modeller.builders import box_collision
from modeller.specs import ObjectSpec, colour_name, colour_rgb
from modeller.specs.common import Colour

if TYPE_CHECKING:
    import bpy

ROOT_LINK = "body"


def material(colour: Colour) -> bpy.types.Material:
    """The Blender material of a spec colour (one per colour)."""
    return colour_material(colour_name(colour), colour_rgb(colour))


def add_box_part(
    name: str,
    size_m: Sequence[float],
    centre_m: Sequence[float],
    *,
    colour: Colour,
    collisions: list[Collision],
    parent: bpy.types.Object | None = None,
    link: str = ROOT_LINK,
    collision_name: str | None = None,
    parent_from_object: np.ndarray | None = None,
) -> bpy.types.Object:
    """A box, placed in the link frame by its mesh coordinates, with a collision box the same,
    named `collision_name` (default: the part's name after its link's, `leg_0` for `body.leg_0`).

    Without `parent` it is the link's own object (named `link`), which sits at the link frame;
    a link's own object below another link's is placed by `parent_from_object`.
    """
    obj = add_object(
        name,
        box_mesh(name, size_m, centre_m),
        link=link,
        material=material(colour),
        parent=parent,
        parent_from_object=parent_from_object,
    )
    collisions.append(box_collision(collision_name or name.split(".")[-1], size_m, centre_m))
    return obj


def colour_property(colour: Colour) -> dict[str, str]:
    """`colour` for the map when the spec names it ("bring me the blue cup")."""
    return {"colour": colour} if isinstance(colour, str) else {}


def contents_property(contents: str | None) -> dict[str, str]:
    """`contents` for the map when the spec says what a container holds ("the sugar")."""
    return {} if contents is None else {"contents": contents}


def surface_heights_property(heights_m: Iterable[float]) -> dict[str, str]:
    """`surface_heights_m`: the heights above the floor of the object's supporting surfaces,
    lowest first, space-separated, so the map can place objects on them."""
    text = " ".join(f"{h:.4f}".rstrip("0").rstrip(".") for h in sorted(heights_m))
    return {"surface_heights_m": text}


def assembly(
    spec: ObjectSpec,
    name: str,
    *,
    category: str,
    collisions: dict[str, list[Collision]],
    grasp_points: Sequence[GraspPoint] = (),
    joints: Sequence[Joint] = (),
    affordances: Sequence[str] = (),
    properties: dict[str, str] | None = None,
) -> Assembly:
    """The Assembly of a built spec, its mass from the spec (`mass_kg`, else its density)."""
    return Assembly(
        name=name,
        category=category,
        collisions=collisions,
        joints=list(joints),
        grasp_points=list(grasp_points),
        affordances=list(affordances),
        properties=dict(properties or {}),
        density_kg_m3=spec.density_or_default_kg_m3,
        mass_kg=spec.mass_kg,
    )
