"""A synthetic photo set with ground truth, rendered with Blender (bpy, Cycles on the CPU) or
with the toolkit's own ray caster (`ray_rendering`, no Blender: direct light, a camera's blur
and noise; the tests' 36 views in 24 CPU-s against 100 with Cycles).

A textured vase-like object stands on a textured table, ringed by ArUco/AprilTag markers of
known size, photographed from `n_views` cameras on two (or one, or three) rings, their file
names in the order taken or shuffled: the set-up of D3.1 Figure 16
with every camera, the true mesh and the scale known. The world frame is marker 0's frame
(x along its top edge, y up its left edge, z up out of the table), the frame a reconstruction
with markers is expressed in, so a result can be compared with the truth without alignment.

Cycles renders through `homemodel.geometry.cycles_scene` (Blender) in a child process
(`python -m photogrammetry.synthetic_scene SPEC.json`) so Blender's libraries never share a
process with open3d or pycolmap. A rendered set is reused while its options and the rendering
code (this module, cycles_scene and ray_rendering) are unchanged.
"""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import trimesh

from homemodel.core.checks import require_at_least, require_choice, require_positive
from homemodel.core.errors import InputError
from homemodel.core.transforms import world_from_camera_looking_at
from homemodel.geometry import cycles_scene
from photogrammetry import ray_rendering

SCENE_FILE = "scene.json"
RING_ELEVATIONS_DEG = {1: (40.0,), 2: (28.0, 52.0), 3: (16.0, 36.0, 58.0)}
TRUTH_MESH_FILE = "object_truth.ply"


@dataclass(kw_only=True)
class SceneOptions:
    n_views: int = 40
    width_px: int = 640
    height_px: int = 480
    lens_mm: float = 35.0
    sensor_width_mm: float = 36.0
    samples: int = 16
    marker_size_m: float = 0.04
    dictionary: str = "apriltag_36h11"
    rings: int = 2  # camera rings, from low to high (RING_ELEVATIONS_DEG)
    shuffled: bool = False  # photo file names in random order, not in the order they were taken
    random_state: int = 0
    # "cycles": Blender, with one diffuse bounce and the sun's soft shadow (`samples` per pixel);
    # "rays": the toolkit's ray caster (ray_rendering): direct light, hard shadow, a camera's
    # blur and shot noise.
    renderer: Literal["cycles", "rays"] = "cycles"

    def check(self) -> None:
        require_at_least("n_views", self.n_views, 2)
        require_choice("rings", self.rings, tuple(RING_ELEVATIONS_DEG))
        require_choice("renderer", self.renderer, ("cycles", "rays"))
        for name in ("width_px", "height_px", "lens_mm", "sensor_width_mm", "samples", "marker_size_m"):
            require_positive(name, getattr(self, name))


@dataclass(kw_only=True)
class SyntheticScene:
    """What a rendered set holds: its folder, the photos, the truth."""

    folder: Path
    image_paths: list[Path]
    truth_mesh: trimesh.Trimesh  # in marker 0's frame, metres
    camera_from_world: dict[str, np.ndarray]  # OpenCV convention, by image name
    fx_px: float
    marker_size_m: float
    dictionary: str

    @property
    def object_size_m(self) -> float:
        """The bounding-box diagonal of the true object."""
        return float(np.linalg.norm(self.truth_mesh.extents))


# The object: a surface of revolution (radius in metres against height), closed at both ends.
_OBJECT_CENTRE_XY_M = (0.17, 0.0)
_PROFILE_Z_M = np.linspace(0.0, 0.14, 15)
_PROFILE_R_M = 0.045 + 0.012 * np.sin(_PROFILE_Z_M / 0.14 * np.pi * 1.3) - 0.01 * (_PROFILE_Z_M / 0.14) ** 2
_SEGMENTS = 64
# The sun shines down the -z of Blender's XYZ Euler angles (35, 10, 40) degrees.
_SUN_EULER_XYZ = np.deg2rad([35.0, 10.0, 40.0])
_WORLD_FROM_SUN = trimesh.transformations.euler_matrix(*_SUN_EULER_XYZ, axes="sxyz") @ cycles_scene.OPENCV_FROM_BLENDER
_SUN_IRRADIANCE_W_M2 = 2.5
_SUN_ANGLE_DEG = 20.0
_SKY_RGB, _SKY_STRENGTH = (0.6, 0.6, 0.6), 0.6
_TABLE_HALF_SIDE_M = 0.6
# The ray-cast photos' camera (ray_rendering): blur (Gaussian sigma, px) and shot noise. Sharp,
# noise-free photos put the cameras 1 % off in the marker frame; with these, 0.06 %.
_RAYS_BLUR_PX, _RAYS_SHOT_NOISE = 0.5, 0.01


def truth_object_mesh() -> tuple[trimesh.Trimesh, np.ndarray]:
    """The object in the world frame and its per-vertex UVs (u around, v up)."""
    rings = len(_PROFILE_Z_M)
    angles = np.linspace(0, 2 * np.pi, _SEGMENTS + 1)  # the seam column is duplicated for the UVs
    r, a = np.meshgrid(_PROFILE_R_M, angles, indexing="ij")
    z = np.repeat(_PROFILE_Z_M[:, None], _SEGMENTS + 1, axis=1)
    side = np.stack([r * np.cos(a), r * np.sin(a), z], axis=-1).reshape(-1, 3)
    u, v = np.meshgrid(angles / (2 * np.pi), _PROFILE_Z_M / _PROFILE_Z_M[-1], indexing="xy")
    side_uv = np.stack([u, v], axis=-1).reshape(-1, 2) * [1.0, 0.8]
    faces = []
    cols = _SEGMENTS + 1
    for i in range(rings - 1):
        for j in range(_SEGMENTS):
            a0, a1, b0, b1 = i * cols + j, i * cols + j + 1, (i + 1) * cols + j, (i + 1) * cols + j + 1
            faces += [[a0, a1, b1], [a0, b1, b0]]
    vertices, uvs = [side], [side_uv]
    count = len(side)
    for ring, up in ((0, False), (rings - 1, True)):  # caps: a centre vertex fanned to the ring
        centre = np.array([[0.0, 0.0, _PROFILE_Z_M[ring]]])
        ring_idx = ring * cols + np.arange(_SEGMENTS)
        cap_uv = 0.5 + 0.1 * np.stack([np.cos(angles[:-1]), np.sin(angles[:-1])], axis=-1)
        vertices += [centre, side[ring_idx]]
        uvs += [np.array([[0.5, 0.9]]), np.column_stack([cap_uv[:, 0], 0.8 + cap_uv[:, 1] * 0.4])]
        c = count
        ring_new = count + 1 + np.arange(_SEGMENTS)
        for j in range(_SEGMENTS):
            k = (j + 1) % _SEGMENTS
            faces.append([c, ring_new[k], ring_new[j]] if not up else [c, ring_new[j], ring_new[k]])
        count += 1 + _SEGMENTS
    mesh = trimesh.Trimesh(np.vstack(vertices), np.array(faces), process=False)
    mesh.apply_translation([*_OBJECT_CENTRE_XY_M, 0.0])
    return mesh, np.vstack(uvs)


def _noise_texture(rng: np.random.Generator, size_px: tuple[int, int], contrast: float) -> np.ndarray:
    """Multi-scale coloured noise with dots: many SIFT features and locally unique patches."""
    import cv2

    h, w = size_px
    image = np.zeros((h, w, 3), np.float32)
    for scale in (2, 5, 11, 23):
        layer = rng.normal(size=(h // scale + 2, w // scale + 2, 3)).astype(np.float32)
        image += cv2.resize(layer, (w, h), interpolation=cv2.INTER_CUBIC) * (scale**0.5)
    image = (image - image.mean()) / image.std()
    image = 0.5 + contrast * 0.18 * image
    for _ in range(h * w // 2500):
        centre = (int(rng.integers(0, w)), int(rng.integers(0, h)))
        colour = tuple(float(c) for c in rng.uniform(0, 1, 3))
        cv2.circle(image, centre, int(rng.integers(2, 12)), colour, -1, lineType=cv2.LINE_AA)
    return (np.clip(image, 0, 1) * 255).astype(np.uint8)


def marker_layout(marker_size_m: float) -> list[tuple[int, float, float, float]]:
    """(id, x, y, yaw) of the markers: marker 0 at the origin, the others on a ring around the object."""
    layout = [(0, 0.0, 0.0, 0.0)]
    cx, cy = _OBJECT_CENTRE_XY_M
    for k, angle in enumerate(np.deg2rad([60, 120, 180, 240, 300]), start=1):
        radius = 0.17 + 0.01 * k % 3
        layout.append((k, cx + radius * np.cos(angle + np.pi), cy + radius * np.sin(angle + np.pi), 0.4 * k))
    return layout


def _marker_image(dictionary: str, marker_id: int, px_per_cell: int = 16) -> np.ndarray:
    """The marker with one white cell of margin (the quiet zone a detector needs)."""
    import cv2

    from photogrammetry.markers import aruco_dictionary

    d = aruco_dictionary(dictionary)
    cells = d.markerSize + 2
    side = cells * px_per_cell
    tag = cv2.aruco.generateImageMarker(d, marker_id, side)
    margin = px_per_cell
    return cv2.copyMakeBorder(tag, margin, margin, margin, margin, cv2.BORDER_CONSTANT, value=255)


def _camera_centres(n_views: int, rings: int, rng: np.random.Generator) -> np.ndarray:
    """Rings around the object, from low to high, each walked round, with a little jitter."""
    cx, cy = _OBJECT_CENTRE_XY_M
    ring_of = np.arange(n_views) * rings // n_views  # equal shares of the views, in order
    centres = []
    for i in range(n_views):
        ring = ring_of[i]
        count = int((ring_of == ring).sum())
        k = i - int(np.argmax(ring_of == ring))
        azimuth = 2 * np.pi * (k + 0.5 * ring) / count + rng.normal(0, 0.03)
        elevation = np.deg2rad(RING_ELEVATIONS_DEG[rings][ring]) + rng.normal(0, 0.03)
        distance = 0.42 + rng.normal(0, 0.015)
        centres.append(
            [
                cx + distance * np.cos(elevation) * np.cos(azimuth),
                cy + distance * np.cos(elevation) * np.sin(azimuth),
                0.06 + distance * np.sin(elevation),
            ]
        )
    return np.array(centres)


def render_scene(folder: Path, options: SceneOptions | None = None) -> SyntheticScene:
    """Render the photo set into `folder` (images/, scene.json, the true mesh); reuse it if present."""
    options = options or SceneOptions()
    options.check()
    folder = Path(folder)
    spec_path = folder / SCENE_FILE
    wanted = asdict(options)
    renderer = cycles_scene.rendering_code_digest(__file__, ray_rendering.__file__)
    if spec_path.is_file():
        spec = json.loads(spec_path.read_text())
        if (
            spec.get("options") == wanted
            and spec.get("renderer") == renderer
            and all((folder / "images" / v["name"]).is_file() for v in spec["views"])
        ):
            return load_scene(folder)
    rng = np.random.default_rng(options.random_state)
    (folder / "images").mkdir(parents=True, exist_ok=True)
    (folder / "textures").mkdir(exist_ok=True)
    import cv2

    mesh, uv = truth_object_mesh()
    mesh.export(folder / TRUTH_MESH_FILE)
    cv2.imwrite(str(folder / "textures" / "object.png"), _noise_texture(rng, (512, 1024), contrast=1.0))
    cv2.imwrite(str(folder / "textures" / "table.png"), _noise_texture(rng, (1024, 1024), contrast=0.6))
    markers = []
    for marker_id, x, y, yaw in marker_layout(options.marker_size_m):
        path = folder / "textures" / f"marker_{marker_id}.png"
        cv2.imwrite(str(path), _marker_image(options.dictionary, marker_id))
        markers.append({"id": marker_id, "x": x, "y": y, "yaw": yaw, "texture": path.name})
    target = np.array([*_OBJECT_CENTRE_XY_M, 0.06])
    fx = options.lens_mm / options.sensor_width_mm * options.width_px
    views = []
    centres = _camera_centres(options.n_views, options.rings, rng)
    numbers = np.arange(len(centres))
    if options.shuffled:  # as when photos are copied off several cameras, or renamed
        numbers = np.random.default_rng(options.random_state + 1).permutation(numbers)
    for number, centre in zip(numbers, centres):
        world_from_camera = world_from_camera_looking_at(centre, target + rng.normal(0, 0.01, 3))
        views.append({"name": f"view_{number:03d}.png", "world_from_camera": world_from_camera.tolist()})
    spec = {
        "options": wanted,
        "renderer": renderer,
        "fx_px": fx,
        "object": {"vertices": mesh.vertices.tolist(), "faces": mesh.faces.tolist(), "uv": uv.tolist()},
        "markers": markers,
        "views": views,
    }
    render_spec = folder / "render_spec.json"
    render_spec.write_text(json.dumps(spec))
    if options.renderer == "rays":
        _render_with_rays(spec, folder)
    else:
        result = subprocess.run(
            [sys.executable, "-m", "photogrammetry.synthetic_scene", str(render_spec)],
            capture_output=True,
            text=True,
        )
        if result.returncode != 0:
            raise InputError(f"{folder}: Blender rendering failed: {result.stderr.strip().splitlines()[-1:]}")
    render_spec.unlink()
    del spec["object"]
    spec_path.write_text(json.dumps(spec, indent=1))
    return load_scene(folder)


def load_scene(folder: Path) -> SyntheticScene:
    spec = json.loads((Path(folder) / SCENE_FILE).read_text())
    options = SceneOptions(**spec["options"])
    return SyntheticScene(
        folder=Path(folder),
        image_paths=[Path(folder) / "images" / v["name"] for v in spec["views"]],
        truth_mesh=trimesh.load(Path(folder) / TRUTH_MESH_FILE, process=False),  # the world is marker 0's frame
        camera_from_world={v["name"]: np.linalg.inv(np.array(v["world_from_camera"])) for v in spec["views"]},
        fx_px=spec["fx_px"],
        marker_size_m=options.marker_size_m,
        dictionary=options.dictionary,
    )


@dataclass(kw_only=True)
class _Part:
    """A textured part of the scene, as both renderers take it."""

    name: str
    texture: str  # file name in the set's textures/
    vertices: np.ndarray
    faces: np.ndarray
    uv: np.ndarray
    closest_texel: bool = False  # printed cells: no interpolation


def _scene_parts(spec: dict, options: SceneOptions) -> list[_Part]:
    """The object, the table and the markers' printed sheets."""
    square = np.array([[0, 1, 2, 3]])
    square_uv = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    obj = spec["object"]
    parts = [_Part(name="object", texture="object.png", vertices=np.array(obj["vertices"]),
                   faces=np.array(obj["faces"]), uv=np.array(obj["uv"]))]  # fmt: skip
    half = _TABLE_HALF_SIDE_M
    table_xy = np.array([[-half, -half], [half, -half], [half, half], [-half, half]]) + _OBJECT_CENTRE_XY_M
    parts.append(_Part(name="table", texture="table.png", vertices=np.column_stack([table_xy, np.zeros(4)]),
                       faces=square, uv=square_uv))  # fmt: skip
    cells = _cells(options.dictionary)
    for m in spec["markers"]:
        # The printed sheet: the marker plus its one-cell margin, 0.2 mm above the table.
        h = options.marker_size_m / 2 * (cells + 2) / cells
        c, s = np.cos(m["yaw"]), np.sin(m["yaw"])
        corners = np.array([[-h, -h], [h, -h], [h, h], [-h, h]]) @ np.array([[c, s], [-s, c]])
        verts = np.column_stack([m["x"] + corners[:, 0], m["y"] + corners[:, 1], np.full(4, 0.0002)])
        parts.append(_Part(name=f"marker_{m['id']}", texture=m["texture"], vertices=verts, faces=square, uv=square_uv,
                           closest_texel=True))  # fmt: skip
    return parts


def _pinhole(spec: dict, options: SceneOptions) -> np.ndarray:
    """K with the principal point at the image centre."""
    fx, cx, cy = spec["fx_px"], (options.width_px - 1) / 2, (options.height_px - 1) / 2
    return np.array([[fx, 0.0, cx], [0.0, fx, cy], [0.0, 0.0, 1.0]])


def _render_with_rays(spec: dict, folder: Path) -> None:
    """Every view through `ray_rendering`, the same scene and light as Blender's but the bounce
    light and the sun's soft shadow edge."""
    import cv2

    from homemodel.core.images import read_image
    from homemodel.geometry.camera import Camera

    options = SceneOptions(**spec["options"])
    parts = [
        ray_rendering.TexturedPart(
            vertices=p.vertices, faces=p.faces, uv=p.uv, closest_texel=p.closest_texel,
            texture_srgb=read_image(folder / "textures" / p.texture)[..., ::-1],
        )
        for p in _scene_parts(spec, options)
    ]  # fmt: skip
    lighting = ray_rendering.Lighting(
        sky_radiance=_SKY_RGB[0] * _SKY_STRENGTH, sun_irradiance_w_m2=_SUN_IRRADIANCE_W_M2, to_sun=-_WORLD_FROM_SUN[:3, 2]
    )
    renderer = ray_rendering.RayRenderer(parts, lighting, blur_px=_RAYS_BLUR_PX, shot_noise=_RAYS_SHOT_NOISE)
    camera = Camera.from_matrix(_pinhole(spec, options), width=options.width_px, height=options.height_px)
    for index, view in enumerate(spec["views"]):
        rng = np.random.default_rng([options.random_state, index])
        image = renderer.render(camera, np.linalg.inv(np.array(view["world_from_camera"])), rng)
        cv2.imwrite(str(folder / "images" / view["name"]), image[..., ::-1])


def _render_in_blender(spec_path: Path) -> None:
    """Build the scene in Blender and render every view (runs in the child process)."""
    spec = json.loads(spec_path.read_text())
    options = SceneOptions(**spec["options"])
    folder = spec_path.parent

    with cycles_scene.empty_scene():
        # Direct light and one diffuse bounce are enough for matte objects, and far faster.
        cycles_scene.set_up_cycles(
            cycles_scene.CyclesSettings(
                width_px=options.width_px,
                height_px=options.height_px,
                samples=options.samples,
                seed=options.random_state,
                max_bounces=1,
                diffuse_bounces=1,
                glossy_bounces=0,
                view_transform="Standard",
            )
        )
        for part in _scene_parts(spec, options):
            image = cycles_scene.image_from_file(folder / "textures" / part.texture)
            # Matte: Lambert is cheaper to render than Principled.
            interpolation = "Closest" if part.closest_texel else "Linear"
            material = cycles_scene.matte_material(part.name, image, shader="diffuse", interpolation=interpolation)
            cycles_scene.add_mesh(part.name, part.vertices, part.faces, material, uv=part.uv)
        cycles_scene.set_world(_SKY_RGB, _SKY_STRENGTH)
        sun = cycles_scene.add_sun("sun", _SUN_IRRADIANCE_W_M2, _SUN_ANGLE_DEG)
        cycles_scene.set_pose(sun, _WORLD_FROM_SUN)
        camera = cycles_scene.add_camera(_pinhole(spec, options), options.width_px, options.height_px)
        for frame, view in enumerate(spec["views"]):
            cycles_scene.set_pose(camera, np.array(view["world_from_camera"]), frame)
        cycles_scene.render_frames([folder / "images" / view["name"] for view in spec["views"]])


def _cells(dictionary: str) -> int:
    from photogrammetry.markers import aruco_dictionary

    return aruco_dictionary(dictionary).markerSize + 2


if __name__ == "__main__":
    _render_in_blender(Path(sys.argv[1]))
