"""The map's models as a scene a depth camera sees: every link of every object as a part,
posed at joint positions and object poses, and ray-cast from a camera.

The fitter (`tracking.observe`) and the view simulator (`tracking.simulate_view`) share it:

    scene = HomeScene.load(map_path)                      # the models, read once
    map_from_parts = scene.pose({"fridge_1": {"door": 1.2}})
    renderer = Renderer(scene.parts)                      # one Open3D scene per part, built once
    rendering = renderer.render(map_from_parts, camera, map_from_camera)

A part is one link of one object (or the floor, or a wall of a room's outline), its mesh in
the link frame. Re-posing costs nothing: the renderer casts each part's rays in the part's
own frame, and only the pixels inside the part's projected bounds, so a door swung to a new
angle needs no new acceleration structure.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from articulation.model import Model
from articulation.scene import walls_from_outlines
from homemodel.core.errors import InputError, MapError
from homemodel.core.transforms import as_transform
from homemodel.geometry.camera import Camera
from homemodel.geometry.raycast import Hits, RayCaster
from semantic_map.hierarchy import SemanticMap
from homemodel.exchange.home_scene import model_path
from semantic_map.nodes import Jointed, MapObject, ObjectJoint, SmallObject
from homemodel.exchange.map_xml import load_map

FLOOR_RGB = (0.62, 0.58, 0.52)
WALL_RGB = (0.88, 0.87, 0.84)
# Nothing nearer the camera than this is seen (depth cameras see nothing within 0.2-0.5 m).
NEAR_M = 0.05
# The floor reaches this far past the rooms' outlines (or the objects, without outlines).
FLOOR_MARGIN_M = 2.0
# The modeller names a door's glass pane's visual "<link>.window": a depth camera sees through
# glass or gets no reading from it, so a fit may ask for its pixels as unknown (`glass_unknown`).
GLASS_VISUAL_MARK = ".window"


@dataclass(frozen=True, eq=False)
class Part:
    """One rigid piece of the scene: a link of a map object, or the floor or a wall.

    `object_id` is the map object the link belongs to (None for the floor and walls);
    `joint` is the nearest movable joint between the link and the object's root (None for a
    fixed link); `face_rgb` is the colour (0..1) of each triangle, from its visual's material;
    `face_glass` marks the triangles of glass panes (None when the part has none).
    """

    object_id: str | None
    link: str
    joint: str | None
    vertices_link: np.ndarray  # (V, 3) float64, in the link frame
    faces: np.ndarray  # (F, 3) int64
    face_rgb: np.ndarray  # (F, 3) float64
    face_glass: np.ndarray | None = None  # (F,) bool

    @property
    def name(self) -> str:
        return f"{self.object_id}/{self.link}" if self.object_id else self.link

    @property
    def rgb(self) -> np.ndarray:
        """The part's colour: its triangles' colours weighted by area."""
        mesh = trimesh.Trimesh(self.vertices_link, self.faces, process=False)
        return np.average(self.face_rgb, axis=0, weights=mesh.area_faces + 1e-12)


@dataclass(kw_only=True)
class SceneObject:
    """A map object with its model: the object's frame is the model's root link frame."""

    node: MapObject
    model: Model

    @property
    def id(self) -> str:
        return self.node.id

    @property
    def is_small(self) -> bool:
        return isinstance(self.node, SmallObject)


@dataclass(kw_only=True)
class HomeScene:
    """The map, its objects' models, and their parts (in a fixed order the renderer keeps)."""

    map_path: Path
    smap: SemanticMap
    objects: dict[str, SceneObject]
    parts: list[Part]

    @classmethod
    def load(cls, map_path: Path, *, structure: bool = True, smap: SemanticMap | None = None) -> HomeScene:
        """Read the map (or use `smap`, loaded from `map_path`) and every object's model.
        `structure` adds the floor (z = 0) and walls on the rooms' outlines as parts."""
        from homemodel.exchange.urdf.read import load_urdf

        map_path = Path(map_path)
        if smap is None:
            try:
                smap = load_map(map_path)
            except MapError as exc:
                raise InputError(exc if str(map_path) in str(exc) else f"{map_path}: {exc}") from None
        objects: dict[str, SceneObject] = {}
        parts: list[Part] = []
        models: dict[Path, Model] = {}  # read once, however many objects share one (two chairs)
        for node in smap.objects():
            path = model_path(map_path, node)
            if path not in models:
                models[path] = load_urdf(path)
            model = models[path]
            objects[node.id] = SceneObject(node=node, model=model)
            parts.extend(_model_parts(node.id, model))
        if not objects:
            raise InputError(f"{map_path}: the map has no objects")
        scene = cls(map_path=map_path, smap=smap, objects=objects, parts=parts)
        if structure:
            scene._add_structure()
        return scene

    def _add_structure(self) -> None:
        rooms = [(room.id, room.outline) for room in self.smap.apartment.rooms if room.outline is not None]
        if rooms:
            corners = np.array([c for _, outline in rooms for c in outline])
        else:
            corners = np.array([self.smap.world_from_object(o)[:2, 3] for o in self.objects])
        low, high = corners.min(axis=0) - FLOOR_MARGIN_M, corners.max(axis=0) + FLOOR_MARGIN_M
        floor = trimesh.creation.box(extents=(*(high - low), 0.02))
        floor.apply_translation((*((low + high) / 2), -0.01))  # the top face at z = 0
        self._add_fixed("floor", floor, FLOOR_RGB)
        for wall in walls_from_outlines(rooms):
            self._add_fixed(wall.name, trimesh.creation.box(extents=wall.size_m, transform=wall.world_from_wall()), WALL_RGB)

    def _add_fixed(self, name: str, mesh_map: trimesh.Trimesh, rgb: tuple[float, float, float]) -> None:
        # The floor and walls are fixed: their link frame is the map frame.
        faces = np.asarray(mesh_map.faces, dtype=np.int64)
        colours = np.tile(np.asarray(rgb, dtype=np.float64), (len(faces), 1))
        self.parts.append(Part(object_id=None, link=name, joint=None,
                               vertices_link=np.asarray(mesh_map.vertices, dtype=np.float64), faces=faces,
                               face_rgb=colours))

    # Queries

    def object(self, object_id: str) -> SceneObject:
        try:
            return self.objects[object_id]
        except KeyError:
            raise InputError(
                f"{self.map_path}: no object {object_id!r} (objects: {', '.join(sorted(self.objects))})"
            ) from None

    def part_indices(self, object_id: str) -> list[int]:
        """The indices in `parts` of one object's links."""
        self.object(object_id)
        return [i for i, part in enumerate(self.parts) if part.object_id == object_id]

    def joint_positions(self) -> dict[str, dict[str, float]]:
        """Every object's joint positions as the map stores them."""
        return {
            oid: {j.name: j.position for j in obj.node.joints} if isinstance(obj.node, Jointed) else {}
            for oid, obj in self.objects.items()
        }

    def checked_joint_positions(
        self, joint_positions: Mapping[str, Mapping[str, float | str]] | None
    ) -> dict[str, dict[str, float]]:
        """The map's joint positions with `joint_positions` ({object id: {joint: rad or m, or
        text: a named state such as "open", or a number}}) over them; an unknown object, joint
        or state, or a position outside the limits, is an error."""
        positions = self.joint_positions()
        for object_id, joints in (joint_positions or {}).items():
            node = self.object(object_id).node
            for name, value in joints.items():
                if not isinstance(node, Jointed) or not node.joints:
                    raise InputError(f"{self.map_path}: object {object_id!r} has no joints (asked for {name!r})")
                try:
                    joint = node.joint(name)
                    if isinstance(value, str):
                        value = _named_state(joint, value)
                    positions[object_id][name] = joint.check_position(value)
                except MapError as exc:
                    raise InputError(f"{self.map_path}: object {object_id!r}: {exc}") from None
        return positions

    # Posing

    def map_from_objects(self, map_from_objects: Mapping[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
        """Every object's pose in the map: the map's poses, with `map_from_objects` over them.

        A small object rides on its parent: moving a table moves the cups on it, unless a
        cup's own pose is given.
        """
        given = {oid: as_transform(m) for oid, m in (map_from_objects or {}).items()}
        for object_id in given:
            self.object(object_id)
        result: dict[str, np.ndarray] = {}
        for object_id, obj in self.objects.items():
            if object_id in given:
                result[object_id] = given[object_id]
            elif isinstance(obj.node, SmallObject):
                parent = given.get(obj.node.parent, self.smap.world_from_object(obj.node.parent))
                result[object_id] = parent @ obj.node.parent_from_object.matrix()
            else:
                result[object_id] = self.smap.world_from_object(object_id)
        return result

    def pose(
        self,
        joint_positions: Mapping[str, Mapping[str, float]] | None = None,
        map_from_objects: Mapping[str, np.ndarray] | None = None,
    ) -> list[np.ndarray]:
        """`map_from_link` of every part, in the order of `parts`: the objects at their map
        poses (or `map_from_objects`), their joints at the map's positions (or those of
        `joint_positions`, {object id: {joint name: rad or m}})."""
        positions = self.checked_joint_positions(joint_positions)
        objects = self.map_from_objects(map_from_objects)
        links = {oid: obj.model.world_from_links(positions[oid]) for oid, obj in self.objects.items()}
        return [
            np.eye(4) if part.object_id is None else objects[part.object_id] @ links[part.object_id][part.link]
            for part in self.parts
        ]


def _named_state(joint: ObjectJoint, text: str) -> float:
    """A joint position given as text: a named state of the joint (an oven knob's "2" is its
    state, not 2 rad), else a number."""
    for state in joint.states:
        if state.name == text:
            return state.position
    try:
        return float(text)
    except ValueError:
        raise MapError(
            f"joint {joint.name!r}: {text!r} is neither a number nor one of its states {[s.name for s in joint.states]}"
        ) from None


def _model_parts(object_id: str, model: Model) -> list[Part]:
    parts = []
    for link in model.links:
        if not link.visuals:
            continue
        vertices, faces, colours, glass, offset = [], [], [], [], 0
        for visual in link.visuals:
            mesh = visual.mesh
            vertices.append(trimesh.transform_points(np.asarray(mesh.vertices, dtype=np.float64), visual.link_from_visual))
            faces.append(np.asarray(mesh.faces, dtype=np.int64) + offset)
            colours.append(np.tile(np.asarray(visual.material.rgba[:3], dtype=np.float64), (len(mesh.faces), 1)))
            glass.append(np.full(len(mesh.faces), GLASS_VISUAL_MARK in visual.name))
            offset += len(mesh.vertices)
        driving = model.joint_driving(link.name)
        parts.append(
            Part(
                object_id=object_id,
                link=link.name,
                joint=None if driving is None else driving.name,
                vertices_link=np.concatenate(vertices),
                faces=np.concatenate(faces),
                face_rgb=np.concatenate(colours),
                face_glass=np.concatenate(glass) if any(g.any() for g in glass) else None,
            )
        )
    return parts


def box_part(name: str, size_m: Sequence[float], rgb: Sequence[float] = (0.35, 0.3, 0.3)) -> Part:
    """A box centred on its frame, e.g. an occluder (a person, a chair) placed with its own
    `map_from_link` beside the scene's."""
    box = trimesh.creation.box(extents=[float(s) for s in size_m])
    faces = np.asarray(box.faces, dtype=np.int64)
    return Part(object_id=None, link=name, joint=None, vertices_link=np.asarray(box.vertices, dtype=np.float64),
                faces=faces, face_rgb=np.tile(np.asarray(rgb, dtype=np.float64), (len(faces), 1)))


@dataclass(kw_only=True)
class Rendering:
    """What each pixel of a camera sees of a set of posed parts."""

    depth_m: np.ndarray  # (H, W) float64 depth along the optical axis; 0 where nothing is hit
    part_index: np.ndarray  # (H, W) int64 index into the rendered parts; -1 where nothing is hit
    normals_camera: np.ndarray  # (H, W, 3) unit normals facing the camera, camera frame; 0 where nothing is hit
    rgb: np.ndarray  # (H, W, 3) float64 colour of the hit triangle (0..1); 0 where nothing is hit

    @property
    def hit(self) -> np.ndarray:
        return self.part_index >= 0


@dataclass(frozen=True, eq=False)
class _PixelTable:
    """What the renderer needs of a camera, worked out once: its pixels' rays, each pixel's
    flat index on the image grid, and its numbers as plain floats (a fitter asks for the
    pixels of a part's box thousands of times; the pydantic `Camera`'s properties and hash
    cost more than the arithmetic)."""

    key: tuple  # the camera's numbers: a cheap key for the depth cache
    rays: np.ndarray  # (H * W, 3) rays with z = 1, row by row
    flat: np.ndarray  # (H, W) int64 flat index of each pixel
    grid_rays: np.ndarray  # (H, W, 3) `rays` on the image grid
    fx: float
    fy: float
    cx: float
    cy: float
    distorted: bool

    @classmethod
    def of(cls, camera: Camera) -> _PixelTable:
        rays = camera.pixel_rays()
        return cls(key=tuple(camera.model_dump().values()), rays=rays,
                   flat=np.arange(camera.width * camera.height).reshape(camera.height, camera.width),
                   grid_rays=rays.reshape(camera.height, camera.width, 3),
                   fx=camera.fx, fy=camera.fy, cx=camera.cx, cy=camera.cy, distorted=camera.has_distortion)


class Renderer:
    """Parts ready to be ray-cast at any poses: one acceleration structure per part, built once."""

    def __init__(self, parts: Sequence[Part]) -> None:
        self.parts = list(parts)
        self._casters = [RayCaster(trimesh.Trimesh(p.vertices_link, p.faces, process=False)) for p in self.parts]
        # A part with glass is also cast as its solid triangles and its glass ones apart, to know
        # which a depth ray meets first (`_signed_depths`).
        self._glass_casters = {
            i: tuple(RayCaster(trimesh.Trimesh(p.vertices_link, p.faces[keep], process=False))
                     for keep in (~p.face_glass, p.face_glass))
            for i, p in enumerate(self.parts) if p.face_glass is not None
        }
        self._corners = [box_corners(p.vertices_link) for p in self.parts]
        self._tables: dict[Camera, _PixelTable] = {}
        self._depths: OrderedDict[tuple, tuple[np.ndarray, np.ndarray]] = OrderedDict()
        self._depth_pixels = 0
        self._last_rendering: tuple[tuple, Rendering] | None = None

    def _table(self, camera: Camera) -> _PixelTable:
        # Kept for the few cameras of one observation: its views and crops.
        if camera not in self._tables:
            if len(self._tables) >= 16:
                self._tables.clear()
            self._tables[camera] = _PixelTable.of(camera)
        return self._tables[camera]

    def pixel_rays(self, camera: Camera) -> np.ndarray:
        """(H * W, 3) rays with z = 1 through every pixel of `camera`, row by row."""
        return self._table(camera).rays

    def render(
        self,
        map_from_parts: Sequence[np.ndarray],
        camera: Camera,
        map_from_camera: np.ndarray,
        *,
        only: Sequence[int] | None = None,
    ) -> Rendering:
        """Depth, part index, normal and colour at every pixel of `camera` at `map_from_camera`,
        the parts at `map_from_parts` (one per part); `only` renders a subset of part indices.
        Its arrays are read-only: the last rendering is given again when asked again (a fitter
        whose step left the pose where it was renders it anew)."""
        if len(map_from_parts) != len(self.parts):
            raise ValueError(f"{len(map_from_parts)=} but expected {len(self.parts)} (one pose per part)")
        parts = range(len(self.parts)) if only is None else only
        key = (self._table(camera).key, as_transform(map_from_camera).tobytes(), tuple(parts),
               *(as_transform(map_from_parts[i]).tobytes() for i in parts))
        if self._last_rendering is not None and self._last_rendering[0] == key:
            return self._last_rendering[1]
        rendering = self._render(map_from_parts, camera, map_from_camera, parts)
        for array in (rendering.depth_m, rendering.part_index, rendering.normals_camera, rendering.rgb):
            array.flags.writeable = False
        self._last_rendering = (key, rendering)
        return rendering

    def _render(
        self, map_from_parts: Sequence[np.ndarray], camera: Camera, map_from_camera: np.ndarray, parts: Sequence[int]
    ) -> Rendering:
        n = camera.width * camera.height
        depth = np.full(n, np.inf)
        index = np.full(n, -1, dtype=np.int64)
        camera_from_map = np.linalg.inv(as_transform(map_from_camera))
        casts = []
        for i in parts:
            camera_from_part = camera_from_map @ as_transform(map_from_parts[i])
            cast = self._cast(i, camera, camera_from_part)
            if cast is None:
                continue
            pixels, _, hits = cast
            t = hits.t.astype(np.float64)
            closer = hits.hit & (t >= NEAR_M) & (t < depth[pixels])
            depth[pixels[closer]] = t[closer]
            index[pixels[closer]] = i
            casts.append((i, camera_from_part, cast, int(closer.sum())))
        # Normals and colours only where each part is the surface seen, not where a later part covers it.
        normals = np.zeros((n, 3))
        rgb = np.zeros((n, 3))
        for i, camera_from_part, (pixels, rays, hits), closer_count in casts:
            seen = index[pixels] == i
            chosen = pixels[seen]
            normal = _rotated(hits.normals[seen], camera_from_part[:3, :3], closer_count)
            facing = np.sign(np.einsum("ij,ij->i", normal, rays[seen]))
            normals[chosen] = -normal * np.where(facing == 0, 1.0, facing)[:, None]
            rgb[chosen] = self.parts[i].face_rgb[hits.triangle[seen]]
        depth[index < 0] = 0.0
        shape = (camera.height, camera.width)
        return Rendering(
            depth_m=depth.reshape(shape),
            part_index=index.reshape(shape),
            normals_camera=normals.reshape(*shape, 3),
            rgb=rgb.reshape(*shape, 3),
        )


    def depth(
        self, map_from_parts: Sequence[np.ndarray], camera: Camera, map_from_camera: np.ndarray, only: Sequence[int],
        *, glass_unknown: bool = False,
    ) -> np.ndarray:
        """(H, W) depth of the parts `only` alone, inf where none is hit: what a fitter
        scoring many poses of one part needs, without `render`'s normals and colours.
        Each part's depth is kept for the last few poses asked (a fitter renders the parts
        it does not move, and the floor and walls, again and again). `glass_unknown`: NaN
        where a glass pane is the nearest surface (glass as solid otherwise)."""
        return self.depth_stack([map_from_parts], camera, map_from_camera, only, glass_unknown=glass_unknown)[0]

    def depth_stack(
        self,
        map_from_parts: Sequence[Sequence[np.ndarray]],
        camera: Camera,
        map_from_camera: np.ndarray,
        only: Sequence[int],
        *,
        glass_unknown: bool = False,
    ) -> np.ndarray:
        """(K, H, W) depth of the parts `only` at K poses each (`map_from_parts[k]`: one pose
        per part of the scene, as for `depth`), inf where none is hit: a joint's candidate
        positions, each part's K poses cast in one batch. `glass_unknown` as for `depth`."""
        n = camera.width * camera.height
        stack = np.full(len(map_from_parts) * n, np.inf)
        glass = np.zeros(len(stack), dtype=bool) if glass_unknown and self._glass_casters.keys() & set(only) else None
        camera_from_map = np.linalg.inv(as_transform(map_from_camera))
        table = self._table(camera)
        for order, i in enumerate(only):
            # A part at a pose cast before (the body, as a joint moves; the search's current
            # estimate, round after round) is cast once.
            camera_from_parts = camera_from_map @ np.array([poses[i] for poses in map_from_parts], dtype=np.float64)
            casts: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
            keys, missing = [], {}
            for camera_from_part in camera_from_parts:
                key = (i, table.key, camera_from_part.tobytes())
                keys.append(key)
                cast = self._depths.get(key)
                if cast is not None:
                    self._depths.move_to_end(key)
                    casts[key] = cast
                elif key not in casts:
                    missing[key] = camera_from_part
            if missing:
                for key, cast in zip(missing, self._cast_depths(i, table, np.array(list(missing.values())))):
                    casts[key] = cast
                    self._remember(key, *cast)
            cells = np.concatenate([k * n + casts[key][0] for k, key in enumerate(keys)])
            depths = np.concatenate([casts[key][1] for key in keys])
            if glass is not None:
                # A glass pixel stays glass while no nearer part covers it.
                glass[cells] = np.where(np.abs(depths) < stack[cells], depths < 0, glass[cells])
            # The first part's cells (each once) are all inf yet: min(inf, t) is t.
            stack[cells] = np.abs(depths) if order == 0 else np.minimum(stack[cells], np.abs(depths))
        if glass is not None:
            stack[glass] = np.nan
        return stack.reshape(len(map_from_parts), camera.height, camera.width)

    def depth_at(
        self,
        map_from_parts: Sequence[np.ndarray],
        camera: Camera,
        map_from_camera: np.ndarray,
        only: Sequence[int],
        pixels: np.ndarray,
    ) -> np.ndarray:
        """`depth(...)` at the flat pixel indices `pixels` alone, the same numbers: only their
        rays are cast (scattered pixels, a third of their window), and nothing is kept."""
        pixels = np.asarray(pixels, dtype=np.int64)
        depth = np.full(len(pixels), np.inf)
        camera_from_map = np.linalg.inv(as_transform(map_from_camera))
        table = self._table(camera)
        rows, columns = np.divmod(pixels, table.flat.shape[1])
        for i in only:
            # As `depth_stack` works out a part's one pose, for the same bits.
            camera_from_parts = camera_from_map @ np.array([map_from_parts[i]], dtype=np.float64)
            box = _window_boxes(table, camera_from_parts, self._corners[i])[0]
            if box is None:
                window = _pixels_in_view(table, camera_from_parts[0], self._corners[i])
                in_window = 0 if window is None else len(window[0])
                chosen = np.flatnonzero(np.isin(pixels, window[0])) if in_window else np.empty(0, np.int64)
            else:
                left, top, right, bottom = box
                in_window = max(right - left + 1, 0) * max(bottom - top + 1, 0)
                chosen = np.flatnonzero((columns >= left) & (columns <= right) & (rows >= top) & (rows <= bottom))
            if not len(chosen):
                continue
            part_from_camera = np.linalg.inv(camera_from_parts)[0]
            rays = np.empty((len(chosen), 6), dtype=np.float32)
            rays[:, :3] = part_from_camera[:3, 3]
            # `depth_stack` turns the window's rays in one product: a single row's bits differ.
            rays[:, 3:] = _rotated(table.rays[pixels[chosen]], part_from_camera[:3, :3], in_window)
            depth[chosen] = np.minimum(depth[chosen], np.abs(self._signed_depths(i, rays)))
        return depth

    def pixels_whole(
        self, map_from_parts: Sequence[np.ndarray], camera: Camera, map_from_camera: np.ndarray, only: Sequence[int],
        *, glass_unknown: bool = False,
    ) -> int:
        """How many pixels the parts `only` cover together with nothing else in the scene, on
        an image grown past `camera`'s edges to hold all of them (`widened`); `glass_unknown`:
        their glass panes' pixels left out."""
        camera_from_map = np.linalg.inv(as_transform(map_from_camera))
        poses = [camera_from_map @ as_transform(map_from_parts[i]) for i in only]
        corners = np.concatenate([self._corners[i] @ m[:3, :3].T + m[:3, 3] for i, m in zip(only, poses)])
        depth = self.depth(map_from_parts, widened(camera, corners), map_from_camera, only, glass_unknown=glass_unknown)
        return int(np.isfinite(depth).sum())

    # Pixels of part depths kept by `depth` (float64 and int64: 16 bytes each).
    DEPTH_CACHE_PIXELS = 2_000_000

    def _remember(self, key: tuple, pixels: np.ndarray, t: np.ndarray) -> None:
        self._depths[key] = (pixels, t)
        self._depth_pixels += len(pixels)
        while self._depth_pixels > self.DEPTH_CACHE_PIXELS and len(self._depths) > 1:
            _, (dropped, _) = self._depths.popitem(last=False)
            self._depth_pixels -= len(dropped)

    def _cast_depths(
        self, index: int, table: _PixelTable, camera_from_parts: np.ndarray
    ) -> list[tuple[np.ndarray, np.ndarray]]:
        """(flat pixel indices, float64 depth there, inf where missed or nearer than
        `NEAR_M`, negated where glass is met first) of part `index` at each pose ((K, 4, 4)
        `camera_from_parts`), all the poses' rays in one cast."""
        windows = _windows(table, camera_from_parts, self._corners[index])
        pixel_sets = [pixels for pixels, _ in windows]
        ends = np.cumsum([len(p) for p in pixel_sets])
        if not ends[-1]:
            return [(p, np.empty(0)) for p in pixel_sets]
        # Every pose's rays in one buffer as the caster takes them (float32, origin then direction).
        parts_from_camera = np.linalg.inv(camera_from_parts)
        buffer = np.empty((ends[-1], 6), dtype=np.float32)
        for (pixels, rays), part_from_camera, end in zip(windows, parts_from_camera, ends):
            if len(pixels):
                buffer[end - len(pixels):end, :3] = part_from_camera[:3, 3]
                buffer[end - len(pixels):end, 3:] = rays @ part_from_camera[:3, :3].T
        return list(zip(pixel_sets, np.split(self._signed_depths(index, buffer), ends[:-1])))

    def _signed_depths(self, index: int, rays: np.ndarray) -> np.ndarray:
        """(N,) float64 distance along each ray ((N, 6) float32, as the caster takes them) to
        part `index`, inf where missed or nearer than `NEAR_M`, negated where the first
        surface met is glass."""
        def distances(caster: RayCaster) -> np.ndarray:
            t = caster.hit_distances_of(rays).astype(np.float64)
            t[t < NEAR_M] = np.inf
            return t

        if index not in self._glass_casters:
            return distances(self._casters[index])
        solid, glass = map(distances, self._glass_casters[index])
        return np.where(glass < solid, -glass, solid)

    def pixels_alone(
        self, index: int, map_from_part: np.ndarray, camera: Camera, map_from_camera: np.ndarray, *, whole: bool = False
    ) -> int:
        """How many pixels part `index` at `map_from_part` covers with nothing else in the
        scene; `whole`: counted on an image grown past `camera`'s edges to hold all of it (a
        part the image's edge cuts is partly unseen, like one something covers)."""
        camera_from_part = np.linalg.inv(as_transform(map_from_camera)) @ as_transform(map_from_part)
        if _pixels_in_view(self._table(camera), camera_from_part, self._corners[index]) is None:
            return 0
        if whole:
            camera = widened(camera, self._corners[index] @ camera_from_part[:3, :3].T + camera_from_part[:3, 3])
        cast = self._cast(index, camera, camera_from_part)
        return 0 if cast is None else int((cast[2].hit & (cast[2].t >= NEAR_M)).sum())

    def _cast(
        self, index: int, camera: Camera, camera_from_part: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, Hits] | None:
        """(flat pixel indices, their (N, 3) rays in the camera frame, their hits) of the rays
        that may reach part `index`, or None."""
        window = _pixels_in_view(self._table(camera), camera_from_part, self._corners[index])
        if window is None:
            return None
        pixels, rays = window
        part_from_camera = np.linalg.inv(camera_from_part)
        return pixels, rays, self._casters[index].first_hits(part_from_camera[:3, 3], rays @ part_from_camera[:3, :3].T)


def _rotated(vectors: np.ndarray, rotation: np.ndarray, rows_before: int) -> np.ndarray:
    """float64 `vectors @ rotation.T`, each row's bits those of the product over the `rows_before`
    rows it was picked from: numpy multiplies a single row another way, whose last bits differ."""
    vectors = vectors.astype(np.float64)
    if len(vectors) == 1 and rows_before > 1:
        return (np.repeat(vectors, 2, axis=0) @ rotation.T)[:1]
    return vectors @ rotation.T


# Corner pairs of `_box_corners` that differ in one coordinate: the box's 12 edges.
_BOX_EDGES = np.array([(i, j) for i in range(8) for j in range(i + 1, 8) if bin(i ^ j).count("1") == 1])


def in_front_of_near_plane(corners: np.ndarray) -> np.ndarray:
    """Points whose hull is a box ((8, 3) camera-frame corners) cut at the near plane: its
    corners in front of the plane and its edges' crossings of it; none when it is all behind."""
    z = corners[:, 2]
    if (z >= NEAR_M).all():
        return corners  # all in front (the fitters' usual case: called thousands of times)
    a, b = corners[_BOX_EDGES[:, 0]], corners[_BOX_EDGES[:, 1]]
    crossing = (a[:, 2] - NEAR_M) * (b[:, 2] - NEAR_M) < 0
    s = (NEAR_M - a[crossing, 2]) / (b[crossing, 2] - a[crossing, 2])
    return np.concatenate([corners[z >= NEAR_M], a[crossing] + s[:, None] * (b[crossing] - a[crossing])])


def box_corners(vertices: np.ndarray) -> np.ndarray:
    """The 8 corners of the axis-aligned bounding box of (N, 3) points."""
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    return np.array([[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])])


def widened(camera: Camera, corners_camera: np.ndarray) -> Camera:
    """`camera` grown (same focal lengths, its image inside the new one) to hold the
    projection of boxes ((8 K, 3) camera-frame corners, 8 a box) cut at the near plane, at
    most by its own size on each side; the camera itself when the lens is distorted. A box
    reaching behind the camera (a door swung open past it) grows it by the most: its image
    reaches past every edge it crosses."""
    boxes = np.asarray(corners_camera, dtype=np.float64).reshape(-1, 8, 3)
    points = np.concatenate([in_front_of_near_plane(box) for box in boxes])
    if camera.has_distortion or not len(points):
        return camera
    uv = camera.project(points)
    left, top = (int(np.clip(np.ceil(-uv[:, k].min()), 0, size)) for k, size in ((0, camera.width), (1, camera.height)))
    right = int(np.clip(np.ceil(uv[:, 0].max() - camera.width + 1), 0, camera.width))
    bottom = int(np.clip(np.ceil(uv[:, 1].max() - camera.height + 1), 0, camera.height))
    if not (left or top or right or bottom):
        return camera
    return Camera(**{**camera.model_dump(), "width": camera.width + left + right, "height": camera.height + top + bottom,
                     "cx": camera.cx + left, "cy": camera.cy + top})


def _windows(
    table: _PixelTable, camera_from_parts: np.ndarray, corners_part: np.ndarray
) -> list[tuple[np.ndarray, np.ndarray]]:
    """`_pixels_in_view` of a part at each of (K, 4, 4) `camera_from_parts` (no pixels for
    none), the usual case (an undistorted lens, every corner in front) worked out for all
    poses at once. A window's edge may lie a pixel off `_pixels_in_view`'s by rounding, never
    at a pixel whose ray reaches the box: either reaches a pixel past the box's image."""
    boxes = _window_boxes(table, camera_from_parts, corners_part)
    if boxes[0] is None:
        return [_pixels_in_view(table, m, corners_part) or _NO_PIXELS for m in camera_from_parts]
    return [_box_pixels(table, box) for box in boxes]


_NO_PIXELS = (np.empty(0, dtype=np.int64), np.empty((0, 3)))


def _window_boxes(
    table: _PixelTable, camera_from_parts: np.ndarray, corners_part: np.ndarray
) -> list[tuple[int, int, int, int]] | list[None]:
    """`_image_boxes` of a part's box corners at each of (K, 4, 4) `camera_from_parts`, or
    None for each when the usual case does not hold (a distorted lens, a corner behind the
    near plane): `_pixels_in_view` then finds the pixels."""
    corners = corners_part @ camera_from_parts[:, :3, :3].transpose(0, 2, 1) + camera_from_parts[:, None, :3, 3]
    if table.distorted or (corners[..., 2] < NEAR_M).any():
        return [None] * len(camera_from_parts)
    return _image_boxes(table, corners)


def _image_boxes(table: _PixelTable, points: np.ndarray) -> list[tuple[int, int, int, int]]:
    """(left, top, right, bottom) pixels, inclusive, of the image box of each of K sets of
    (K, M, 3) camera-frame points in front of the near plane, a pixel wider each way (empty,
    right < left or bottom < top, for a box off the image), for an undistorted lens:
    `Camera.project`'s pinhole arithmetic on plain floats."""
    u = table.fx * (points[..., 0] / points[..., 2]) + table.cx
    v = table.fy * (points[..., 1] / points[..., 2]) + table.cy
    height, width = table.flat.shape
    u0 = np.maximum(np.floor(u.min(axis=1)).astype(int) - 1, 0)
    v0 = np.maximum(np.floor(v.min(axis=1)).astype(int) - 1, 0)
    u1 = np.minimum(np.ceil(u.max(axis=1)).astype(int) + 1, width - 1)
    v1 = np.minimum(np.ceil(v.max(axis=1)).astype(int) + 1, height - 1)
    return list(zip(u0.tolist(), v0.tolist(), u1.tolist(), v1.tolist()))


def _box_pixels(table: _PixelTable, box: tuple[int, int, int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Flat indices and (N, 3) rays of the pixels of an `_image_boxes` box."""
    left, top, right, bottom = box
    if right < left or bottom < top:
        return _NO_PIXELS
    # Windows of the image: slicing the tables costs a third of gathering their pixels' rays.
    rows, columns = slice(top, bottom + 1), slice(left, right + 1)
    return table.flat[rows, columns].flatten(), table.grid_rays[rows, columns].reshape(-1, 3)


def _pixels_in_view(
    table: _PixelTable, camera_from_part: np.ndarray, corners_part: np.ndarray
) -> tuple[np.ndarray, np.ndarray] | None:
    """Flat indices and (N, 3) rays (z = 1) of the pixels of `table`'s camera whose rays may
    hit the part in front of the near plane (inside the projection of its bounding box
    clipped there), or None when there are none."""
    points = in_front_of_near_plane(corners_part @ camera_from_part[:3, :3].T + camera_from_part[:3, 3])
    if not len(points):
        return None
    if table.distorted:
        # A lens bends the box's outline in the image, not on the plane z = 1 the rays cross.
        xy = points[:, :2] / points[:, 2:]
        (x0, y0), (x1, y1) = xy.min(axis=0), xy.max(axis=0)
        rays = table.rays
        inside = (rays[:, 0] >= x0) & (rays[:, 0] <= x1) & (rays[:, 1] >= y0) & (rays[:, 1] <= y1)
        pixels = np.flatnonzero(inside)
        return (pixels, rays[pixels]) if len(pixels) else None
    pixels, rays = _box_pixels(table, _image_boxes(table, points[None])[0])
    return (pixels, rays) if len(pixels) else None
