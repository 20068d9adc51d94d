"""Draw `simulate_view.png`: a simulated observation of the demo kitchen, its colour image
beside its depth image (near red, far blue, no reading black), as the README's
`homemodel map simulate-view` command writes them (README, "Keep the map up to date from
the robot's camera").

    make demo && .venv/bin/python docs/images/simulate_view.py
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np

REPO = Path(__file__).resolve().parents[2]
COMMAND = [
    "map", "simulate-view", "build/kitchen/map.xml", "--camera", "examples/cameras/kinect_v1.yaml",
    "--look-at", "fridge_1", "--distance-m", "2.3", "--height-m", "1.5", "--bearing-deg", "-30",
    "--joint", "fridge_1/door_0_hinge=0.9", "--joint", "cupboard_1/drawer_0_slide=0.2",
    "--move", "red_cup=cupboard_1:0.0,0.1,0.5", "--occlude", "fridge_1=0.3",
]  # fmt: skip
NEAR_M, FAR_M = 0.5, 4.0


def depth_picture(depth_m: np.ndarray) -> np.ndarray:
    """Depth in colour: near red, far blue, no reading black."""
    scaled = np.clip((depth_m - NEAR_M) / (FAR_M - NEAR_M), 0, 1)
    picture = cv2.applyColorMap((255 * (1 - scaled)).astype(np.uint8), cv2.COLORMAP_TURBO)
    picture[depth_m == 0] = 0
    return picture


def main() -> None:
    from tracking.observation_files import read_observation

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "obs"
        subprocess.run([sys.executable, "-m", "homemodel", *COMMAND, "--out", str(out)], cwd=REPO, check=True)
        observation = read_observation(out)
        colour = cv2.imread(str(out / "color.png"))
    both = np.hstack([colour, depth_picture(observation.depth_m)])
    picture = cv2.resize(both, None, fx=0.75, fy=0.75, interpolation=cv2.INTER_AREA)
    cv2.imwrite(str(REPO / "docs" / "images" / "simulate_view.png"), picture)

if __name__ == "__main__":
    main()
