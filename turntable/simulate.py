"""A synthetic turntable capture of a mesh: the folder `homemodel turntable reconstruct` reads,
plus the truth to test it against.

A fixed camera on a tripod looks down at a round table that turns once, at constant speed,
about a vertical axis that crosses the board off its origin (`axis_offset_m`, so the circle
fit has something to find). Colour comes from Blender's Cycles; depth from open3d's ray
casting of the very same triangles from the very same camera (pixel centres, exact), so
the two are registered by construction. The optional noise model is that of a structured-light
sensor: Gaussian noise whose deviation grows with the square of the depth, and no depth at
grazing angles or next to depth edges.

Writes `camera.yaml`, `board.yaml`, `color/`, `depth/`, `true_cameras.json` (the cameras.json
format of `homemodel.exchange.cameras`: camera_from_table per frame), `ground_truth.ply` (the object in the table frame, with its colours) and
`simulation.json` (the options, so `resimulate_depth` can render the same scene's depth again
under another noise level).
"""

from __future__ import annotations

import dataclasses
import json
import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import trimesh

from homemodel.core.atomic import atomic_dir, write_bytes_atomic, write_json
from homemodel.core.checks import require_at_least, require_between, require_choice, require_positive
from homemodel.core.errors import InputError
from homemodel.core.limits import RENDER_PIXELS
from homemodel.geometry.mesh_io import load_mesh
from homemodel.core.input_files import read_bounded
from homemodel.core.progress import Progress, no_progress
from homemodel.core.transforms import world_from_camera_looking_at
from turntable.board import Board, grid_board, load_board, save_board
from turntable.capture import SIMULATION_JSON
from homemodel.geometry.camera import Camera, load_camera, save_camera
from homemodel.geometry.depth_io import write_depth
from homemodel.geometry.raycast import RayCaster
from homemodel.exchange.cameras import TRUE_CAMERAS_FILE, CameraView, read_cameras, true_cameras_file, write_cameras

NOISE_REFERENCE_DEPTH_M = 0.7
GROUND_TRUTH = "ground_truth.ply"
MAX_FRAMES = 3600  # ten a degree
MAX_CYCLES_SAMPLES = 4096
_TABLE_THICKNESS_M = 0.02
_TABLE_TOP_BELOW_TAGS_M = 5e-5  # the tags' paper lies on the table top
_FLOOR_BELOW_TABLE_M = 0.7


@dataclass(kw_only=True)
class SimulationOptions:
    frames: int = 72
    width_px: int = 640
    height_px: int = 480
    horizontal_fov_deg: float = 58.0
    camera_distance_m: float = 0.6  # horizontal, from the turntable axis
    camera_height_m: float = 0.4  # above the table top
    table_diameter_m: float = 0.4
    tag_size_m: float = 0.03
    board_path: Path | None = None  # a board.yaml to use instead of a generated grid
    axis_offset_m: tuple[float, float] = (0.011, -0.007)  # where the turntable axis crosses the board
    lighting: Literal["studio", "ambient"] = "studio"
    # Cycles (path tracing, Blender) by default: the images a user expects of a renderer. The
    # ray caster (turntable/raycast_render.py) draws the same scene with direct light only,
    # its tag corners as exact, for a fraction of the CPU: for tests and quick runs.
    renderer: Literal["cycles", "raycast"] = "cycles"
    samples: int = 16  # Cycles' samples per pixel (the ray caster takes a fixed grid of rays)
    depth_format: Literal["png", "exr"] = "png"
    depth_scale_m: float = 0.0001
    depth_noise_m: float = 0.0  # standard deviation at 0.7 m; grows with depth squared
    grazing_angle_deg: float = 78.0  # no depth beyond this angle between ray and surface normal
    edge_jump_m: float = 0.01  # no depth next to a depth jump larger than this
    mesh_scale: float = 1.0  # multiplies the mesh's coordinates into metres
    random_state: int = 0  # of the depth noise and the Cycles sampling

    def check(self) -> None:
        positive = ("frames", "width_px", "height_px", "camera_distance_m", "table_diameter_m", "tag_size_m", "samples")
        for name in (*positive, "camera_height_m", "mesh_scale"):  # the camera stands above the table
            require_positive(name, getattr(self, name))
        require_between("horizontal_fov_deg", self.horizontal_fov_deg, 1.0, 170.0)
        require_at_least("depth_noise_m", self.depth_noise_m, 0.0)
        require_choice("renderer", self.renderer, ("cycles", "raycast"))
        # Each frame is rendered and held in memory: bound its pixels, the frames and Cycles' samples.
        RENDER_PIXELS.check(f"width_px x height_px = {self.width_px}x{self.height_px}", self.width_px * self.height_px)
        require_between("frames", self.frames, 1, MAX_FRAMES)
        require_between("samples", self.samples, 1, MAX_CYCLES_SAMPLES)


@dataclass(kw_only=True)
class SimulationResult:
    out_dir: Path
    frames: int
    render_s: float
    depth_s: float


def camera_for(options: SimulationOptions) -> Camera:
    f = options.width_px / 2 / math.tan(math.radians(options.horizontal_fov_deg) / 2)
    return Camera(
        width=options.width_px,
        height=options.height_px,
        fx=f,
        fy=f,
        cx=(options.width_px - 1) / 2,
        cy=(options.height_px - 1) / 2,
        depth_scale_m=options.depth_scale_m,
    )


def _vertex_rgba(path: Path, vertex_count: int) -> np.ndarray:
    """Per-vertex linear RGBA in [0, 1] from the file's colours or texture, or light grey when
    it has none or they do not map one-to-one onto its vertices (an OBJ whose texture is
    missing, a glTF whose primitives trimesh merges)."""
    grey = np.full((vertex_count, 4), 0.7)
    try:
        loaded = trimesh.load(path, force="mesh", process=False)  # from the path: textures beside it resolve
        if loaded.visual.kind not in ("vertex", "texture", "face"):
            return grey
        visual = loaded.visual.to_color() if loaded.visual.kind == "texture" else loaded.visual
        colours = np.asarray(visual.vertex_colors, dtype=np.float64)
    except Exception:  # trimesh's colour conversions fail in many ways on partial materials
        return grey
    if colours.shape != (vertex_count, 4) or not np.all(np.isfinite(colours)):
        return grey
    return colours / 255.0


def load_object_mesh(path: Path, scale: float) -> tuple[trimesh.Trimesh, np.ndarray]:
    """The mesh (in metres) and its per-vertex linear RGBA in [0, 1] (light grey when it has
    none). `path` is a mesh file or a model folder (its model.glb, in the model's z-up frame)."""
    path = Path(path)
    loaded = load_mesh(path)  # bounded, finite, with triangles
    mesh = trimesh.Trimesh(loaded.vertices * scale, loaded.faces, process=False)
    return mesh, _vertex_rgba(path / "model.glb" if path.is_dir() else path, len(mesh.vertices))


def _place_on_table(mesh: trimesh.Trimesh, axis_table: np.ndarray) -> trimesh.Trimesh:
    """The object centred on the turntable's axis, standing on the table top (z = 0)."""
    lo, hi = mesh.bounds
    offset = np.array([axis_table[0] - (lo[0] + hi[0]) / 2, axis_table[1] - (lo[1] + hi[1]) / 2, -lo[2]])
    placed = mesh.copy()
    placed.apply_translation(offset)
    return placed


def _table_meshes(board: Board, axis_table: np.ndarray) -> tuple[trimesh.Trimesh, trimesh.Trimesh]:
    radius = board.radius_m * 1.03
    table = trimesh.creation.cylinder(radius=radius, height=_TABLE_THICKNESS_M, sections=256)
    table.apply_translation([axis_table[0], axis_table[1], -_TABLE_THICKNESS_M / 2 - _TABLE_TOP_BELOW_TAGS_M])
    floor = trimesh.creation.box((8.0, 8.0, 0.01))
    floor.apply_translation([axis_table[0], axis_table[1], -_FLOOR_BELOW_TABLE_M])
    return table, floor


def turntable_motion(options: SimulationOptions, object_height_m: float) -> tuple[np.ndarray, list[np.ndarray]]:
    """`camera_from_world` of the tripod and `world_from_table` per frame.

    The world frame has z along the turntable axis and its origin where the axis meets the
    table top; the table turns counter-clockwise (seen from above) once over the frames.
    """
    axis_table = np.array([*options.axis_offset_m, 0.0])
    eye = np.array([0.0, -options.camera_distance_m, options.camera_height_m])
    target = np.array([0.0, 0.0, min(object_height_m * 0.35, options.camera_height_m * 0.5)])
    camera_from_world = np.linalg.inv(world_from_camera_looking_at(eye, target))
    world_from_tables = []
    for k in range(options.frames):
        world_from_table = trimesh.transformations.rotation_matrix(2 * math.pi * k / options.frames, [0, 0, 1])
        world_from_table[:3, 3] = -world_from_table[:3, :3] @ axis_table
        world_from_tables.append(world_from_table)
    return camera_from_world, world_from_tables


def _lights(
    options: SimulationOptions, world_from_tables: list[np.ndarray]
) -> tuple[list[list[np.ndarray]], list[float], float]:
    """Per frame, the table-frame pose of each light; their powers; the ambient strength."""
    if options.lighting == "ambient":
        return [[] for _ in world_from_tables], [], 0.85
    # A key light above and to the left of the camera, standing still like the tripod.
    d, h = options.camera_distance_m, options.camera_height_m
    world_from_light = world_from_camera_looking_at(np.array([-0.5 * d, -0.8 * d, h + 0.5]), np.zeros(3))
    return [[np.linalg.inv(w) @ world_from_light] for w in world_from_tables], [12.0], 0.35


def render_depth(caster: RayCaster, camera: Camera, camera_from_table: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Depth (z along the optical axis, NaN where no hit) and the cosine between each ray and
    the surface it hits, at every pixel centre."""
    directions, hits = caster.camera_hits(camera, camera_from_table)
    t = hits.t.astype(np.float64)  # in units of the direction, whose z is 1: depth
    unit = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    cosine = np.abs(np.sum(unit * hits.normals.astype(np.float64), axis=1))
    depth = np.where(np.isfinite(t), t, np.nan)
    return depth.reshape(camera.height, camera.width), cosine.reshape(camera.height, camera.width)


def add_sensor_noise(
    depth_m: np.ndarray, cosine: np.ndarray, options: SimulationOptions, rng: np.random.Generator
) -> np.ndarray:
    """Structured-light noise: N(0, sigma * (z / 0.7 m)^2), holes at grazing angles and depth edges."""
    noisy = depth_m + rng.normal(size=depth_m.shape) * options.depth_noise_m * (depth_m / NOISE_REFERENCE_DEPTH_M) ** 2
    noisy[cosine < math.cos(math.radians(options.grazing_angle_deg))] = np.nan
    padded = np.pad(depth_m, 1, mode="edge")
    neighbours = [
        padded[1 + dy : 1 + dy + depth_m.shape[0], 1 + dx : 1 + dx + depth_m.shape[1]]
        for dy in (-1, 0, 1)
        for dx in (-1, 0, 1)
    ]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN neighbourhoods: no depth there anyway
        jump = np.nanmax(np.abs(np.stack(neighbours) - depth_m), axis=0)
    near_edge = (jump > options.edge_jump_m) | np.any(np.isnan(np.stack(neighbours)), axis=0)
    noisy[near_edge] = np.nan
    return noisy


def _write_depth_frames(
    folder: Path,
    scene_mesh: trimesh.Trimesh,
    camera: Camera,
    camera_from_tables: dict[str, np.ndarray],
    options: SimulationOptions,
    report: Progress,
) -> None:
    caster = RayCaster(scene_mesh)
    rng = np.random.default_rng(options.random_state)
    for k, (stem, camera_from_table) in enumerate(sorted(camera_from_tables.items())):
        depth, cosine = render_depth(caster, camera, camera_from_table)
        if options.depth_noise_m > 0:
            depth = add_sensor_noise(depth, cosine, options, rng)
        write_depth(folder / f"{stem}.{options.depth_format}", depth, depth_scale_m=options.depth_scale_m)
        report("render depth", k + 1, len(camera_from_tables))


def _scene(options: SimulationOptions, board: Board, placed: trimesh.Trimesh) -> trimesh.Trimesh:
    """Everything depth sees: the object, the table (its top just under the tags), the floor."""
    table, floor = _table_meshes(board, np.array([*options.axis_offset_m, 0.0]))
    return trimesh.util.concatenate([placed, table, floor])


def simulate_capture(
    mesh_path: Path,
    out_dir: Path,
    options: SimulationOptions | None = None,
    *,
    force: bool = False,
    progress: Progress | None = None,
) -> SimulationResult:
    """Render a capture of the mesh at `mesh_path` into `out_dir` (atomically)."""
    import time

    from turntable.blender_render import RenderScene, render_colour_frames
    from turntable.raycast_render import render_colour_frames_raycast

    options = options or SimulationOptions()
    options.check()
    report = progress or no_progress
    board = (
        load_board(options.board_path)
        if options.board_path
        else grid_board(table_diameter_m=options.table_diameter_m, tag_size_m=options.tag_size_m)
    )
    camera = camera_for(options)
    mesh, rgba = load_object_mesh(mesh_path, options.mesh_scale)
    axis_table = np.array([*options.axis_offset_m, 0.0])
    placed = _place_on_table(mesh, axis_table)
    footprint = np.max(np.linalg.norm(placed.vertices[:, :2] - axis_table[:2], axis=1))
    if footprint > board.radius_m * 0.9:
        raise InputError(
            f"{mesh_path}: the object ({footprint:.3f} m from the axis) does not fit on a {board.radius_m:.3f} m-radius table"
        )
    table, floor = _table_meshes(board, axis_table)
    camera_from_world, world_from_tables = turntable_motion(options, float(placed.bounds[1, 2]))
    stems = [f"{k:06d}" for k in range(options.frames)]
    camera_from_tables = {stem: camera_from_world @ w for stem, w in zip(stems, world_from_tables)}
    table_from_lights, powers, ambient = _lights(options, world_from_tables)
    with atomic_dir(Path(out_dir), force=force, inputs=[Path(mesh_path)]) as tmp:
        (tmp / "color").mkdir()
        (tmp / "depth").mkdir()
        save_camera(camera, tmp / "camera.yaml")
        save_board(board, tmp / "board.yaml")
        start = time.perf_counter()
        scene = RenderScene(
            object_mesh=placed,
            object_rgba=rgba,
            table_mesh=table,
            floor_mesh=floor,
            board=board,
            camera=camera,
            table_from_cameras=[np.linalg.inv(camera_from_tables[s]) for s in stems],
            table_from_lights=table_from_lights,
            light_power_w=powers,
            ambient_strength=ambient,
            samples=options.samples,
            seed=options.random_state,
        )
        render = render_colour_frames if options.renderer == "cycles" else render_colour_frames_raycast
        render(scene, tmp / "color", progress=lambda done: report("render colour", done, options.frames))
        render_s = time.perf_counter() - start
        start = time.perf_counter()
        _write_depth_frames(tmp / "depth", _scene(options, board, placed), camera, camera_from_tables, options, report)
        write_cameras(tmp / TRUE_CAMERAS_FILE, [CameraView(name=s, camera=camera, camera_from_frame=camera_from_tables[s])
                                                for s in stems], frame="table")  # fmt: skip
        truth = trimesh.Trimesh(
            placed.vertices, placed.faces, vertex_colors=np.round(rgba * 255).astype(np.uint8), process=False
        )
        write_bytes_atomic(tmp / GROUND_TRUTH, truth.export(file_type="ply"))
        write_json(tmp / SIMULATION_JSON, _options_json(options))
        depth_s = time.perf_counter() - start
    return SimulationResult(out_dir=Path(out_dir), frames=options.frames, render_s=render_s, depth_s=depth_s)


def _options_json(options: SimulationOptions) -> dict:
    data = dataclasses.asdict(options)
    data["board_path"] = None if options.board_path is None else str(options.board_path)
    return data


def resimulate_depth(
    capture_dir: Path, out_dir: Path, *, depth_noise_m: float, random_state: int = 0, force: bool = False
) -> Path:
    """A copy of a simulated capture with its depth rendered again under another noise level
    (the colour frames, poses and truth are the same): the same scene, rebuilt from
    `simulation.json`, `board.yaml` and `ground_truth.ply`, without rendering colour again."""
    import shutil

    capture_dir = Path(capture_dir)
    options, scene = simulated_scene(capture_dir)
    options = dataclasses.replace(options, depth_noise_m=depth_noise_m, random_state=random_state)
    options.check()
    camera = load_camera(capture_dir / "camera.yaml")
    truth = true_cameras_file(capture_dir)
    camera_from_tables = read_cameras(truth).poses
    with atomic_dir(Path(out_dir), force=force, inputs=[capture_dir]) as tmp:
        for name in ("camera.yaml", "board.yaml", truth.name, GROUND_TRUTH):
            shutil.copy2(capture_dir / name, tmp / name)
        shutil.copytree(capture_dir / "color", tmp / "color")
        (tmp / "depth").mkdir()
        _write_depth_frames(tmp / "depth", scene, camera, camera_from_tables, options, no_progress)
        write_json(tmp / SIMULATION_JSON, _options_json(options))
    return Path(out_dir)


def simulated_scene(capture_dir: Path) -> tuple[SimulationOptions, trimesh.Trimesh]:
    """A simulated capture's options and everything its depth sees (object, table, floor, in
    the table frame), rebuilt from `simulation.json`, `board.yaml` and `ground_truth.ply`: to
    render its depth again, from other cameras too."""
    capture_dir = Path(capture_dir)
    try:
        saved = json.loads(read_bounded(capture_dir / SIMULATION_JSON, 1 << 20))
        saved["board_path"] = None if saved["board_path"] is None else Path(saved["board_path"])
        saved["axis_offset_m"] = tuple(saved["axis_offset_m"])
        options = SimulationOptions(**saved)
    except (ValueError, TypeError, KeyError, RecursionError) as exc:  # RecursionError: nested deep
        raise InputError(f"{capture_dir / SIMULATION_JSON}: not a simulation record: {exc}") from None
    options.check()
    board = load_board(capture_dir / "board.yaml")
    placed = load_mesh(capture_dir / GROUND_TRUTH)  # bounded, finite
    return options, _scene(options, board, placed)
