"""Move a model's root frame: the same object, its coordinates given in a new frame."""

from __future__ import annotations

import dataclasses

import numpy as np

from articulation.model import Inertial, Model


def reframed(model: Model, new_root_from_old_root: np.ndarray) -> Model:
    """A copy of `model` whose root link frame is `new_root_from_old_root` applied to the old
    one: the root's visuals, collisions, inertial, child joints and grasp points move with it;
    every other link keeps its own frame, so joint axes and limits are unchanged."""
    transform = np.asarray(new_root_from_old_root, dtype=np.float64)
    rotation = transform[:3, :3]
    root = model.root_link
    links = []
    for link in model.links:
        if link.name != root:
            links.append(link)
            continue
        inertial = link.inertial
        if inertial is not None:
            inertial = Inertial(
                mass_kg=inertial.mass_kg,
                com_m=rotation @ inertial.com_m + transform[:3, 3],
                inertia_kgm2=rotation @ inertial.inertia_kgm2 @ rotation.T,
            )
        links.append(
            dataclasses.replace(
                link,
                visuals=[dataclasses.replace(v, link_from_visual=transform @ v.link_from_visual) for v in link.visuals],
                collisions=[
                    dataclasses.replace(c, link_from_collision=transform @ c.link_from_collision) for c in link.collisions
                ],
                inertial=inertial,
            )
        )
    joints = [
        dataclasses.replace(j, parent_from_joint=transform @ j.parent_from_joint) if j.parent == root else j
        for j in model.joints
    ]
    grasps = [
        dataclasses.replace(g, link_from_grasp=transform @ g.link_from_grasp) if g.link == root else g
        for g in model.grasp_points
    ]
    return dataclasses.replace(model, links=links, joints=joints, grasp_points=grasps)
