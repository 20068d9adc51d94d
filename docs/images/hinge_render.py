"""Draw `hinge_render.png`: catalogue units with their doors open and the solved hinge lines
in red, as the comparison render draws them (README, "Measuring a door's hinge line").

    .venv/bin/python docs/images/hinge_render.py
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np

from modeller import build_model
from modeller.comparison_picture import PictureOptions, render_model, three_quarter_camera

REPO = Path(__file__).resolve().parents[2]
VIEWS = [
    ("cupboard_face_frame", {"door_0_hinge": math.radians(90)}),
    ("wall_cabinet_handleless", {"door_0_hinge": math.radians(90), "door_1_hinge": math.radians(60)}),
    ("base_unit_inset", {"door_0_hinge": math.radians(110), "door_1_hinge": math.radians(45)}),
]


def main() -> None:
    options = PictureOptions(panel_height_px=420, shaded=True)
    size = (420, 420)
    panels = []
    for name, joints in VIEWS:
        model = build_model(REPO / "examples" / "catalogue" / f"{name}.yaml")
        camera, focal = three_quarter_camera(model, size, towards=np.array([3.0, -1.6, 2.2]))
        picture = render_model(model, camera, focal, size, options, joint_positions=joints)
        panel = cv2.cvtColor(picture, cv2.COLOR_RGB2BGR)
        cv2.putText(panel, name, (10, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (0, 0, 0), 1, cv2.LINE_AA)
        panels += [panel, np.full((size[1], 6, 3), 255, np.uint8)]
    cv2.imwrite(str(Path(__file__).with_name("hinge_render.png")), np.hstack(panels[:-1]))


if __name__ == "__main__":
    main()
