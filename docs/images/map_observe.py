"""Draw `map_observe.png`: a simulated observation of the demo kitchen (the fridge door open
0.9 rad, a box hiding 30 % of the fridge, the red cup moved onto the cupboard), its depth
image with the models `homemodel map observe` fitted drawn over it (each part's outline,
small objects found in yellow), and the fridge door's estimated angle beside its truth.

    make demo && .venv/bin/python docs/images/map_observe.py
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np

from simulate_view import COMMAND, REPO, depth_picture  # the same view, beside this script


def _homemodel(*args: str) -> None:
    subprocess.run([sys.executable, "-m", "homemodel", *args], cwd=REPO, check=True)


def main() -> None:
    from tracking.observation_files import read_observation
    from tracking.scene import HomeScene, Renderer

    with tempfile.TemporaryDirectory() as tmp:
        obs, new_map, report_path = Path(tmp) / "obs", Path(tmp) / "new_map.xml", Path(tmp) / "report.json"
        _homemodel(*COMMAND, "--out", str(obs))
        _homemodel("map", "observe", "build/kitchen/map.xml", str(obs), "--out", str(new_map), "--report", str(report_path))
        observation = read_observation(obs)
        report = json.loads(report_path.read_text())
        scene = HomeScene.load(new_map, structure=False)
        rendering = Renderer(scene.parts).render(scene.pose(), observation.camera, observation.map_from_camera)
    picture = (0.6 * depth_picture(observation.depth_m)).astype(np.uint8)  # dimmed, so the outlines stand out
    index = rendering.part_index
    edges = np.zeros(index.shape, dtype=bool)
    edges[:, 1:] |= index[:, 1:] != index[:, :-1]
    edges[1:, :] |= index[1:, :] != index[:-1, :]
    edges = cv2.dilate(edges.astype(np.uint8), np.ones((2, 2), np.uint8)).astype(bool)
    found = {s["id"] for o in report["objects"] for s in o["small_objects"] if s["status"] == "found"}
    small = np.isin(index, [i for i, p in enumerate(scene.parts) if p.object_id in found])
    picture[edges] = (255, 255, 255)
    picture[edges & cv2.dilate(small.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)] = (0, 230, 255)
    fridge = next(o for o in report["objects"] if o["id"] == "fridge_1")
    door = next(j for j in fridge["joints"] if j["name"] == "door_0_hinge")
    truth_deg = np.degrees(observation.truth["joints"]["fridge_1"]["door_0_hinge"])
    lines = [
        f"fridge door: estimated {np.degrees(door['position']):.1f} deg, truth {truth_deg:.1f} deg",
        f"({door['visible_fraction']:.0%} of it visible, a box hides 30 % of the fridge)",
        "red cup: found on the cupboard, re-parented" if "red_cup" in found else "red cup: not found",
    ]
    for row, text in enumerate(lines):
        y = 24 + 24 * row
        cv2.putText(picture, text, (12, y), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (0, 0, 0), 4, cv2.LINE_AA)
        cv2.putText(picture, text, (12, y), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (255, 255, 255), 1, cv2.LINE_AA)
    cv2.imwrite(str(REPO / "docs" / "images" / "map_observe.png"), picture)


if __name__ == "__main__":
    main()
