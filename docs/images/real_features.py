"""Draw `real_features.png`: the catalogue's examples of how real cabinets and appliances are
built (README, "Furniture as it is built"): a face-frame unit with its doors open (one hung
on the middle stile) and its drawer out (the second board, the box above and beside the
front's middle), and a microwave whose thick door has its inner part in the cavity's recess
(a rectangular button and a knob in pockets, the plate off centre). Solved hinge lines in red.

    .venv/bin/python docs/images/real_features.py
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
    ("base_unit_face_frame_stile", {"door_0_hinge": math.radians(95), "door_1_hinge": math.radians(80), "drawer_0_slide": 0.3}, (3.0, -1.6, 2.6)),
    ("microwave_thick_door", {"door_0_hinge": math.radians(100)}, (3.0, -1.2, 1.2)),
    ("microwave_thick_door", {"door_0_hinge": math.radians(60)}, (3.0, -3.0, 0.6)),
]


def main() -> None:
    options = PictureOptions(panel_height_px=420, shaded=True)
    size = (460, 420)
    panels = []
    for name, joints, towards in VIEWS:
        model = build_model(REPO / "examples" / "catalogue" / f"{name}.yaml")
        camera, focal = three_quarter_camera(model, size, towards=np.array(towards))
        picture = render_model(model, camera, focal, size, options, joint_positions=joints)
        panel = cv2.cvtColor(picture, cv2.COLOR_RGB2BGR)
        cv2.putText(panel, name, (10, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (0, 0, 0), 1, cv2.LINE_AA)
        panels += [panel, np.full((size[1], 6, 3), 255, np.uint8)]
    cv2.imwrite(str(Path(__file__).with_name("real_features.png")), np.hstack(panels[:-1]))


if __name__ == "__main__":
    main()
