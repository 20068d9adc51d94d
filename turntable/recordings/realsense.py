"""Intel RealSense through `pyrealsense2`: a connected camera (live) or a recorded .bag played
back without one. Depth keeps the depth sensor's units and is registered to colour by the
reader of the pairs with both streams' intrinsics and the recorded extrinsics
(`register.register_depth`), not by the SDK's `rs.align`: that paints each depth pixel's value
over a block of colour pixels, later pixels over earlier ones: a receding plane seen by a
D435-like pair came out 1.4 mm short (median), and on a mug at 0.5 m (848x480 depth into
1280x720 colour) the table's edge stood above the cut and joined the mesh (8.2 mm from the
truth against 0.73 mm). The colour intrinsics and distortion come from the stream."""

from __future__ import annotations

import queue
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from homemodel.core.errors import InputError
from homemodel.geometry.camera import Camera
from turntable.recordings.associate import MAX_TOLERANCE_S, StreamAssociation
from turntable.recordings.lens import refit_as_brown_conrady, undistort_inverse_brown_conrady
from turntable.recordings.source import FrameSource, RgbdPair, StreamSetup

_WAIT_S = 5.0  # a live camera without a frame this long has stalled
_PLAYBACK_STALL_S = 60.0  # a playback ends by its status; this long without a frame, it hung
_QUEUE_FRAMES = 8  # frames waiting for the reader (each held outside the SDK's pool)
# Frames of one stream held until the other's first tells whether both stamp by one clock
# (a stream starting up to a second later at 30 frames a second).
_CLOCK_WAIT_FRAMES = 32


def _depth_units_m(depth_sensor: object) -> tuple[float, list[str]]:
    """The depth sensor's units (its depth_units option, as a camera and the Viewer's .bag keep
    it); 1 mm, said, for a recording without the option."""
    import pyrealsense2 as rs

    if depth_sensor.supports(rs.option.depth_units):
        return float(depth_sensor.get_option(rs.option.depth_units)), []
    return 0.001, ["no depth units in the recording: 1 mm assumed (the D400's default)"]


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
        # Its coefficients undistort: fit the forward (OpenCV) model to what they do.
        refitted, residual_px = refit_as_brown_conrady(camera, undistort_inverse_brown_conrady(coeffs))
        notes.append(f"inverse Brown-Conrady refitted as Brown-Conrady ({residual_px:.3f} px at worst)")
        return refitted, notes
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
    if form == rs.format.yuyv:  # the SDK hands its two bytes a pixel over as uint16
        pairs = np.frombuffer(image.tobytes(), np.uint8).reshape(image.shape[0], -1, 2)
        return cv2.cvtColor(pairs, cv2.COLOR_YUV2RGB_YUYV)
    if form != rs.format.rgb8:
        raise InputError(f"colour stream format {form} is not supported (rgb8, bgr8, rgba8, bgra8, yuyv)")
    return image.copy()


class RealSenseSource(FrameSource):
    """`bag`: play a recording (no camera needed); else the connected camera `serial` (or the
    only one), streaming colour at `color_size` and depth at `depth_size`, 30 frames a second.

    Each sensor's frames come through its own callback, and we pair colour with depth by time
    (`StreamAssociation`, the TUM and ROS readers' one-to-one pairing): the SDK's syncer behind
    `rs.pipeline` keeps one frameset and drops the rest while the reader is busy, which lost 1-4
    of 24 pairs on a loaded machine. A bag plays back not in real time, and the playback waits
    while our bounded queue is full: no frame of the file is lost."""

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
        self._sensors: list = []
        self._playback = None
        self._frames: queue.Queue = queue.Queue(maxsize=_QUEUE_FRAMES)
        self._closing = False
        self.where = str(self.bag) if self.bag else f"RealSense {serial or '(first connected)'}"

    def _device(self) -> object:
        import pyrealsense2 as rs

        context = rs.context()
        if self.bag is not None:
            try:
                device = context.load_device(str(self.bag))
            except RuntimeError as exc:
                raise InputError(f"{self.where}: cannot be played back: {exc}") from None
            # Its end is read from its status, not told by a status callback: the SDK calls that
            # from its reading thread while pause() and resume() wait for that thread, holding
            # Python's lock, so each stalled 10 s (the SDK's time-out) before the callback ran.
            self._playback = device.as_playback()
            self._playback.set_real_time(False)  # every frame, waiting for our callbacks
            return device
        devices = {d.get_info(rs.camera_info.serial_number): d for d in context.query_devices()}
        if not devices:
            raise InputError(
                "no RealSense camera is connected (pyrealsense2 finds none): plug it into a USB 3 port, "
                "or play a recording with --playback FILE.bag"
            )
        if self.serial is not None and self.serial not in devices:
            raise InputError(f"no RealSense camera with serial {self.serial} (connected: {', '.join(devices)})")
        return devices[self.serial] if self.serial is not None else next(iter(devices.values()))

    def _profiles(self, device: object) -> dict[object, tuple[object, object]]:
        """stream -> (its sensor, its profile): a recording's own, or the sizes asked of a camera."""
        import pyrealsense2 as rs

        wanted = {rs.stream.color: (rs.format.rgb8, self.color_size), rs.stream.depth: (rs.format.z16, self.depth_size)}
        chosen = {}
        for sensor in device.query_sensors():
            for profile in sensor.get_stream_profiles():
                stream = profile.stream_type()
                if stream not in wanted or stream in chosen or not profile.is_video_stream_profile():
                    continue
                video = profile.as_video_stream_profile()
                form, size = wanted[stream]
                if self.bag is None and (profile.format(), (video.width(), video.height()), profile.fps()) != (form, size, 30):
                    continue
                chosen[stream] = (sensor, video)
        for stream, name, size in ((rs.stream.depth, "depth", self.depth_size), (rs.stream.color, "colour", self.color_size)):
            if stream not in chosen:
                asked = "" if self.bag else f" at {size[0]}x{size[1]}, 30 frames a second"
                raise InputError(f"{self.where}: no {name} stream{asked}")
        return chosen

    def open(self) -> StreamSetup:
        import pyrealsense2 as rs

        device = self._device()
        profiles = self._profiles(device)
        (depth_sensor, depth_profile), (color_sensor, color_profile) = profiles[rs.stream.depth], profiles[rs.stream.color]
        depth_scale, notes = _depth_units_m(depth_sensor)
        intrinsics = color_profile.get_intrinsics()
        if intrinsics.fx <= 0 or intrinsics.fy <= 0:
            raise InputError(f"{self.where}: the colour stream has no intrinsics")
        camera, lens_notes = camera_from_intrinsics(intrinsics, depth_scale)
        notes += lens_notes
        setup = StreamSetup(format="realsense-bag" if self.bag else "realsense-live", color_camera=camera, notes=notes)
        depth_camera, depth_notes = camera_from_intrinsics(depth_profile.get_intrinsics(), depth_scale)
        color_from_depth: np.ndarray | None = np.eye(4)
        try:
            extrinsics = depth_profile.get_extrinsics_to(color_profile)
            color_from_depth[:3, :3] = np.asarray(extrinsics.rotation, dtype=np.float64).reshape(3, 3).T  # column-major
            color_from_depth[:3, 3] = extrinsics.translation
        except RuntimeError:  # "Requested extrinsics are not available!"
            color_from_depth = None
        missing = "no depth-to-colour extrinsics in the recording"
        if depth_camera == camera and (color_from_depth is None or np.allclose(color_from_depth, np.eye(4), atol=1e-9)):
            if color_from_depth is None:  # one camera (D405's colour)
                setup.notes.append(f"{missing}; the depth has colour's camera: taken as registered")
        else:
            # None: the importer takes --camera's color_from_depth, else the depth as seen from colour's point.
            setup.depth_camera, setup.color_from_depth = depth_camera, color_from_depth
            setup.notes += depth_notes
            if color_from_depth is None:
                setup.notes.append(
                    f"{missing}: depth reprojected as if the two cameras sat at one point, unless --camera's "
                    "color_from_depth gives its pose"
                )
        if self.tolerance_s is None:  # half a frame interval
            self.tolerance_s = min(0.5 / max(color_profile.fps(), 1), MAX_TOLERANCE_S)
        self._start(profiles)
        return setup

    def _start(self, profiles: dict[object, tuple[object, object]]) -> None:
        """Open the sensors and start their callbacks; a playback paused until both run (else
        the first started can take frames the other misses)."""
        by_sensor: dict[int, tuple[object, list]] = {}
        for sensor, profile in profiles.values():
            by_sensor.setdefault(id(sensor), (sensor, []))[1].append(profile)
        if self._playback is not None:
            self._playback.pause()
        try:
            for sensor, sensor_profiles in by_sensor.values():
                sensor.open(sensor_profiles)
                self._sensors.append(sensor)
                sensor.start(self._deliver)
        except RuntimeError as exc:
            self.close()
            raise InputError(f"{self.where}: cannot start the streams: {exc}") from None
        if self._playback is not None:
            self._playback.resume()

    def _deliver(self, frame: object) -> None:
        """A sensor's callback (the SDK's thread): queue the frame with its arrival time, waiting
        while the queue is full (a playback then waits too; a live camera drops frames, counted
        by their numbers)."""
        frame.keep()  # held beyond the callback, outside the sensor's pool of 16
        # When it reached the host, one clock for both streams: a playback's position (the
        # recorder filed each frame as it arrived), or now.
        arrival_s = self._playback.get_position() / 1e9 if self._playback is not None else time.monotonic()
        while not self._closing:
            try:
                self._frames.put((frame, arrival_s), timeout=0.1)
                return
            except queue.Full:
                continue

    def _next_frame(self) -> tuple[object, float] | None:
        """The next frame of either stream and its arrival time; None at the end of a recording."""
        waited_s = 0.0
        while True:
            try:
                return self._frames.get(timeout=0.1)
            except queue.Empty:
                if self._playback_ended() and self._frames.empty():
                    return None
                waited_s += 0.1
                limit_s = _WAIT_S if self.bag is None else _PLAYBACK_STALL_S
                if waited_s > limit_s:
                    raise InputError(f"{self.where}: no frames for {limit_s:.0f} s") from None

    def _playback_ended(self) -> bool:
        """A playback's status is "stopped" before it starts and once it ends; `_start`'s resume
        returns once it plays."""
        import pyrealsense2 as rs

        return self._playback is not None and self._playback.current_status() == rs.playback_status.stopped

    def _images(self, color: object, depth: object) -> tuple[np.ndarray, np.ndarray]:
        """Colour as RGB and depth in its units, registered later (setup.depth_camera)."""
        return _rgb(color), np.asanyarray(depth.get_data()).copy()

    def close(self) -> None:
        self._closing = True
        for sensor in self._sensors:
            try:
                sensor.stop()
            except RuntimeError:  # opened, never started
                pass
            sensor.close()
        self._sensors = []
        while not self._frames.empty():
            self._frames.get_nowait()

    def _associated(self, seen: dict[str, set[tuple[int, float]]]) -> Iterator[tuple[object, object, float]]:
        """(colour frame, depth frame, depth minus colour seconds) in time order, each frame once
        (a frame delivered twice has the same number and time; a writer may leave every number 0)."""
        import pyrealsense2 as rs

        association = StreamAssociation(self.tolerance_s)
        waiting: list[tuple[str, object, float]] = []  # until both streams' clocks are known
        domains: dict[str, object] = {}
        by_arrival = None
        ended = False
        while not ended:
            item = self._next_frame()
            ended = item is None
            if item is not None:
                frame, arrival_s = item
                kind = "color" if frame.get_profile().stream_type() == rs.stream.color else "depth"
                key = (frame.get_frame_number(), frame.get_timestamp())
                if key in seen[kind]:
                    continue
                seen[kind].add(key)
                domains.setdefault(kind, frame.get_frame_timestamp_domain())
                waiting.append((kind, frame, arrival_s))
                if by_arrival is None and len(domains) < 2 and len(waiting) < _CLOCK_WAIT_FRAMES:
                    continue
            if by_arrival is None:
                by_arrival = self._clocks_differ(domains)
            for kind, frame, arrival_s in waiting:
                yield from association.add(kind, arrival_s if by_arrival else frame.get_timestamp() / 1000, frame)
            waiting = []
        yield from association.finish()

    def _clocks_differ(self, domains: dict[str, object]) -> bool:
        """Whether the two streams stamp their frames by different clocks (the camera's own and
        the host's, as a sensor without frame metadata does): said, and then paired by arrival."""
        if len(set(domains.values())) < 2:
            return False
        note = (
            f"colour stamped by {domains['color'].name}, depth by {domains['depth'].name}: "
            "paired by the times the frames arrived"
        )
        if note not in self.setup.notes:
            self.setup.notes.append(note)
        return True

    def pairs(self, *, start_s: float = 0.0, end_s: float | None = None) -> Iterator[RgbdPair]:
        counts = self.counts
        origin = None
        seen: dict[str, set[tuple[int, float]]] = {"color": set(), "depth": set()}
        kept = 0
        try:
            for color, depth, offset_s in self._associated(seen):
                counts.pairs += 1
                counts.max_offset_s = max(counts.max_offset_s, abs(offset_s))
                origin = color.get_timestamp() if origin is None else origin
                time_s = (color.get_timestamp() - origin) / 1000
                if time_s < start_s or (end_s is not None and time_s > end_s):
                    continue
                kept += 1
                if (kept - 1) % self.every:
                    continue
                color_image, depth_image = self._images(color, depth)
                yield RgbdPair(time_s=time_s, color=color_image, depth=depth_image, depth_offset_s=offset_s)
        finally:
            for kind in ("color", "depth"):
                numbers = {number for number, _ in seen[kind]}
                setattr(counts, f"{kind}_frames", len(seen[kind]))
                # Frames the camera counted but never delivered are dropped too (when it numbered them).
                missing = max(numbers) - min(numbers) + 1 - len(numbers) if len(numbers) == len(seen[kind]) > 0 else 0
                setattr(counts, f"dropped_{kind}", len(seen[kind]) - counts.pairs + missing)
