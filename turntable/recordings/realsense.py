"""Intel RealSense through `pyrealsense2`: a connected camera (live) or a recorded .bag played
back without one. Depth is aligned to colour by the SDK (`rs.align`), keeping the depth
sensor's units; the colour intrinsics and distortion come from the stream."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np

from homemodel.core.errors import InputError
from homemodel.geometry.camera import Camera
from turntable.recordings.associate import MAX_TOLERANCE_S
from turntable.recordings.source import FrameSource, RgbdPair, StreamSetup

_WAIT_MS = 5000  # a frameset later than this: the recording has ended (or the camera stalled)


def fit_brown_conrady(undistorted: np.ndarray, distorted: np.ndarray) -> tuple[np.ndarray, float]:
    """OpenCV Brown-Conrady k1 k2 p1 p2 k3 mapping normalised `undistorted` points onto
    `distorted` ones, by linear least squares (the model is linear in its coefficients), and the
    largest residual (normalised units)."""
    x, y = undistorted[:, 0], undistorted[:, 1]
    r2 = x * x + y * y
    rows_x = np.column_stack([x * r2, x * r2 * r2, 2 * x * y, r2 + 2 * x * x, x * r2**3])
    rows_y = np.column_stack([y * r2, y * r2 * r2, r2 + 2 * y * y, 2 * x * y, y * r2**3])
    a = np.vstack([rows_x, rows_y])
    b = np.concatenate([distorted[:, 0] - x, distorted[:, 1] - y])
    coefficients = np.linalg.lstsq(a, b, rcond=None)[0]
    return coefficients, float(np.max(np.abs(a @ coefficients - b)))


def camera_from_intrinsics(intrinsics: object, depth_scale_m: float) -> tuple[Camera, list[str]]:
    """Our Camera of an rs.intrinsics, and notes on what its distortion model became."""
    import pyrealsense2 as rs

    camera = Camera(
        width=intrinsics.width,
        height=intrinsics.height,
        fx=intrinsics.fx,
        fy=intrinsics.fy,
        cx=intrinsics.ppx,
        cy=intrinsics.ppy,
        depth_scale_m=depth_scale_m,
    )
    coeffs = [float(c) for c in intrinsics.coeffs]
    model = intrinsics.model
    if not any(coeffs) or model == rs.distortion.none:
        return camera, []
    notes = []
    if model in (rs.distortion.kannala_brandt4, rs.distortion.ftheta):
        if model == rs.distortion.ftheta:
            notes.append("F-theta distortion read as Kannala-Brandt")
        fields = {"distortion": tuple(coeffs[:4]), "distortion_model": "kannala_brandt"}
    elif model == rs.distortion.inverse_brown_conrady:
        # Its coefficients undistort: map a grid of image points through them and fit the
        # forward (OpenCV) model to the pairs.
        u, v = np.meshgrid(np.linspace(0, camera.width - 1, 40), np.linspace(0, camera.height - 1, 30))
        distorted = np.column_stack([(u.ravel() - camera.cx) / camera.fx, (v.ravel() - camera.cy) / camera.fy])
        k1, k2, p1, p2, k3 = coeffs
        x, y = distorted[:, 0], distorted[:, 1]
        r2 = x * x + y * y
        radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
        undistorted = np.column_stack(
            [x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x), y * radial + 2 * p2 * x * y + p1 * (r2 + 2 * y * y)]
        )
        fitted, residual = fit_brown_conrady(undistorted, distorted)
        notes.append(f"inverse Brown-Conrady refitted as Brown-Conrady ({residual * camera.fx:.3f} px at worst)")
        fields = {"distortion": tuple(float(c) for c in fitted)}
    else:
        if model == rs.distortion.modified_brown_conrady:
            notes.append("modified Brown-Conrady read as Brown-Conrady")
        fields = {"distortion": tuple(coeffs[:5])}
    return Camera(**{**camera.model_dump(), **fields}), notes


def _rgb(frame: object) -> np.ndarray:
    import cv2
    import pyrealsense2 as rs

    image = np.asanyarray(frame.get_data())
    form = frame.get_profile().format()
    if form == rs.format.bgr8:
        return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)
    if form in (rs.format.rgba8, rs.format.bgra8):
        return cv2.cvtColor(image, cv2.COLOR_RGBA2RGB if form == rs.format.rgba8 else cv2.COLOR_BGRA2RGB)
    if form == rs.format.yuyv:
        return cv2.cvtColor(image.reshape(image.shape[0], -1, 2), cv2.COLOR_YUV2RGB_YUYV)
    if form != rs.format.rgb8:
        raise InputError(f"colour stream format {form} is not supported (rgb8, bgr8, rgba8, bgra8, yuyv)")
    return image.copy()


class RealSenseSource(FrameSource):
    """`bag`: play a recording (no camera needed); else the connected camera `serial` (or the
    only one), streaming colour at `color_size` and depth at `depth_size`, 30 frames a second."""

    def __init__(
        self,
        *,
        bag: Path | None = None,
        serial: str | None = None,
        every: int = 1,
        tolerance_s: float | None = None,
        color_size: tuple[int, int] = (1280, 720),
        depth_size: tuple[int, int] = (848, 480),
    ) -> None:
        self.bag = None if bag is None else Path(bag)
        self.serial = serial
        self.every = every
        self.tolerance_s = tolerance_s
        self.color_size, self.depth_size = color_size, depth_size
        self._pipeline = None
        self.where = str(self.bag) if self.bag else f"RealSense {serial or '(first connected)'}"

    def open(self) -> StreamSetup:
        import pyrealsense2 as rs

        config = rs.config()
        if self.bag is not None:
            config.enable_device_from_file(str(self.bag), repeat_playback=False)
        else:
            serials = [d.get_info(rs.camera_info.serial_number) for d in rs.context().query_devices()]
            if not serials:
                raise InputError("no RealSense camera is connected (pyrealsense2 finds none)")
            if self.serial is not None and self.serial not in serials:
                raise InputError(f"no RealSense camera with serial {self.serial} (connected: {', '.join(serials)})")
            if self.serial is not None:
                config.enable_device(self.serial)
            config.enable_stream(rs.stream.color, *self.color_size, rs.format.rgb8, 30)
            config.enable_stream(rs.stream.depth, *self.depth_size, rs.format.z16, 30)
        self._pipeline = rs.pipeline()
        try:
            profile = self._pipeline.start(config)
        except RuntimeError as exc:
            self._pipeline = None
            raise InputError(f"{self.where}: cannot start the streams: {exc}") from None
        device = profile.get_device()
        if self.bag is not None:
            device.as_playback().set_real_time(False)  # every frame, as fast as it decodes
        streams = {s.stream_type(): s for s in profile.get_streams()}
        if rs.stream.depth not in streams:
            raise InputError(f"{self.where}: no depth stream")
        if rs.stream.color not in streams:
            raise InputError(f"{self.where}: no colour stream")
        depth_scale = device.first_depth_sensor().get_depth_scale()
        intrinsics = streams[rs.stream.color].as_video_stream_profile().get_intrinsics()
        if intrinsics.fx <= 0 or intrinsics.fy <= 0:
            raise InputError(f"{self.where}: the colour stream has no intrinsics")
        camera, notes = camera_from_intrinsics(intrinsics, depth_scale)
        self._align = rs.align(rs.stream.color)
        setup = StreamSetup(format="realsense-bag" if self.bag else "realsense-live", color_camera=camera, notes=notes)
        if intrinsics.model in (rs.distortion.brown_conrady, rs.distortion.kannala_brandt4) and any(intrinsics.coeffs):
            # The SDK's align lands depth up to mm off the truth under a forward-distorting colour
            # lens here (measured against ray-cast depth); D400 colour uses inverse Brown-Conrady.
            depth_intrinsics = streams[rs.stream.depth].as_video_stream_profile().get_intrinsics()
            setup.depth_camera, depth_notes = camera_from_intrinsics(depth_intrinsics, depth_scale)
            extrinsics = streams[rs.stream.depth].get_extrinsics_to(streams[rs.stream.color])
            setup.color_from_depth = np.eye(4)
            setup.color_from_depth[:3, :3] = np.asarray(extrinsics.rotation, dtype=np.float64).reshape(3, 3).T
            setup.color_from_depth[:3, 3] = extrinsics.translation
            setup.notes += depth_notes + ["a distorting colour lens: depth reprojected here, not by the SDK's align"]
            self._align = None
        # The SDK's align keeps each depth pixel's own z (the depth camera's), not the z in
        # colour's frame: off by the cameras' relative tilt (mm at a metre for half a degree).
        # The point lies on its colour pixel's ray r at z_c: z_d = z_c (R^T r)_z - (R^T t)_z.
        extrinsics = streams[rs.stream.depth].get_extrinsics_to(streams[rs.stream.color])
        rotation = np.asarray(extrinsics.rotation, dtype=np.float64).reshape(3, 3).T  # column-major
        translation = np.asarray(extrinsics.translation, dtype=np.float64)
        depth_from_color_rays = camera.pixel_rays() @ rotation  # rows: (R^T r)^T
        self._z_gain = (1.0 / depth_from_color_rays[:, 2]).reshape(camera.height, camera.width).astype(np.float32)
        self._z_offset_m = float((rotation.T @ translation)[2])
        if self.tolerance_s is None:  # half a frame interval
            self.tolerance_s = min(0.5 / max(streams[rs.stream.color].fps(), 1), MAX_TOLERANCE_S)
        return setup

    def _colour_z(self, units: np.ndarray) -> np.ndarray:
        """Aligned depth units to float32 metres along colour's axis (NaN: none)."""
        z_depth = units.astype(np.float32) * np.float32(self.setup.color_camera.depth_scale_m)
        z_depth[units == 0] = np.nan
        return (z_depth + np.float32(self._z_offset_m)) * self._z_gain

    def close(self) -> None:
        if self._pipeline is not None:
            self._pipeline.stop()
            self._pipeline = None

    def pairs(self, *, start_s: float = 0.0, end_s: float | None = None) -> Iterator[RgbdPair]:
        """The SDK's framesets, each colour and depth frame used once, in pairs at most
        `tolerance_s` apart (the syncer repeats a stream's last frame beside the other's new one)."""
        counts = self.counts
        origin = None
        seen: dict[str, set[int]] = {"color": set(), "depth": set()}
        used: dict[str, set[int]] = {"color": set(), "depth": set()}
        kept = 0
        try:
            while True:
                ok, frames = self._pipeline.try_wait_for_frames(_WAIT_MS)
                if not ok:
                    if self.bag is None:
                        raise InputError(f"{self.where}: no frames for {_WAIT_MS / 1000:.0f} s")
                    return
                color, depth = frames.get_color_frame(), frames.get_depth_frame()
                for kind, frame in (("color", color), ("depth", depth)):
                    if frame:
                        seen[kind].add(frame.get_frame_number())
                if not color or not depth:
                    continue
                numbers = color.get_frame_number(), depth.get_frame_number()
                offset_s = (depth.get_timestamp() - color.get_timestamp()) / 1000
                if numbers[0] in used["color"] or numbers[1] in used["depth"] or abs(offset_s) > self.tolerance_s:
                    continue
                used["color"].add(numbers[0])
                used["depth"].add(numbers[1])
                counts.pairs += 1
                counts.max_offset_s = max(counts.max_offset_s, abs(offset_s))
                origin = color.get_timestamp() if origin is None else origin
                time_s = (color.get_timestamp() - origin) / 1000
                if time_s < start_s or (end_s is not None and time_s > end_s):
                    continue
                kept += 1
                if (kept - 1) % self.every:
                    continue
                if self._align is None:  # registered by the reader of the pairs (setup.depth_camera)
                    color_image, depth_image = _rgb(color), np.asanyarray(depth.get_data()).copy()
                else:
                    aligned = self._align.process(frames)
                    color_image = _rgb(aligned.get_color_frame())
                    depth_image = self._colour_z(np.asanyarray(aligned.get_depth_frame().get_data()))
                yield RgbdPair(time_s=time_s, color=color_image, depth=depth_image, depth_offset_s=offset_s)
        finally:
            for kind in ("color", "depth"):
                numbers = seen[kind]
                setattr(counts, f"{kind}_frames", len(numbers))
                # Frames the camera counted but never delivered are dropped too.
                missing = max(numbers) - min(numbers) + 1 - len(numbers) if numbers else 0
                setattr(counts, f"dropped_{kind}", len(numbers) - counts.pairs + missing)
