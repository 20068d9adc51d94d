"""Recordings the importers have not seen, rendered here from a truth mesh independently of the
project's simulator (issue 29's independent check, s17's check29b).

Each recording is ray-cast with Open3D from its own scene: a truth mesh standing on a turntable
covered by a tag36h11 board drawn from `board.yaml` (tags from OpenCV's dictionary, top row
towards +y), seen by a colour camera through its lens (every pixel's ray undistorted by
OpenCV, 2x2 samples a pixel) and a depth camera of its own size, lens and pose. Sensor faults:
the structured-light noise sigma(z) = 0.0012 + 0.0019 (z - 0.4)^2 m, flying pixels at depth
edges, holes on a dark shiny surface, dropped frames, depth captured up to `jitter_s` away
from its colour, motion blur on some colour frames, sRGB-encoded 8-bit colour. The writers store
the streams as the cameras' own software does (ROS 1 bags with CompressedImage colour, ROS 2
MCAP or sqlite3, TUM folders, Open3D folders), and `run_check` imports and reconstructs them
with the README's commands and measures the mesh against the truth and against the clean twin
(the same colour camera, depth rendered in its pixels with the same noise, no other fault).

Run `python tests/unseen_recordings.py OUT_DIR [NAME...]` for the whole table.
"""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import trimesh
import yaml

CLI = Path(sys.executable).with_name("homemodel")


# ---------------------------------------------------------------- truth meshes (table frame, m)
def revolved(profile_rz: list[tuple[float, float]], sections: int = 96) -> trimesh.Trimesh:
    """A closed solid of revolution about z from its (radius, z) outline, axis to axis."""
    return trimesh.creation.revolve(np.asarray(profile_rz, float), sections=sections)


def tall_bottle() -> trimesh.Trimesh:
    return revolved([(0, 0), (0.032, 0), (0.034, 0.004), (0.034, 0.15), (0.014, 0.2), (0.013, 0.235),
                     (0.015, 0.24), (0, 0.24)])


def flat_plate() -> trimesh.Trimesh:
    return revolved([(0, 0), (0.06, 0), (0.062, 0.008), (0.11, 0.02), (0.11, 0.024), (0.105, 0.024),
                     (0.06, 0.012), (0, 0.012)])


def mug_with_handle() -> trimesh.Trimesh:
    """A mug (outer r 40 mm, 100 mm tall, 4 mm wall) with a ring handle standing out 30 mm."""
    import manifold3d

    cup = revolved([(0, 0), (0.04, 0), (0.04, 0.1), (0.036, 0.1), (0.036, 0.006), (0, 0.006)])
    handle = trimesh.creation.torus(major_radius=0.026, minor_radius=0.006, major_sections=48, minor_sections=16)
    handle.apply_transform(trimesh.transformations.rotation_matrix(math.pi / 2, [1, 0, 0]))
    handle.apply_translation([0.058, 0, 0.05])

    def solid(m: trimesh.Trimesh) -> manifold3d.Manifold:
        return manifold3d.Manifold(manifold3d.Mesh(vert_properties=np.asarray(m.vertices, np.float32),
                                                   tri_verts=np.asarray(m.faces, np.uint32)))

    out = (solid(cup) + solid(handle)).to_mesh()
    return trimesh.Trimesh(np.asarray(out.vert_properties)[:, :3], np.asarray(out.tri_verts))


def sharp_box() -> trimesh.Trimesh:
    box = trimesh.creation.box([0.13, 0.07, 0.09])
    box.apply_translation([0.0, 0.0, 0.045])
    box.apply_transform(trimesh.transformations.rotation_matrix(math.radians(25), [0, 0, 1]))
    box.apply_translation([0.015, -0.01, 0])
    return box


OBJECTS = {"bottle": tall_bottle, "plate": flat_plate, "mug": mug_with_handle, "box": sharp_box}


# ---------------------------------------------------------------- cameras
@dataclass(frozen=True)
class Lens:
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    dist: tuple[float, ...] = ()  # OpenCV order: k1 k2 p1 p2 [k3 [k4 k5 k6]]

    @property
    def K(self) -> np.ndarray:  # noqa: N802
        return np.array([[self.fx, 0, self.cx], [0, self.fy, self.cy], [0, 0, 1.0]])

    def pinhole(self) -> Lens:
        return replace(self, dist=())

    def rays(self, samples: int = 1) -> np.ndarray:
        """(H, W, samples^2, 3) ray directions with z = 1 through each pixel (sub-pixel samples
        on a grid), undistorted through the lens by OpenCV."""
        import cv2

        offs = (np.arange(samples) + 0.5) / samples - 0.5
        u, v = np.meshgrid(np.arange(self.width, dtype=np.float64), np.arange(self.height, dtype=np.float64))
        du, dv = np.meshgrid(offs, offs)
        px = np.stack([u[..., None] + du.ravel(), v[..., None] + dv.ravel()], -1).reshape(-1, 1, 2)
        if self.dist:
            xy = cv2.undistortPointsIter(px, self.K, np.asarray(self.dist), None, None,
                                         (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-9)).reshape(-1, 2)
        else:
            xy = (px.reshape(-1, 2) - [self.cx, self.cy]) / [self.fx, self.fy]
        return np.concatenate([xy, np.ones((len(xy), 1))], 1).reshape(self.height, self.width, samples * samples, 3)


def look_at(eye: np.ndarray, target: np.ndarray) -> np.ndarray:
    """World-from-camera (OpenCV axes: x right, y down, z forward), the image's up towards +z."""
    z = (target - eye) / np.linalg.norm(target - eye)
    x = np.cross(z, [0, 0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    T = np.eye(4)
    T[:3, :3] = np.stack([x, y, z], 1)
    T[:3, 3] = eye
    return T


def rot_z(angle: float) -> np.ndarray:
    T = np.eye(4)
    c, s = math.cos(angle), math.sin(angle)
    T[:2, :2] = [[c, -s], [s, c]]
    return T


def small_turn(yaw_deg: float, pitch_deg: float, shift_m: tuple[float, float, float]) -> np.ndarray:
    """colour-from-depth: the depth camera beside colour's, turned a little."""
    a, b = math.radians(yaw_deg), math.radians(pitch_deg)
    Ry = np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])
    Rx = np.array([[1, 0, 0], [0, math.cos(b), -math.sin(b)], [0, math.sin(b), math.cos(b)]])
    T = np.eye(4)
    T[:3, :3] = Ry @ Rx
    T[:3, 3] = shift_m
    return T


# ---------------------------------------------------------------- the scene
@dataclass
class Scene:
    """The truth mesh on the board, in the table frame; the table turns about z."""

    truth: trimesh.Trimesh
    board_yaml: Path
    albedo: float = 0.55  # the object's grey level (linear)
    dark_shiny: bool = False  # holes where it faces the depth camera or at random (a dark glaze)
    _built: object = None

    def build(self) -> None:
        import open3d as o3d

        board = yaml.safe_load(self.board_yaml.read_text())
        self.tag_size = float(board["tag_size_m"])
        self.radius = float(board.get("table_diameter_m", 0.4)) / 2
        self.tags = [(int(t["id"]), np.asarray(t["center_m"], float)) for t in board["tags"]]
        self.bits = {i: _tag_bits(i) for i, _ in self.tags}
        scene = o3d.t.geometry.RaycastingScene()
        disc = trimesh.creation.cylinder(radius=self.radius, height=0.02, sections=128)
        disc.apply_translation([0, 0, -0.01])
        floor = trimesh.creation.box([3, 3, 0.01])
        floor.apply_translation([0, 0, -0.2])
        self.meshes = [self.truth, disc, floor]
        for m in self.meshes:
            scene.add_triangles(o3d.core.Tensor(np.asarray(m.vertices, np.float32)),
                                o3d.core.Tensor(np.asarray(m.faces, np.uint32)))
        self._built = scene

    def cast(self, world_from_cam: np.ndarray, dirs_cam: np.ndarray) -> dict[str, np.ndarray]:
        import open3d as o3d

        if self._built is None:
            self.build()
        d = dirs_cam.reshape(-1, 3) @ world_from_cam[:3, :3].T
        o = np.broadcast_to(world_from_cam[:3, 3], d.shape)
        rays = o3d.core.Tensor(np.concatenate([o, d], 1).astype(np.float32))
        hit = self._built.cast_rays(rays)
        t = hit["t_hit"].numpy().astype(np.float64)
        geom = hit["geometry_ids"].numpy().astype(np.int64)
        normals = hit["primitive_normals"].numpy().astype(np.float64)
        shape = dirs_cam.shape[:-1]
        return {"z": t.reshape(shape), "id": geom.reshape(shape), "n": normals.reshape(*shape, 3),
                "p": (o + d * t[:, None]).reshape(*shape, 3), "d": d.reshape(*shape, 3)}

    def board_white(self, xy: np.ndarray) -> np.ndarray:
        """True where the board's paper is white at table points xy (N, 2)."""
        white = np.ones(len(xy), bool)
        cell = self.tag_size / 8
        for tag_id, c in self.tags:
            j = np.floor((xy[:, 0] - (c[0] - self.tag_size / 2)) / cell).astype(int)
            i = np.floor(((c[1] + self.tag_size / 2) - xy[:, 1]) / cell).astype(int)
            inside = (i >= 0) & (i < 8) & (j >= 0) & (j < 8)
            white[inside] = self.bits[tag_id][i[inside], j[inside]]
        return white

    def shade(self, hit: dict[str, np.ndarray], light_dir: np.ndarray) -> np.ndarray:
        """Linear RGB radiance of each hit: albedo x (ambient + Lambert), a stripe on the object."""
        ids, p, n = hit["id"], hit["p"], hit["n"]
        albedo = np.full(ids.shape + (3,), 0.3)
        obj = ids == 0
        height = np.where(np.isfinite(p[..., 2]), p[..., 2], 0.0)
        stripe = (np.floor(height / 0.02) % 2 == 0)[..., None]
        obj_rgb = np.where(stripe, [self.albedo, self.albedo * 0.8, self.albedo * 0.6],
                           [self.albedo * 0.6, self.albedo * 0.7, self.albedo])
        albedo[obj] = obj_rgb[obj]
        on_board = ids == 1
        if on_board.any():
            pts = p[on_board]
            top = pts[:, 2] > -0.001
            white = self.board_white(pts[:, :2]) & top
            albedo[on_board] = np.where(white[:, None], 0.8, 0.04)
        cos = np.abs(np.einsum("...k,k->...", n, light_dir))
        return albedo * (0.35 + 0.6 * cos)[..., None]


def _tag_bits(tag_id: int) -> np.ndarray:
    import cv2

    d = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
    return cv2.aruco.generateImageMarker(d, tag_id, 8, borderBits=1) > 127


# ---------------------------------------------------------------- the rig and its faults
@dataclass
class Rig:
    color: Lens
    depth: Lens | None = None  # None: depth registered to colour, in its pixels
    color_from_depth: np.ndarray = field(default_factory=lambda: np.eye(4))
    distance_m: float = 0.6  # camera to the table's centre
    elevation_deg: float = 40.0
    aim_height_m: float = 0.05
    samples: int = 2  # colour rays a pixel along each side (antialiasing)


@dataclass
class Faults:
    noise: bool = True
    flying: bool = True
    drop_fraction: float = 0.03
    jitter_s: float = 0.02
    blurred: tuple[int, ...] = (7, 19)
    seed: int = 0


@dataclass
class Turn:
    frames: int = 36
    fps: float = 2.0
    deg_per_s: float = 20.0
    still_s: float = 0.0  # before the table starts
    stop_deg: float = math.inf  # where the table stops (a turn cut short)


@dataclass
class Streams:
    colors: list[tuple[float, np.ndarray]]  # (time, RGB uint8 sRGB-encoded)
    depths: list[tuple[float, np.ndarray]]  # (time, depth in m, 0 = none)
    rig: Rig


def turn_angle(t: float, turn: Turn) -> float:
    return math.radians(min(turn.stop_deg, turn.deg_per_s * max(0.0, t - turn.still_s)))


def camera_pose(rig: Rig, angle: float) -> np.ndarray:
    """World(table)-from-colour at a table turned by `angle` (the camera orbits backwards)."""
    e = math.radians(rig.elevation_deg)
    eye = np.array([rig.distance_m * math.cos(e), 0.0, rig.distance_m * math.sin(e)])
    return rot_z(-angle) @ look_at(eye, np.array([0, 0, rig.aim_height_m]))


def structured_light_sigma(z: np.ndarray) -> np.ndarray:
    return 0.0012 + 0.0019 * (z - 0.4) ** 2


def noisy_depth(hit: dict[str, np.ndarray], scene: Scene, faults: Faults, rng: np.random.Generator) -> np.ndarray:
    z = hit["z"].copy()
    z[~np.isfinite(z)] = 0
    if faults.noise:
        z = np.where(z > 0, z + rng.normal(0, 1, z.shape) * structured_light_sigma(z), 0)
    cos = np.abs(np.einsum("...k,...k->...", hit["n"], hit["d"] / np.linalg.norm(hit["d"], axis=-1, keepdims=True)))
    z[cos < 0.12] = 0  # grazing: no return
    if scene.dark_shiny:
        obj = hit["id"] == 0
        z[obj & ((cos > 0.93) | (rng.random(z.shape) < 0.25))] = 0
    if faults.flying:
        import cv2

        k = np.ones((3, 3), np.uint8)
        zf = z.astype(np.float32)
        hi, lo = cv2.dilate(zf, k), cv2.erode(np.where(zf > 0, zf, 1e3).astype(np.float32), k)
        edge = (hi - lo > 0.03) & (z > 0) & (lo < 1e3) & (rng.random(z.shape) < 0.4)
        z[edge] = (lo + rng.random(z.shape) * (hi - lo))[edge]
    return z


def motion_blur(linear: np.ndarray, px: int) -> np.ndarray:
    import cv2

    kernel = np.full((1, px), 1.0 / px, np.float32)
    return cv2.filter2D(linear.astype(np.float32), -1, kernel, borderType=cv2.BORDER_REPLICATE)


def srgb8(linear: np.ndarray) -> np.ndarray:
    c = np.clip(linear, 0, 1)
    s = np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)
    return np.round(s * 255).astype(np.uint8)


def record(scene: Scene, rig: Rig, turn: Turn, faults: Faults) -> Streams:
    """Both streams' frames and times: colour at fps from t = 0, depth near each, each
    stream dropping its own frames."""
    rng = np.random.default_rng(faults.seed)
    color_rays = rig.color.rays(samples=rig.samples)
    depth_rays = (rig.depth.rays() if rig.depth else rig.color.rays())[..., 0, :]
    n = turn.frames
    drop_c = set(rng.choice(n, int(round(faults.drop_fraction * n)), replace=False).tolist()) if faults.drop_fraction else set()
    drop_d = set(rng.choice(n, int(round(faults.drop_fraction * n)), replace=False).tolist()) if faults.drop_fraction else set()
    colors, depths = [], []
    for k in range(n):
        t = k / turn.fps
        world_from_color = camera_pose(rig, turn_angle(t, turn))
        light = world_from_color[:3, :3] @ np.array([0.3, -0.6, 0.75])
        if k not in drop_c:
            hit = scene.cast(world_from_color, color_rays)
            rgb = scene.shade(hit, light / np.linalg.norm(light)).mean(axis=2)
            if k in faults.blurred:
                rgb = motion_blur(rgb, 13)
            colors.append((t, srgb8(rgb)))
        if k not in drop_d:
            td = t + (rng.uniform(-faults.jitter_s, faults.jitter_s) if faults.jitter_s else 0.0)
            hit = scene.cast(camera_pose(rig, turn_angle(td, turn)) @ rig.color_from_depth, depth_rays)
            depths.append((td, noisy_depth(hit, scene, faults, rng)))
    return Streams(colors, depths, rig)


# ---------------------------------------------------------------- writers
def depth_u16(z_m: np.ndarray, unit_m: float) -> np.ndarray:
    return np.clip(np.round(z_m / unit_m), 0, 65535).astype(np.uint16)


def write_tum(s: Streams, folder: Path, *, unit_m: float = 0.0002, t0: float = 1305031449.0,
              depth_clock_drift: float = 0.0) -> None:
    """The TUM benchmark's layout: rgb/, depth/, rgb.txt, depth.txt; depth stamped by its own
    clock, which may drift (`depth_clock_drift`, s per s)."""
    import cv2

    (folder / "rgb").mkdir(parents=True)
    (folder / "depth").mkdir()
    lines = {"rgb": ["# color images", "# file: 'unseen'", "# timestamp filename"],
             "depth": ["# depth maps", "# file: 'unseen'", "# timestamp filename"]}
    for t, rgb in s.colors:
        name = f"rgb/{t0 + t:.6f}.png"
        cv2.imwrite(str(folder / name), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
        lines["rgb"].append(f"{t0 + t:.6f} {name}")
    for t, z in s.depths:
        stamp = t0 + t * (1 + depth_clock_drift)
        name = f"depth/{stamp:.6f}.png"
        cv2.imwrite(str(folder / name), depth_u16(z, unit_m))
        lines["depth"].append(f"{stamp:.6f} {name}")
    for key, rows in lines.items():
        (folder / f"{key}.txt").write_text("\n".join(rows) + "\n")


def camera_yaml(lens: Lens, path: Path, *, depth_scale_m: float = 0.001) -> None:
    doc = {"width": lens.width, "height": lens.height, "fx": lens.fx, "fy": lens.fy, "cx": lens.cx, "cy": lens.cy,
           "depth_scale_m": depth_scale_m}
    if lens.dist:
        doc["distortion"] = list(lens.dist[:5]) + [0.0] * (5 - len(lens.dist[:5]))
    path.write_text(yaml.safe_dump(doc))


def write_open3d(s: Streams, folder: Path, *, unit_m: float, intrinsic: dict, jpg: bool = False) -> None:
    """color/ and depth/ numbered from 0, with `intrinsic` as intrinsic.json."""
    import cv2

    (folder / "color").mkdir(parents=True)
    (folder / "depth").mkdir()
    pairs = pair_by_time(s)
    for k, (rgb, z) in enumerate(pairs):
        cv2.imwrite(str(folder / "color" / f"{k:06d}.{'jpg' if jpg else 'png'}"), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
        cv2.imwrite(str(folder / "depth" / f"{k:06d}.png"), depth_u16(z, unit_m))
    (folder / "intrinsic.json").write_text(json.dumps(intrinsic, indent=1))


def pair_by_time(s: Streams) -> list[tuple[np.ndarray, np.ndarray]]:
    """What a recorder that saves pairs keeps: each colour with the nearest depth within half a period."""
    times = np.array([t for t, _ in s.depths])
    out = []
    for t, rgb in s.colors:
        j = int(np.argmin(np.abs(times - t)))
        if abs(times[j] - t) < 0.25:
            out.append((rgb, s.depths[j][1]))
    return out


@dataclass
class RosLayout:
    color_topic: str
    depth_topic: str
    color_info: str
    depth_info: str
    color_frame: str
    depth_frame: str
    base_frame: str = "camera_base"
    color_compressed: str | None = None  # "jpeg" or "png": sensor_msgs/CompressedImage
    color_encoding: str = "rgb8"  # rgb8 | bgr8 (raw Image)
    depth_encoding: str = "16UC1"  # 16UC1 (mm) | 32FC1 (m)
    big_endian: bool = False
    tf_static: bool = True
    distortion_model: str = "plumb_bob"
    info_distortion: tuple[float, ...] | None = None  # CameraInfo's D for rectified images (the lens they came through)


def ros_messages(s: Streams, lay: RosLayout, typestore, t0: float = 1_700_000_000.0):  # noqa: ANN001, ANN201
    """(topic, msgtype, time ns, message) for the streams, in time order."""
    import cv2

    T = typestore.types
    Header, Time = T["std_msgs/msg/Header"], T["builtin_interfaces/msg/Time"]
    ros1 = "seq" in Header.__dataclass_fields__

    def header(t: float, frame: str, seq: int = 0):  # noqa: ANN202
        stamp = Time(sec=int(t0 + t), nanosec=int(round(((t0 + t) % 1) * 1e9)) % 1_000_000_000)
        return Header(seq=seq, stamp=stamp, frame_id=frame) if ros1 else Header(stamp=stamp, frame_id=frame)

    def info(t: float, lens: Lens, frame: str):  # noqa: ANN202
        d = list(lens.dist if lay.info_distortion is None else lay.info_distortion) + [0.0] * max(0, (8 if lay.distortion_model == "rational_polynomial" else 5) - len(lens.dist))
        P = [lens.fx, 0, lens.cx, 0, 0, lens.fy, lens.cy, 0, 0, 0, 1, 0]
        Roi = T["sensor_msgs/msg/RegionOfInterest"]
        kw = dict(header=header(t, frame), height=lens.height, width=lens.width, distortion_model=lay.distortion_model,
                  binning_x=0, binning_y=0, roi=Roi(x_offset=0, y_offset=0, height=0, width=0, do_rectify=False))
        if ros1:
            kw.update(D=np.array(d, float), K=lens.K.ravel(), R=np.eye(3).ravel(), P=np.array(P, float))
        else:
            kw.update(d=np.array(d, float), k=lens.K.ravel(), r=np.eye(3).ravel(), p=np.array(P, float))
        return T["sensor_msgs/msg/CameraInfo"](**kw)

    def image(t: float, frame: str, arr: np.ndarray, enc: str, big: bool = False):  # noqa: ANN202
        if big and arr.dtype.itemsize > 1:
            arr = arr.astype(arr.dtype.newbyteorder(">"))
        data = np.frombuffer(np.ascontiguousarray(arr).tobytes(), np.uint8)
        return T["sensor_msgs/msg/Image"](header=header(t, frame), height=arr.shape[0], width=arr.shape[1],
                                          encoding=enc, is_bigendian=int(big), step=arr.shape[1] * arr[0, 0].nbytes if arr.ndim == 3 else arr.shape[1] * arr.itemsize,
                                          data=data)

    color_lens, depth_lens = s.rig.color, s.rig.depth or s.rig.color
    out = []
    for t, rgb in s.colors:
        if lay.color_compressed:
            ext = ".jpg" if lay.color_compressed == "jpeg" else ".png"
            ok, buf = cv2.imencode(ext, cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
            fmt = f"bgr8; {lay.color_compressed} compressed bgr8"
            msg = T["sensor_msgs/msg/CompressedImage"](header=header(t, lay.color_frame), format=fmt,
                                                     data=np.frombuffer(buf.tobytes(), np.uint8))
            out.append((lay.color_topic, "sensor_msgs/msg/CompressedImage", t, msg))
        else:
            arr = rgb if lay.color_encoding == "rgb8" else rgb[..., ::-1].copy()
            out.append((lay.color_topic, "sensor_msgs/msg/Image", t, image(t, lay.color_frame, arr, lay.color_encoding)))
        out.append((lay.color_info, "sensor_msgs/msg/CameraInfo", t, info(t, color_lens, lay.color_frame)))
    for t, z in s.depths:
        arr = depth_u16(z, 0.001) if lay.depth_encoding == "16UC1" else z.astype(np.float32)
        out.append((lay.depth_topic, "sensor_msgs/msg/Image", t, image(t, lay.depth_frame, arr, lay.depth_encoding, lay.big_endian)))
        out.append((lay.depth_info, "sensor_msgs/msg/CameraInfo", t, info(t, depth_lens, lay.depth_frame)))
    if lay.tf_static and s.rig.depth is not None:
        out.append(("/tf_static", "tf2_msgs/msg/TFMessage", -0.5, tf_static(s.rig, lay, typestore, header)))
    out.sort(key=lambda m: m[2])
    return [(topic, mt, int(round((t0 + t) * 1e9)), msg) for topic, mt, t, msg in out]


def tf_static(rig: Rig, lay: RosLayout, typestore, header):  # noqa: ANN001, ANN201
    """base -> colour (identity) and base -> depth (colour-from-depth), as a driver publishes them."""
    from scipy.spatial.transform import Rotation

    T = typestore.types

    def stamped(child: str, M: np.ndarray):  # noqa: ANN202
        q = Rotation.from_matrix(M[:3, :3]).as_quat()
        tr = T["geometry_msgs/msg/Transform"](
            translation=T["geometry_msgs/msg/Vector3"](x=M[0, 3], y=M[1, 3], z=M[2, 3]),
            rotation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3]))
        return T["geometry_msgs/msg/TransformStamped"](header=header(-0.5, lay.base_frame), child_frame_id=child, transform=tr)

    return T["tf2_msgs/msg/TFMessage"](transforms=[stamped(lay.color_frame, np.eye(4)),
                                                   stamped(lay.depth_frame, rig.color_from_depth)])


def write_ros1(s: Streams, path: Path, lay: RosLayout) -> None:
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    from rosbags.typesys import get_types_from_msg

    store = get_typestore(Stores.ROS1_NOETIC)
    if "tf2_msgs/msg/TFMessage" not in store.types:  # not in rosbags' noetic store
        store.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"))
    msgs = ros_messages(s, lay, store)
    with Writer(path) as w:
        conns = {}
        for topic, mt, ns, msg in msgs:
            if topic not in conns:
                conns[topic] = w.add_connection(topic, mt, typestore=store, latching=1 if topic == "/tf_static" else None)
            w.write(conns[topic], ns, store.serialize_ros1(msg, mt))


def write_ros2(s: Streams, path: Path, lay: RosLayout, *, mcap: bool) -> None:
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    msgs = ros_messages(s, lay, store)
    with Writer(path, version=8, storage_plugin=StoragePlugin.MCAP if mcap else StoragePlugin.SQLITE3) as w:
        conns = {}
        for topic, mt, ns, msg in msgs:
            if topic not in conns:
                conns[topic] = w.add_connection(topic, mt, typestore=store)
            w.write(conns[topic], ns, store.serialize_cdr(msg, mt))


def write_realsense(s: Streams, path: Path, *, depth_unit_m: float = 0.001, color_format: str = "bgr8") -> None:
    """A .bag as the RealSense Viewer records a D400: pyrealsense2's software device (a Stereo
    Module with z16 depth and its depth_units, an RGB Camera) and its recorder; both streams
    stamped by the camera's clock; the depth-to-colour extrinsics registered."""
    import pyrealsense2 as rs

    def intrinsics(lens: Lens) -> object:
        i = rs.intrinsics()
        i.width, i.height, i.fx, i.fy, i.ppx, i.ppy = lens.width, lens.height, lens.fx, lens.fy, lens.cx, lens.cy
        i.model = rs.distortion.brown_conrady
        i.coeffs = [float(c) for c in (list(lens.dist) + [0.0] * 5)[:5]]
        return i

    depth_lens = s.rig.depth or s.rig.color
    device = rs.software_device()
    depth_sensor, color_sensor = device.add_sensor("Stereo Module"), device.add_sensor("RGB Camera")
    profiles = []
    for sensor, kind, uid, lens, bpp, fmt in ((depth_sensor, rs.stream.depth, 0, depth_lens, 2, rs.format.z16),
                                              (color_sensor, rs.stream.color, 1, s.rig.color, 3, getattr(rs.format, color_format))):
        stream = rs.video_stream()
        stream.type, stream.uid, stream.index, stream.fps, stream.bpp, stream.fmt = kind, uid, 0, 30, bpp, fmt
        stream.width, stream.height, stream.intrinsics = lens.width, lens.height, intrinsics(lens)
        profiles.append(sensor.add_video_stream(stream))
    depth_sensor.add_read_only_option(rs.option.depth_units, depth_unit_m)
    ext = rs.extrinsics()
    ext.rotation = s.rig.color_from_depth[:3, :3].T.ravel().tolist()  # column-major
    ext.translation = s.rig.color_from_depth[:3, 3].tolist()
    profiles[0].register_extrinsics_to(profiles[1], ext)
    recorder = rs.recorder(str(path), device)
    queue = rs.syncer()
    for sensor, profile in zip((depth_sensor, color_sensor), profiles):
        sensor.open(profile)
        sensor.start(queue)
    events = [(t, 0, depth_u16(z, depth_unit_m)) for t, z in s.depths]
    events += [(t, 1, rgb[..., ::-1].copy() if color_format == "bgr8" else rgb) for t, rgb in s.colors]
    for n, (t, which, pixels) in enumerate(sorted(events, key=lambda e: e[0])):
        frame = rs.software_video_frame()
        frame.pixels = np.ascontiguousarray(pixels)
        frame.bpp = pixels.itemsize * (pixels.shape[2] if pixels.ndim == 3 else 1)
        frame.stride = pixels.shape[1] * frame.bpp
        frame.timestamp, frame.domain, frame.frame_number = 1000.0 * (t + 5000.0), rs.timestamp_domain.hardware_clock, n + 1
        frame.profile = profiles[which].as_video_stream_profile()
        if which == 0:
            frame.depth_units = depth_unit_m
        (depth_sensor if which == 0 else color_sensor).on_video_frame(frame)
    for sensor in (depth_sensor, color_sensor):
        sensor.stop()
        sensor.close()
    del recorder  # closes the file


# ---------------------------------------------------------------- running the README's commands
def run(args: list[str], cwd: Path) -> tuple[int, str, str, float]:
    import resource

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    p = subprocess.run([str(CLI), *args], cwd=cwd, capture_output=True, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return p.returncode, p.stdout, p.stderr, cpu


def model_mesh(model_dir: Path) -> Path:
    for name in ("mesh.ply", "model.ply"):
        if (model_dir / name).exists():
            return model_dir / name
    plys = sorted(model_dir.rglob("*.ply"))
    if not plys:
        raise FileNotFoundError(f"no mesh in {model_dir}")
    return plys[0]


def measure(mesh_path: Path, truth: trimesh.Trimesh) -> tuple[float, float]:
    from homemodel.evaluation import mean_surface_distance_m, voxel_iou

    mesh = trimesh.load(mesh_path, force="mesh")
    return 1000 * mean_surface_distance_m(mesh, truth), voxel_iou(mesh, truth, voxel_size_m=0.002)


def import_and_reconstruct(recording: Path, work: Path, board_yaml: Path, extra: list[str] = ()) -> dict:
    scan, model = work / "scan", work / "model"
    code, out, err, cpu_i = run(["turntable", "import", str(recording), "--board", str(board_yaml), "--out", str(scan), *extra], work)
    res = {"import_exit": code, "import_out": out.strip()[-2000:], "import_err": err.strip()[-2000:], "import_cpu_s": round(cpu_i, 2)}
    if code != 0:
        return res
    code, out, err, cpu_r = run(["turntable", "reconstruct", str(scan), "--out", str(model)], work)
    res.update(reconstruct_exit=code, reconstruct_err=err.strip()[-2000:], reconstruct_cpu_s=round(cpu_r, 2))
    return res


# ---------------------------------------------------------------- the cases
AZURE_COLOR = Lens(1280, 720, 605.2, 605.0, 638.4, 365.9, (0.512, -2.61, 0.0004, -0.0003, 1.45, 0.39, -2.43, 1.37))
AZURE_NFOV = Lens(640, 576, 504.3, 504.4, 322.9, 333.6, (3.12, 1.95, 0.00011, -0.00002, 0.11, 3.46, 2.95, 0.58))
# The Azure Kinect's depth camera sits 32 mm beside colour's and looks 6 deg further down.
AZURE_COLOR_FROM_DEPTH = small_turn(0.1, -6.0, (-0.032, -0.002, 0.004))
FEMTO_COLOR = Lens(1280, 720, 689.9, 689.6, 644.3, 363.4, (0.071, -0.092, 0.0003, -0.0002, 0.037))
L515_COLOR = Lens(960, 540, 680.1, 680.3, 483.4, 271.2)
L515_DEPTH = Lens(640, 480, 458.2, 458.4, 325.3, 244.1)
L515_COLOR_FROM_DEPTH = small_turn(0.35, 0.2, (0.0144, 0.0, 0.0))  # lidar beside colour, no tf recorded
KINECT1 = Lens(640, 480, 525.0, 525.0, 319.5, 239.5)
ASTRA_COLOR = Lens(640, 480, 517.3, 516.5, 318.6, 255.3, (0.26, -0.95, -0.0054, 0.0026, 1.16))
ASTRA_DEPTH = Lens(640, 480, 570.3, 570.3, 319.5, 239.5)
ASTRA_COLOR_FROM_DEPTH = small_turn(-0.2, 0.1, (-0.025, 0.0003, 0.001))
D405 = Lens(848, 480, 431.6, 431.1, 424.7, 241.8)
KINECT2_QHD = Lens(960, 540, 529.9, 530.1, 477.4, 269.8)  # image_*_rect: rectified
KINECT2_LENS = (0.021, -0.018, 0.0004, -0.0006, 0.003)
D435_COLOR = Lens(640, 480, 615.4, 615.6, 326.3, 240.9)
D435_DEPTH = Lens(848, 480, 427.9, 427.9, 424.1, 238.5)
D435_COLOR_FROM_DEPTH = small_turn(0.25, -0.15, (0.0148, 0.0001, 0.0003))


@dataclass
class Case:
    name: str
    fmt: str
    obj: str
    rig: Rig
    turn: Turn = field(default_factory=Turn)
    faults: Faults = field(default_factory=Faults)
    dark_shiny: bool = False
    albedo: float = 0.55
    notes: str = ""


CASES = {
    c.name: c
    for c in [
        Case("azure_ros1_bottle", "ros1 jpeg CompressedImage colour, 16UC1 mm NFOV depth, rational k1-k6, /tf_static", "bottle",
             Rig(AZURE_COLOR, AZURE_NFOV, AZURE_COLOR_FROM_DEPTH, distance_m=0.75, elevation_deg=35, aim_height_m=0.1, samples=1)),
        Case("femto_mcap_plate", "ros2 mcap, rgb8 colour, 32FC1 m big-endian depth registered in colour's frame", "plate",
             Rig(FEMTO_COLOR, None, distance_m=0.55, elevation_deg=50, aim_height_m=0.0, samples=1),
             turn=Turn(frames=54, fps=3.0, deg_per_s=40.0)),  # two turns
        Case("l515_db3_box", "ros2 sqlite3, png CompressedImage colour, 16UC1 depth of its own, no /tf_static", "box",
             Rig(L515_COLOR, L515_DEPTH, L515_COLOR_FROM_DEPTH, distance_m=0.65, elevation_deg=40, samples=1)),
        Case("kinect1_tum_mug", "TUM, depth clock drifting 1.5 ms/s, dark shiny mug (holes)", "mug",
             Rig(KINECT1, None, distance_m=0.7, elevation_deg=40), dark_shiny=True, albedo=0.06),
        Case("astra_mcap_mug_stops", "ros2 mcap, bgr8 colour, 16UC1 big-endian depth of its own, /tf_static, table stops at 250 deg", "mug",
             Rig(ASTRA_COLOR, ASTRA_DEPTH, ASTRA_COLOR_FROM_DEPTH, distance_m=0.6, elevation_deg=30, aim_height_m=0.05),
             turn=Turn(frames=36, fps=2.0, deg_per_s=20.0, stop_deg=250.0)),
        Case("astra_mcap_bottle", "ros2 mcap, bgr8 colour, 16UC1 big-endian depth of its own, /tf_static", "bottle",
             Rig(ASTRA_COLOR, ASTRA_DEPTH, ASTRA_COLOR_FROM_DEPTH, distance_m=0.6, elevation_deg=30, aim_height_m=0.05)),
        Case("d435_bag_bottle_fast", "RealSense .bag (software device + recorder), bgr8 640x480 colour, z16 848x480 depth, "
             "extrinsics, a fast turn (36 deg/s, 2 blurred)", "bottle",
             Rig(D435_COLOR, D435_DEPTH, D435_COLOR_FROM_DEPTH, distance_m=0.5, elevation_deg=35, aim_height_m=0.1),
             turn=Turn(frames=30, fps=3.0, deg_per_s=36.0), faults=Faults(blurred=(5, 17), seed=3)),
        Case("kinect2_ros1_qhd_bottle_far", "ros1 iai_kinect2 qhd: png CompressedImage colour, registered 16UC1 depth, bottle at 1.0 m",
             "bottle", Rig(KINECT2_QHD, None, distance_m=1.0, elevation_deg=45, aim_height_m=0.08, samples=1),
             faults=Faults(seed=5)),
        Case("d405_open3d_box", "Open3D folder, 0.1 mm depth, intrinsic.json row-major nested matrix", "box",
             Rig(D405, None, distance_m=0.42, elevation_deg=45, aim_height_m=0.03)),
    ]
}


def write_case(case: Case, streams: Streams, rec: Path) -> list[str]:
    """Writes the recording as its camera's software would; returns the import's extra arguments."""
    lens = case.rig.color
    if case.name == "azure_ros1_bottle":
        write_ros1(streams, rec.with_suffix(".bag"), RosLayout(
            "/rgb/image_raw/compressed", "/depth/image_raw", "/rgb/camera_info", "/depth/camera_info",
            "rgb_camera_link", "depth_camera_link", color_compressed="jpeg", distortion_model="rational_polynomial"))
        return []
    if case.name == "femto_mcap_plate":
        write_ros2(streams, rec, RosLayout("/camera/color/image_raw", "/camera/depth/image_raw", "/camera/color/camera_info",
                                           "/camera/depth/camera_info", "camera_color_optical_frame", "camera_color_optical_frame",
                                           depth_encoding="32FC1", big_endian=True), mcap=True)
        return []
    if case.name == "kinect2_ros1_qhd_bottle_far":
        write_ros1(streams, rec.with_suffix(".bag"), RosLayout(
            "/kinect2/qhd/image_color_rect/compressed", "/kinect2/qhd/image_depth_rect", "/kinect2/qhd/camera_info",
            "/kinect2/qhd/camera_info_depth", "kinect2_rgb_optical_frame", "kinect2_rgb_optical_frame", color_compressed="png",
            info_distortion=KINECT2_LENS))
        return []
    if case.name == "l515_db3_box":
        write_ros2(streams, rec, RosLayout("/camera/color/image_raw/compressed", "/camera/depth/image_rect_raw",
                                           "/camera/color/camera_info", "/camera/depth/camera_info",
                                           "camera_color_optical_frame", "camera_depth_optical_frame",
                                           color_compressed="png", tf_static=False), mcap=False)
        return []
    if case.name.startswith("astra_mcap"):
        write_ros2(streams, rec, RosLayout("/camera/color/image_raw", "/camera/depth/image_raw", "/camera/color/camera_info",
                                           "/camera/depth/camera_info", "camera_color_optical_frame", "camera_depth_optical_frame",
                                           color_encoding="bgr8", big_endian=True), mcap=True)
        return []
    if case.name == "d435_bag_bottle_fast":
        write_realsense(streams, rec.with_suffix(".bag"))
        return []
    if case.name == "kinect1_tum_mug":
        write_tum(streams, rec, depth_clock_drift=0.0015)
        camera_yaml(lens, rec.parent / "kinect1.yaml", depth_scale_m=0.0002)
        return ["--camera", str(rec.parent / "kinect1.yaml")]
    if case.name == "d405_open3d_box":
        intrinsic = {"width": lens.width, "height": lens.height, "depth_scale": 10000.0,
                     "intrinsic_matrix": [[lens.fx, 0, lens.cx], [0, lens.fy, lens.cy], [0, 0, 1]]}
        write_open3d(streams, rec, unit_m=0.0001, intrinsic=intrinsic)
        return []
    raise KeyError(case.name)


def recording_path(case: Case, root: Path) -> Path:
    rec = root / "recordings" / case.name
    return rec.with_suffix(".bag") if case.name in ("azure_ros1_bottle", "d435_bag_bottle_fast", "kinect2_ros1_qhd_bottle_far") else rec


def clean_twin(case: Case, root: Path, board_yaml: Path) -> Path:
    """The same colour camera without its lens, depth rendered in its pixels, the same noise,
    no other fault: an Open3D folder in 0.1 mm."""
    scene = Scene(OBJECTS[case.obj](), board_yaml, albedo=case.albedo, dark_shiny=case.dark_shiny)
    rig = replace(case.rig, color=case.rig.color.pinhole(), depth=None, color_from_depth=np.eye(4))
    streams = record(scene, rig, case.turn, Faults(flying=False, drop_fraction=0, jitter_s=0, blurred=()))
    lens = rig.color
    folder = root / "recordings" / f"{case.name}_twin"
    shutil.rmtree(folder, ignore_errors=True)
    write_open3d(streams, folder, unit_m=0.0001, intrinsic={
        "width": lens.width, "height": lens.height, "depth_scale": 10000.0,
        "intrinsic_matrix": [lens.fx, 0, 0, 0, lens.fy, 0, lens.cx, lens.cy, 1]})
    return folder


def run_case(case: Case, root: Path, board_yaml: Path, *, twin: bool = True) -> dict:
    truth = OBJECTS[case.obj]()
    (root / "truth").mkdir(parents=True, exist_ok=True)
    truth.export(root / "truth" / f"{case.obj}.ply")
    rec = recording_path(case, root)
    shutil.rmtree(rec, ignore_errors=True)
    rec.unlink(missing_ok=True)
    rec.parent.mkdir(parents=True, exist_ok=True)
    t = time.process_time()
    scene = Scene(truth, board_yaml, albedo=case.albedo, dark_shiny=case.dark_shiny)
    extra = write_case(case, record(scene, case.rig, case.turn, case.faults), rec)
    result: dict = {"case": case.name, "format": case.fmt, "render_cpu_s": round(time.process_time() - t, 1)}
    work = root / "runs" / case.name
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    result.update(import_and_reconstruct(rec, work, board_yaml, extra))
    if result.get("reconstruct_exit") == 0:
        mm, iou = measure(model_mesh(work / "model"), truth)
        result.update(mm=round(mm, 3), iou=round(iou, 3))
    if twin:
        folder = clean_twin(case, root, board_yaml)
        tw = root / "runs" / f"{case.name}_twin"
        shutil.rmtree(tw, ignore_errors=True)
        tw.mkdir(parents=True)
        r = import_and_reconstruct(folder, tw, board_yaml)
        if r.get("reconstruct_exit") == 0:
            mm, iou = measure(model_mesh(tw / "model"), truth)
            result.update(twin_mm=round(mm, 3), twin_iou=round(iou, 3))
        else:
            result["twin_error"] = r.get("import_err") or r.get("reconstruct_err")
    return result


def main(argv: list[str]) -> None:
    twin = "--no-twin" not in argv
    argv = [a for a in argv if a != "--no-twin"]
    root = Path(argv[0])
    root.mkdir(parents=True, exist_ok=True)
    board_yaml = root / "board" / "board.yaml"
    if not board_yaml.exists():
        subprocess.run([str(CLI), "turntable", "board", "--out", str(board_yaml.parent)], check=True, capture_output=True)
    for name in argv[1:] or list(CASES):
        result = run_case(CASES[name], root, board_yaml, twin=twin)
        print(json.dumps(result))
        with open(root / "results.jsonl", "a") as f:
            f.write(json.dumps(result) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
