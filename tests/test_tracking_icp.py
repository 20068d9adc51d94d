"""The pose fit's ICP (`tracking.fit_pose.icp_correction`) on surfaces that leave motions
free, and its determinism; the part visibility past the image's edges (`tracking.scene`)."""

from __future__ import annotations

import numpy as np
import trimesh

from homemodel.geometry.camera import Camera
from tracking.fit_pose import icp_correction
from tracking.scene import Part, Renderer


def _front(rng: np.random.Generator, count: int) -> tuple[np.ndarray, np.ndarray]:
    """Points on a 0.6 x 1.6 m plane facing +x (a fridge's door seen from the front alone)."""
    points = np.column_stack([np.zeros(count), rng.uniform(-0.3, 0.3, count), rng.uniform(0.1, 1.7, count)])
    return points, np.tile([1.0, 0.0, 0.0], (count, 1))


def test_a_front_alone_gives_its_shift_and_turn() -> None:
    # The front leaves the slide, the height and the roll free: only the shift along its
    # normal and the turn are pinned, and those must come out.
    rng = np.random.default_rng(0)
    target, normals = _front(rng, 3000)
    yaw = np.radians(2.0)
    true = np.eye(4)  # target_from_source: the observed front 20 mm behind and turned 2 degrees
    true[:2, :2] = [[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]]
    true[0, 3] = 0.02
    source_points, _ = _front(rng, 1500)
    exact = (source_points - true[:3, 3]) @ true[:3, :3]  # inverse of `true`
    noisy = exact + np.column_stack([rng.normal(0, 0.002, len(exact)), np.zeros((len(exact), 2))])
    correction = icp_correction(noisy, target, normals, gate_m=0.05, kernel_m=0.01, planar=True)
    assert correction is not None
    moved = exact @ correction[:3, :3].T + correction[:3, 3]
    # Along the normal (what the front pins) every point lands on the plane within 2 mm.
    assert np.abs(moved[:, 0]).max() < 0.002
    assert abs(np.degrees(np.arctan2(correction[1, 0], correction[0, 0])) - 2.0) < 0.3


def test_the_same_points_give_the_same_correction() -> None:
    rng = np.random.default_rng(1)
    target = rng.normal(size=(3000, 3))
    normals = rng.normal(size=(3000, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    source = target[:1500] + rng.normal(scale=0.01, size=(1500, 3)) + 0.02
    results = {icp_correction(source, target, normals, gate_m=0.1, kernel_m=0.02, planar=False).tobytes()
               for _ in range(20)}
    # (With two threads Open3D gave 12 different transforms in 40 runs: its sums' order.)
    assert len(results) == 1


def _one_box_looked_at_along_x(extents: tuple[float, float, float]) -> tuple[Renderer, Camera, np.ndarray]:
    """A renderer of one box part, a 160 x 120 camera at 100 px/m and its pose at the origin
    looking along +x (the image's left at +y)."""
    box = trimesh.creation.box(extents=extents)
    faces = np.asarray(box.faces, dtype=np.int64)
    part = Part(object_id="a", link="door", joint=None, vertices_link=np.asarray(box.vertices, dtype=np.float64),
                faces=faces, face_rgb=np.full((len(faces), 3), 0.5))
    camera = Camera(width=160, height=120, fx=100.0, fy=100.0, cx=79.5, cy=59.5)
    map_from_camera = np.eye(4)
    map_from_camera[:3, :3] = [[0, 0, 1], [-1, 0, 0], [0, -1, 0]]
    return Renderer([part]), camera, map_from_camera


def test_a_part_the_image_edge_cuts_counts_its_pixels_outside() -> None:
    renderer, camera, map_from_camera = _one_box_looked_at_along_x((0.02, 0.4, 0.4))
    map_from_part = np.eye(4)
    map_from_part[:3, 3] = (1.0, 0.0, 0.0)
    whole = renderer.pixels_alone(0, map_from_part, camera, map_from_camera, whole=True)
    assert abs(whole - 40 * 40) < 2 * 40  # 0.4 m at 1 m and 100 px/m: 40 x 40 pixels
    map_from_part[1, 3] = 0.79  # the image's edge 0.795 m across: about half of it is inside
    inside = renderer.pixels_alone(0, map_from_part, camera, map_from_camera)
    cut = renderer.pixels_alone(0, map_from_part, camera, map_from_camera, whole=True)
    assert abs(cut - whole) <= 2 * 40 and 0.4 < inside / cut < 0.6
    assert renderer.pixels_whole([map_from_part], camera, map_from_camera, [0]) == cut


def test_a_part_reaching_behind_the_camera_counts_its_image_past_the_edge() -> None:
    # A door swung open towards the camera, past its side: only a sliver at the image's left
    # edge is in view. Its box crosses the near plane, so its image has no finite bounds;
    # counted on the image grown by its size each side, most of it is outside (the old
    # count took the image itself and called the sliver the whole door).
    renderer, camera, map_from_camera = _one_box_looked_at_along_x((1.0, 0.02, 0.4))
    map_from_part = np.eye(4)
    map_from_part[:3, 3] = (0.2, 0.35, 0.0)  # from 0.3 m behind the camera to 0.7 m in front, 0.35 m to its left
    inside = renderer.pixels_alone(0, map_from_part, camera, map_from_camera)
    whole = renderer.pixels_alone(0, map_from_part, camera, map_from_camera, whole=True)
    assert inside > 0 and inside / whole < 0.5
    assert renderer.pixels_whole([map_from_part], camera, map_from_camera, [0]) == whole
