"""What the fitters change as they go: each object's pose in the map and its joints'
positions, over one `HomeScene` and its `Renderer` (built once per observation)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tracking.fit_view import FitView
from tracking.scene import HomeScene, Renderer


@dataclass(kw_only=True)
class FitState:
    """The scene at the current estimates. Large-object fits render `context_parts`: the
    large objects and the floor and walls, never the small objects (they may have moved; a
    cup in front of a door is an occluder to the door's fit)."""

    scene: HomeScene
    renderer: Renderer
    map_from_objects: dict[str, np.ndarray] = field(default_factory=dict)
    joint_positions: dict[str, dict[str, float]] = field(default_factory=dict)

    @classmethod
    def start(cls, scene: HomeScene) -> FitState:
        return cls(
            scene=scene,
            renderer=Renderer(scene.parts),
            map_from_objects=scene.map_from_objects(),
            joint_positions=scene.joint_positions(),
        )

    @property
    def context_parts(self) -> list[int]:
        return [
            i for i, part in enumerate(self.scene.parts)
            if part.object_id is None or not self.scene.objects[part.object_id].is_small
        ]

    def object_parts(self, object_id: str, *, fixed_only: bool = False) -> list[int]:
        """One object's parts; `fixed_only`: only the links no movable joint carries."""
        return [i for i in self.scene.part_indices(object_id) if not (fixed_only and self.scene.parts[i].joint)]

    def background_depth(self, view: FitView, object_id: str) -> np.ndarray:
        """Depth of everything large-object fits render but `object_id` (inf where nothing is
        hit): what stays put while that object is fitted."""
        others = [i for i in self.context_parts if self.scene.parts[i].object_id != object_id]
        return self.renderer.depth(self.map_from_parts(), view.camera, view.map_from_camera, others)

    def map_from_parts(self) -> list[np.ndarray]:
        """`map_from_link` of every part at the current estimates."""
        return self.scene.pose(self.joint_positions, self.map_from_objects)

    def moving_parts(self, object_id: str, joint: str) -> list[int]:
        """The parts `joint` carries: its child link and everything downstream of it."""
        model = self.scene.object(object_id).model
        parent_joint = {j.child: j for j in model.joints}
        carried = []
        for i in self.scene.part_indices(object_id):
            link = self.scene.parts[i].link
            while link in parent_joint:
                if parent_joint[link].name == joint:
                    carried.append(i)
                    break
                link = parent_joint[link].parent
        return carried

    def part_poses_at(self, object_id: str, joint: str, position: float, parts: list[int]) -> list[np.ndarray]:
        """`map_from_link` of `parts` (of `object_id`) with `joint` at `position`, the other
        joints at their estimates."""
        positions = {**self.joint_positions[object_id], joint: float(position)}
        links = self.scene.object(object_id).model.world_from_links(positions)
        map_from_object = self.map_from_objects[object_id]
        return [map_from_object @ links[self.scene.parts[i].link] for i in parts]
