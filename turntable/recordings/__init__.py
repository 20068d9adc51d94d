"""Real RGB-D cameras' recordings and live streams as turntable capture folders.

- `source`: the frame-source interface (colour and depth paired in time) that every reader
  and the live camera implement; `associate`: pairing two timed streams; `register`: depth
  reprojected into colour's pixels;
- one reader per format: `realsense` (pyrealsense2: a .bag played back, or a live camera),
  `rosbag` (ROS 1 and ROS 2 bags, with rosbags), `tum`, `open3d_folder`; `detect` tells them apart;
- `importer`: `import_recording`, a recording to a capture folder and its `recording.json`.
"""

from turntable.recordings.detect import FORMATS, detect_format
from turntable.recordings.importer import ImportOptions, ImportReport, import_recording, open_recording
from turntable.recordings.source import FrameSource, RgbdPair, StreamSetup

__all__ = [
    "FORMATS",
    "FrameSource",
    "ImportOptions",
    "ImportReport",
    "RgbdPair",
    "StreamSetup",
    "detect_format",
    "import_recording",
    "open_recording",
]
