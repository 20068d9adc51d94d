"""Draw `real_features.png`: the catalogue's examples of how real cabinets and appliances are
built (README, "Furniture as it is built"): a face-frame unit with its doors open (one hung
on the middle stile) and its drawer out (the second board, the box above and beside the
front's middle), and a microwave whose thick door has its inner part in the cavity's recess
(a rectangular button and a knob in pockets, the plate off centre); below, a unit whose
door and drawer front cover its face frame's overhang (the drawer's second board lower than
its front) and an oven with its knobs and button in pockets. Solved hinge lines in red.

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
ROWS = [
    [
        ("base_unit_face_frame_stile", {"door_0_hinge": math.radians(95), "door_1_hinge": math.radians(80), "drawer_0_slide": 0.3}, (3.0, -1.6, 2.6)),
        ("microwave_thick_door", {"door_0_hinge": math.radians(100)}, (3.0, -1.2, 1.2)),
        ("microwave_thick_door", {"door_0_hinge": math.radians(60)}, (3.0, -3.0, 0.6)),
    ],
    [  # fronts over the frame's overhang, a second board lower than its front; knobs and a button in pockets
        ("base_unit_frame_overlay", {"door_0_hinge": math.radians(100), "drawer_0_slide": 0.35}, (3.0, -1.8, 2.2)),
        ("base_unit_frame_overlay", {}, (3.0, -0.9, 0.9)),
        ("oven_pocketed_controls", {"door_0_hinge": math.radians(80), "button_0_press": 0.006}, (3.0, -1.4, 1.6)),
    ],
]


def main() -> None:
    options = PictureOptions(panel_height_px=420, shaded=True)
    size = (460, 420)
    rows = []
    for views in ROWS:
        panels = []
        for name, joints, towards in views:
            model = build_model(REPO / "examples" / "catalogue" / f"{name}.yaml")
            camera, focal = three_quarter_camera(model, size, towards=np.array(towards))
            picture = render_model(model, camera, focal, size, options, joint_positions=joints)
            panel = cv2.cvtColor(picture, cv2.COLOR_RGB2BGR)
            cv2.putText(panel, name, (10, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (0, 0, 0), 1, cv2.LINE_AA)
            panels += [panel, np.full((size[1], 6, 3), 255, np.uint8)]
        rows += [np.hstack(panels[:-1]), np.full((6, len(views) * (size[0] + 6) - 6, 3), 255, np.uint8)]
    cv2.imwrite(str(Path(__file__).with_name("real_features.png")), np.vstack(rows[:-1]))


if __name__ == "__main__":
    main()
