"""Make the example "photos" of examples/textured/ (synthetic, so the corners are known exactly).

Each photo is a flat design (a door's painted front, a cup's label, a food packet's print)
put where a pinhole camera (focal length `FOCAL_PX`, principal point at the centre) sees
it, over a noisy background, and saved as a small JPEG. The corners printed here are the
ones the example specs give. Run:

    .venv/bin/python examples/textured/make_photos.py
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from homemodel.core.transforms import transform_points, world_from_camera_looking_at
from homemodel.geometry.camera import Camera

HERE = Path(__file__).resolve().parent / "photos"
RNG = np.random.default_rng(7)


def background(width: int, height: int, top_bgr: tuple, bottom_bgr: tuple) -> np.ndarray:
    """A wall-like vertical gradient with sensor noise."""
    t = np.linspace(0, 1, height)[:, None, None]
    image = (1 - t) * np.array(top_bgr) + t * np.array(bottom_bgr)
    image = np.broadcast_to(image, (height, width, 3)) + RNG.normal(0, 4, (height, width, 3))
    return np.clip(image, 0, 255).astype(np.uint8)


def paste(photo: np.ndarray, design: np.ndarray, corners: np.ndarray) -> None:
    """Warp `design` so its corners land on `corners` (TL, TR, BR, BL) of `photo`."""
    h, w = design.shape[:2]
    source = np.float32([[-0.5, -0.5], [w - 0.5, -0.5], [w - 0.5, h - 0.5], [-0.5, h - 0.5]])
    homography = cv2.getPerspectiveTransform(source, np.float32(corners))
    size = (photo.shape[1], photo.shape[0])
    warped = cv2.warpPerspective(design, homography, size, flags=cv2.INTER_AREA)
    mask = cv2.warpPerspective(np.full((h, w), 255, np.uint8), homography, size, flags=cv2.INTER_AREA)[..., None] / 255
    photo[:] = np.clip(mask * warped + (1 - mask) * photo, 0, 255).astype(np.uint8)


def door_design() -> np.ndarray:
    """A 0.396 x 0.636 m door front at 1 px/mm: oak with a grain, a routed panel, a knot."""
    h, w = 636, 396
    grain = cv2.resize(RNG.normal(0, 1, (h // 40, w)), (w, h), interpolation=cv2.INTER_CUBIC)
    base = np.array([60, 105, 160], dtype=np.float64)  # BGR oak
    design = base + grain[..., None] * np.array([8, 12, 16])
    cv2.rectangle(design, (50, 50), (w - 51, h - 51), (35, 70, 115), 10)
    cv2.rectangle(design, (70, 70), (w - 71, h - 71), (80, 130, 185), 4)
    cv2.ellipse(design, (150, 420), (18, 9), 20, 0, 360, (30, 60, 100), -1)
    cv2.putText(design, "HOME", (95, 320), cv2.FONT_HERSHEY_DUPLEX, 2.2, (240, 240, 240), 5, cv2.LINE_AA)
    return np.clip(design, 0, 255).astype(np.uint8)


def cup_label() -> np.ndarray:
    """A label round half of a 0.085 m cup (0.1335 m of arc, 0.1 m high) at 4 px/mm."""
    h, w = 400, 534
    label = np.zeros((h, w, 3), np.uint8)
    label[:] = (170, 90, 20)  # blue
    for x in range(0, w, 66):
        cv2.rectangle(label, (x, 0), (x + 14, h), (250, 250, 250), -1)
    cv2.circle(label, (w // 2, h // 2), 95, (40, 40, 210), -1)
    cv2.putText(label, "TEA", (w // 2 - 78, h // 2 + 26), cv2.FONT_HERSHEY_DUPLEX, 2.4, (255, 255, 255), 6, cv2.LINE_AA)
    return label


def cup_photo() -> tuple[np.ndarray, np.ndarray]:
    """A side view of the cup (far camera, so orthographic): the half facing the camera shows
    the label unrolled by sin(angle); the silhouette is the band's left and right edges."""
    photo = background(480, 360, (200, 205, 210), (120, 125, 130))
    label = cup_label()
    radius_px, height_px, x0, y0 = 120, 282, 120, 40  # 0.0425 m -> 120 px, 0.1 m -> 282 px
    columns = np.arange(2 * radius_px)
    sine = (columns + 0.5) / radius_px - 1  # -1 .. 1 across the silhouette
    angle = np.arcsin(sine)  # -90 .. 90 deg from the view direction
    source_x = ((angle / np.pi + 0.5) * label.shape[1]).astype(np.float32)
    source_y = np.linspace(0, label.shape[0] - 1, height_px).astype(np.float32)
    map_x, map_y = np.meshgrid(source_x, source_y)
    side = cv2.remap(label, map_x, map_y, cv2.INTER_LINEAR)
    shade = (0.55 + 0.45 * np.cos(angle))[None, :, None]  # light from the camera
    photo[y0 : y0 + height_px, x0 : x0 + 2 * radius_px] = (side * shade).astype(np.uint8)
    corners = np.array([[x0 - 0.5, y0 - 0.5], [x0 + 2 * radius_px - 0.5, y0 - 0.5]])
    corners = np.vstack([corners, corners[::-1] + [0, height_px]])
    return photo, corners


def packet_designs() -> dict[str, np.ndarray]:
    """A 0.19 x 0.07 x 0.28 m cereal packet's front, right side and top at 2 px/mm."""
    front = np.zeros((560, 380, 3), np.uint8)
    front[:] = (30, 160, 235)  # orange-yellow
    cv2.rectangle(front, (20, 20), (359, 539), (20, 40, 200), 8)
    cv2.putText(front, "OATS", (70, 160), cv2.FONT_HERSHEY_TRIPLEX, 2.6, (20, 40, 200), 7, cv2.LINE_AA)
    cv2.circle(front, (190, 360), 110, (40, 200, 255), -1)
    cv2.circle(front, (190, 360), 110, (20, 40, 200), 6)
    side = np.zeros((560, 140, 3), np.uint8)
    side[:] = (20, 40, 200)
    for y in range(60, 500, 48):
        cv2.line(side, (20, y), (120, y), (240, 240, 240), 6)
    top = np.zeros((140, 380, 3), np.uint8)
    top[:] = (40, 200, 255)
    cv2.putText(top, "OPEN", (110, 90), cv2.FONT_HERSHEY_DUPLEX, 1.6, (20, 40, 200), 4, cv2.LINE_AA)
    return {"front": front, "right": side, "top": top}


FOCAL_PX = 700.0


def project(points_m: np.ndarray, eye_m: tuple, target_m: tuple, size_px: tuple[int, int]) -> np.ndarray:
    """Pixels of model-frame points (z up) seen by a level pinhole camera at `eye_m` looking at `target_m`."""
    width, height = size_px
    camera = Camera(width=width, height=height, fx=FOCAL_PX, fy=FOCAL_PX, cx=(width - 1) / 2, cy=(height - 1) / 2)
    camera_from_model = np.linalg.inv(world_from_camera_looking_at(eye_m, target_m))
    return np.round(camera.project(transform_points(camera_from_model, points_m)), 1)


# The left door of the cupboard (front face at x = 0.245, y -0.398..-0.002, z 0.102..0.738),
# photographed from in front, left of it and a little above its middle.
DOOR_FACE_M = np.array([[0.245, -0.398, 0.738], [0.245, -0.002, 0.738], [0.245, -0.002, 0.102], [0.245, -0.398, 0.102]])
DOOR_VIEW = {"eye_m": (1.0, -0.6, 0.55), "target_m": (0.245, -0.2, 0.42), "size_px": (520, 640)}

# A 0.07 x 0.19 x 0.28 m (x, y, z) packet standing on the floor, seen from the front right, above.
_D, _W, _H = 0.07, 0.19, 0.28
PACKET_FACES_M = {
    "front": np.array([[_D / 2, -_W / 2, _H], [_D / 2, _W / 2, _H], [_D / 2, _W / 2, 0], [_D / 2, -_W / 2, 0]]),
    "right": np.array([[_D / 2, _W / 2, _H], [-_D / 2, _W / 2, _H], [-_D / 2, _W / 2, 0], [_D / 2, _W / 2, 0]]),
    "top": np.array([[-_D / 2, -_W / 2, _H], [-_D / 2, _W / 2, _H], [_D / 2, _W / 2, _H], [_D / 2, -_W / 2, _H]]),
}
PACKET_VIEW = {"eye_m": (0.42, 0.34, 0.42), "target_m": (0.0, 0.0, 0.13), "size_px": (600, 560)}


def main() -> None:
    HERE.mkdir(exist_ok=True)
    door = background(*DOOR_VIEW["size_px"], (215, 220, 225), (150, 155, 160))
    door_corners = project(DOOR_FACE_M, **DOOR_VIEW)
    paste(door, door_design(), door_corners)
    cv2.imwrite(str(HERE / "cupboard_door.jpg"), door, [cv2.IMWRITE_JPEG_QUALITY, 85])
    print("cupboard_door.jpg corners", door_corners.tolist())

    cup, cup_corners = cup_photo()
    cv2.imwrite(str(HERE / "cup_side.jpg"), cup, [cv2.IMWRITE_JPEG_QUALITY, 85])
    print("cup_side.jpg corners", cup_corners.tolist())

    packet = background(*PACKET_VIEW["size_px"], (190, 200, 205), (110, 115, 120))
    for face, design in packet_designs().items():
        corners = project(PACKET_FACES_M[face], **PACKET_VIEW)
        paste(packet, design, corners)
        print(f"packet.jpg {face} corners", corners.tolist())
    cv2.imwrite(str(HERE / "packet.jpg"), packet, [cv2.IMWRITE_JPEG_QUALITY, 85])


if __name__ == "__main__":
    main()
