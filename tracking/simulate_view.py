"""The view simulator: an observation of the home rendered from the map's own models, with a
structured-light sensor's noise and the truth to score a fitter against.

    simulator = ViewSimulator.load(map_path)          # models and ray-casting scenes, once
    map_from_camera = simulator.camera_looking_at("fridge_1", distance_m=1.8, height_m=1.4)
    view = simulator.render(camera, map_from_camera, ViewOptions(joint_positions={"fridge_1": {"door_0_hinge": 0.6}}))
    write_view(view, out_dir)                         # depth.png, color.png, camera.yaml, truth.json

The truth (`truth.json`) holds every joint's true position, every object's true map pose
(small objects with their parent and relation), and for each part in the camera's field of
view how many pixels it covers and what fraction of it is visible: its pixels in the view
over its pixels were nothing else in front of it and the image as large as the part (a part
the image's edge cuts is partly unseen)."""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from homemodel.core.atomic import atomic_dir
from homemodel.core.checks import check_nested, require_between, require_positive
from homemodel.core.errors import InputError
from homemodel.core.progress import Progress, StageClock
from homemodel.core.transforms import (
    as_transform,
    rpy_from_rotation,
    transform_from_xyz_rpy,
    world_from_camera_looking_at,
)
from homemodel.geometry.camera import Camera
from semantic_map.nodes import LargeObject, SmallObject
from tracking.observation_files import Observation, write_observation
from tracking.scene import HomeScene, Part, Renderer, Rendering, SceneObject, box_part
from tracking.sensor_noise import SensorNoise, noisy_depth

# Headlight shading of color.png: this much of a colour shows on a surface seen edge-on.
AMBIENT = 0.35
OCCLUDER_THICKNESS_M = 0.1


@dataclass(kw_only=True)
class SmallObjectMove:
    """A small object put at (x, y, yaw) in a large object's frame: its parent's, or
    `parent_id`'s (the object is then re-parented, "on" it). `z_m` None keeps the height on
    the same parent and puts it on the new parent's top surface under (x, y) otherwise."""

    object_id: str
    x_m: float
    y_m: float
    yaw_rad: float
    z_m: float | None = None
    parent_id: str | None = None


@dataclass(kw_only=True)
class BoxOccluder:
    """A box (a person, a chair) between the camera and the home, centred at `map_from_box`."""

    size_m: tuple[float, float, float]
    map_from_box: np.ndarray

    def check(self) -> None:
        for axis, size in zip("xyz", self.size_m):
            require_positive(f"size_m.{axis}", size)
        self.map_from_box = as_transform(self.map_from_box)


@dataclass(kw_only=True)
class ViewOptions:
    """What differs from the map in the simulated home, and the sensor.

    `joint_positions`: {object id: {joint name: rad or m, or a named state}} over the map's;
    `moves`: small objects put elsewhere; `occluders`: boxes in front of the home;
    `occlude`: {object id: fraction}: a box hiding that fraction of the object's pixels,
    from its left edge in the image, half-way between the camera and the object.
    """

    joint_positions: dict[str, dict[str, float | str]] = field(default_factory=dict)
    moves: list[SmallObjectMove] = field(default_factory=list)
    occluders: list[BoxOccluder] = field(default_factory=list)
    occlude: dict[str, float] = field(default_factory=dict)
    noise: SensorNoise = field(default_factory=SensorNoise)

    def check(self) -> None:
        check_nested("noise", self.noise)
        for index, occluder in enumerate(self.occluders):
            check_nested(f"occluders.{index}", occluder)
        for object_id, fraction in self.occlude.items():
            require_between(f"occlude.{object_id}", fraction, 0.0, 0.95)


@dataclass(kw_only=True)
class SimulatedView:
    observation: Observation  # depth with the sensor's noise, colour, camera, truth
    rendering: Rendering  # the exact rendering of the scene's parts and the occluders
    parts: list[Part]  # what `rendering.part_index` indexes: the scene's parts, then the occluders


class ViewSimulator:
    """A map's home ready to be seen from many cameras."""

    def __init__(self, scene: HomeScene) -> None:
        self.scene = scene

    @functools.cached_property
    def renderer(self) -> Renderer:
        """Built on first use, so bad options fail before the ray-casting scenes are built."""
        return Renderer(self.scene.parts)

    @classmethod
    def load(cls, map_path: Path) -> ViewSimulator:
        return cls(HomeScene.load(map_path))

    def camera_looking_at(
        self, object_id: str, *, distance_m: float = 1.8, height_m: float = 1.3, bearing_deg: float = 0.0
    ) -> np.ndarray:
        """`map_from_camera` of a camera `distance_m` (horizontally) in front of an object's
        centre, `height_m` above the floor, looking at the centre. Front is the object's +x
        axis (where the modeller puts doors and drawers); `bearing_deg` turns the camera about
        the object's vertical axis, positive toward its +y."""
        require_positive("distance_m", distance_m)
        obj = self.scene.object(object_id)
        map_from_object = self.scene.map_from_objects()[object_id]
        centre_object = obj.model.world_mesh(self.scene.joint_positions()[object_id]).bounds.mean(axis=0)
        centre = map_from_object[:3, :3] @ centre_object + map_from_object[:3, 3]
        bearing = np.radians(bearing_deg)
        forward = map_from_object[:3, :3] @ np.array([np.cos(bearing), np.sin(bearing), 0.0])
        horizontal = np.array([forward[0], forward[1], 0.0])
        if np.linalg.norm(horizontal) < 1e-6:
            raise InputError(f"object {object_id!r}: its x axis is vertical, so it has no front to look at")
        eye = centre + horizontal / np.linalg.norm(horizontal) * distance_m
        eye[2] = height_m
        return world_from_camera_looking_at(eye, centre)

    def render(
        self,
        camera: Camera,
        map_from_camera: np.ndarray,
        options: ViewOptions | None = None,
        *,
        progress: Progress | None = None,
    ) -> SimulatedView:
        """The observation of the home as `options` change it, seen by `camera` at `map_from_camera`."""
        options = options or ViewOptions()
        options.check()
        clock = StageClock(progress)
        clock.start("pose")
        map_from_camera = as_transform(map_from_camera)
        positions = self.scene.checked_joint_positions(options.joint_positions)
        parents, map_from_small = self._moves(options.moves, positions)
        map_from_objects = self.scene.map_from_objects(map_from_small)
        map_from_parts = self.scene.pose(positions, map_from_small)
        clock.start("render")
        rendering = self.renderer.render(map_from_parts, camera, map_from_camera)
        occluders = list(options.occluders)
        for object_id, fraction in options.occlude.items():
            occluders.append(self._occluder(object_id, fraction, rendering, camera, map_from_camera))
        occluder_parts = [box_part(f"occluder_{i}", o.size_m) for i, o in enumerate(occluders)]
        if occluders:
            boxes = Renderer(occluder_parts).render([o.map_from_box for o in occluders], camera, map_from_camera)
            rendering = _nearest(rendering, boxes, len(self.scene.parts))
        clock.start("visibility")
        visibility = self._visibility(rendering, map_from_parts, camera, map_from_camera)
        clock.start("sensor")
        rays = self.renderer.pixel_rays(camera)
        depth = noisy_depth(rendering.depth_m, rendering.normals_camera, rays, options.noise)
        truth = {
            "noise": options.noise.model,
            "joints": positions,
            "objects": {oid: _pose_truth(self.scene, oid, m, parents) for oid, m in map_from_objects.items()},
            "occluders": [{"size_m": list(o.size_m), "map_from_box": o.map_from_box.tolist()} for o in occluders],
            "parts": visibility,
        }
        observation = Observation(
            camera=camera,
            map_from_camera=map_from_camera,
            depth_m=depth,
            color_rgb=_shaded(rendering, rays),
            truth=truth,
        )
        clock.stop()
        return SimulatedView(observation=observation, rendering=rendering, parts=self.scene.parts + occluder_parts)

    def _moves(
        self, moves: Sequence[SmallObjectMove], positions: dict[str, dict[str, float]]
    ) -> tuple[dict[str, tuple[str, str]], dict[str, np.ndarray]]:
        """(small object id -> (parent, relation), small object id -> map_from_object) of the moves."""
        parents: dict[str, tuple[str, str]] = {}
        map_from_small: dict[str, np.ndarray] = {}
        for move in moves:
            node = self.scene.object(move.object_id).node
            if not isinstance(node, SmallObject):
                raise InputError(f"{self.scene.map_path}: {move.object_id!r} is not a small object (only small objects move)")
            parent_id = move.parent_id or node.parent
            parent = self.scene.object(parent_id)
            if not isinstance(parent.node, LargeObject):
                raise InputError(f"{self.scene.map_path}: {parent_id!r} is not a large object (small objects go on large ones)")
            z_m = move.z_m
            if z_m is None:
                z_m = node.parent_from_object.xyz[2] if parent_id == node.parent else _top_z(parent, positions[parent_id], move)
            roll, pitch, _ = node.parent_from_object.rpy
            parent_from_object = transform_from_xyz_rpy((move.x_m, move.y_m, z_m), (roll, pitch, move.yaw_rad))
            map_from_parent = self.scene.map_from_objects()[parent_id]
            map_from_small[move.object_id] = map_from_parent @ parent_from_object
            parents[move.object_id] = (parent_id, node.relation if parent_id == node.parent else "on")
        return parents, map_from_small

    def _occluder(
        self, object_id: str, fraction: float, rendering: Rendering, camera: Camera, map_from_camera: np.ndarray
    ) -> BoxOccluder:
        """A box, square to the camera, hiding the left `fraction` of the object's pixels."""
        mine = np.isin(rendering.part_index, self.scene.part_indices(object_id))
        if not mine.any():
            raise InputError(f"cannot occlude {object_id!r}: it is not in the camera's view")
        v, u = np.nonzero(mine)
        columns = np.sort(u)
        right = columns[min(int(round(fraction * len(columns))), len(columns) - 1)]
        depth_m = 0.5 * float(np.median(rendering.depth_m[mine]))
        corners = camera.rays(np.array([[u.min() - 2.0, v.min() - 2.0], [right + 0.5, v.max() + 2.0]])) * depth_m
        (x0, y0, _), (x1, y1, _) = corners
        camera_from_box = np.eye(4)
        camera_from_box[:3, 3] = ((x0 + x1) / 2, (y0 + y1) / 2, depth_m)
        size = (max(x1 - x0, 1e-3), max(y1 - y0, 1e-3), OCCLUDER_THICKNESS_M)
        return BoxOccluder(size_m=size, map_from_box=as_transform(map_from_camera) @ camera_from_box)

    def _visibility(
        self, rendering: Rendering, map_from_parts: list[np.ndarray], camera: Camera, map_from_camera: np.ndarray
    ) -> list[dict]:
        """Per object part in the field of view: pixels seen, pixels alone, the visible fraction."""
        counts = np.bincount(rendering.part_index[rendering.hit], minlength=len(self.scene.parts))
        result = []
        for index, part in enumerate(self.scene.parts):
            if part.object_id is None:
                continue
            alone = self.renderer.pixels_alone(index, map_from_parts[index], camera, map_from_camera, whole=True)
            if alone == 0:
                continue
            seen = int(counts[index])
            result.append(
                {
                    "object": part.object_id,
                    "link": part.link,
                    "joint": part.joint,
                    "pixels": seen,
                    "pixels_unoccluded": alone,
                    "visible_fraction": round(seen / alone, 4),
                }
            )
        return result


def unlike_their_models(scene: HomeScene, *, off_m: float, seed: int = 0) -> HomeScene:
    """The scene's furniture as it may really be beside the models an installer measured:
    each link of each object between 0.6 and 1 times `off_m` larger or smaller along each of
    its axes (about its centre) and shifted by up to half `off_m` along each, the joints'
    origins and the objects' poses unchanged. The parts are replaced in `scene`, returned."""
    import dataclasses

    require_positive("off_m", off_m)
    rng = np.random.default_rng(seed)
    parts = []
    for part in scene.parts:
        if part.object_id is not None:
            low, high = part.vertices_link.min(axis=0), part.vertices_link.max(axis=0)
            size = np.maximum(high - low, 1e-6)
            scale = np.maximum(size + rng.uniform(0.6, 1.0, 3) * off_m * rng.choice([-1.0, 1.0], 3), size / 2) / size
            shift = rng.uniform(-0.5, 0.5, 3) * off_m
            centre = (low + high) / 2
            part = dataclasses.replace(part, vertices_link=(part.vertices_link - centre) * scale + centre + shift)
        parts.append(part)
    scene.parts = parts
    return scene


def write_view(view: SimulatedView, out_dir: Path, *, force: bool = False, inputs: Sequence[Path] = ()) -> None:
    """Write the observation folder at once (nothing half-written); a non-empty `out_dir` only with `force`."""
    with atomic_dir(out_dir, force=force, inputs=inputs) as tmp:
        write_observation(tmp, view.observation)


def _nearest(scene: Rendering, boxes: Rendering, offset: int) -> Rendering:
    """The two renderings merged pixel by pixel, the nearer hit winning; `boxes`' part
    indices shifted by `offset`."""
    nearer = boxes.hit & (~scene.hit | (boxes.depth_m < scene.depth_m))
    return Rendering(
        depth_m=np.where(nearer, boxes.depth_m, scene.depth_m),
        part_index=np.where(nearer, boxes.part_index + offset, scene.part_index),
        normals_camera=np.where(nearer[..., None], boxes.normals_camera, scene.normals_camera),
        rgb=np.where(nearer[..., None], boxes.rgb, scene.rgb),
    )


def _shaded(rendering: Rendering, rays: np.ndarray) -> np.ndarray:
    """8-bit RGB: each surface's colour lit by a lamp at the camera."""
    directions = rays / np.linalg.norm(rays, axis=1, keepdims=True)
    cosine = np.abs(np.einsum("ij,ij->i", rendering.normals_camera.reshape(-1, 3), directions))
    light = (AMBIENT + (1 - AMBIENT) * cosine).reshape(rendering.depth_m.shape)
    return np.clip(np.round(rendering.rgb * light[..., None] * 255), 0, 255).astype(np.uint8)


def _top_z(parent: SceneObject, joint_positions: dict[str, float], move: SmallObjectMove) -> float:
    """The height of the parent's top surface under (x, y) in its frame."""
    from homemodel.geometry.raycast import RayCaster

    mesh = parent.model.world_mesh(joint_positions)
    origin = np.array([move.x_m, move.y_m, mesh.bounds[1][2] + 1.0])
    hits = RayCaster(mesh).first_hits(origin, np.array([[0.0, 0.0, -1.0]]))
    if not hits.hit[0]:
        raise InputError(f"cannot move {move.object_id!r} to ({move.x_m}, {move.y_m}) on {parent.id!r}: nothing of it is there")
    return float(origin[2] - hits.t[0])


def _pose_truth(scene: HomeScene, object_id: str, map_from_object: np.ndarray, moved: dict[str, tuple[str, str]]) -> dict:
    node = scene.object(object_id).node
    truth: dict = {"map_from_object": np.round(map_from_object, 9).tolist()}
    if isinstance(node, SmallObject):
        parent, relation = moved.get(object_id, (node.parent, node.relation))
        parent_from_object = np.linalg.inv(scene.map_from_objects()[parent]) @ map_from_object
        truth.update(
            parent=parent,
            relation=relation,
            xyz_in_parent=np.round(parent_from_object[:3, 3], 9).tolist(),
            yaw_in_parent_rad=round(float(rpy_from_rotation(parent_from_object[:3, :3])[2]), 9),
        )
    return truth
