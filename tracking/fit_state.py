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
    # The fitters pose the same objects at the same joint positions thousands of times.
    _links: dict[tuple, dict[str, np.ndarray]] = field(default_factory=dict, repr=False)
    _object_parts: dict[str, list[int]] = field(default_factory=dict, repr=False)

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
        if object_id not in self._object_parts:
            self._object_parts[object_id] = self.scene.part_indices(object_id)
        return [i for i in self._object_parts[object_id] if not (fixed_only and self.scene.parts[i].joint)]

    def background_depth(self, view: FitView, object_id: str) -> np.ndarray:
        """Depth of everything large-object fits render but `object_id` (inf where nothing is
        hit): what stays put while that object is fitted."""
        others = [i for i in self.context_parts if self.scene.parts[i].object_id != object_id]
        return self.renderer.depth(self.map_from_parts(), view.camera, view.map_from_camera, others)

    def map_from_parts(self) -> list[np.ndarray]:
        """`map_from_link` of every part at the current estimates."""
        identity = np.eye(4)
        links = {object_id: self.object_from_links(object_id) for object_id in self.map_from_objects}
        return [
            identity if part.object_id is None
            else self.map_from_objects[part.object_id] @ links[part.object_id][part.link]
            for part in self.scene.parts
        ]

    def object_from_links(self, object_id: str, positions: dict[str, float] | None = None) -> dict[str, np.ndarray]:
        """The model's `world_from_links` (its root frame the object's) at `positions`, or at
        the current estimates; cached (the returned arrays are shared: do not change them)."""
        positions = self.joint_positions[object_id] if positions is None else positions
        key = (object_id, *sorted(positions.items()))
        if key not in self._links:
            if len(self._links) > 4096:
                self._links.clear()
            self._links[key] = self.scene.object(object_id).model.world_from_links(positions)
        return self._links[key]

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
        links = self.object_from_links(object_id, {**self.joint_positions[object_id], joint: float(position)})
        map_from_object = self.map_from_objects[object_id]
        return [map_from_object @ links[self.scene.parts[i].link] for i in parts]
