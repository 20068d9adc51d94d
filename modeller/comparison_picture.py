"""Pictures of a textured model beside the photos it was textured from (pyvista, off-screen).

For each photo placement the model is rendered as the photo's camera saw it: the camera
is recovered from the face's four corners, known on the model (`PhotoPlacement`) and in
the photo, by PnP (OpenCV SQPnP) with the principal point at the image centre and
the focal length from the face's homography (Zhang's orthogonality constraint), or a
normal lens (`fallback_fov_deg`) when the photo shows too little perspective to tell.
A 3/4 view from the front right completes the picture: photo | same view | 3/4 view.
Every door's hinge line (a revolute joint's axis, as the spec's hinge fields solved it) is
drawn as a red line along the door's height, so a wrong axis shows against the photo.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from articulation.model import Model
from homemodel.core.atomic import write_bytes_atomic
from homemodel.core.c_stdio_capture import captured_c_output
from homemodel.core.checks import require_between
from homemodel.core.errors import InputError
from homemodel.core.srgb import srgb_encode
from homemodel.core.transforms import world_from_camera_looking_at
from modeller.blender_textures import PhotoPlacement
from modeller.photo_texture import read_photo

# Focal lengths outside these multiples of the photo's longer side are taken as noise.
_FOCAL_RANGE = (0.3, 6.0)


@dataclass(kw_only=True)
class PictureOptions:
    panel_height_px: int = 360
    fallback_fov_deg: float = 50.0  # of the photo's longer side
    background_rgb: tuple[int, int, int] = (255, 255, 255)
    three_quarter_view: bool = True
    hinge_lines: bool = True
    shaded: bool = False  # lit from a light kit (faces told apart), not evenly as the photos' faces look
    hinge_line_rgb: tuple[int, int, int] = (220, 20, 20)

    def check(self) -> None:
        require_between("panel_height_px", self.panel_height_px, 64, 2048)
        require_between("fallback_fov_deg", self.fallback_fov_deg, 1.0, 170.0)
        for name in ("background_rgb", "hinge_line_rgb"):
            rgb = getattr(self, name)
            if len(rgb) != 3 or not all(0 <= c <= 255 for c in rgb):
                raise InputError(f"{name}: three values in [0, 255], got {rgb!r}")


def focal_from_corners(
    image_size: tuple[int, int], model_corners_m: np.ndarray, corners_px: np.ndarray
) -> float | None:
    """The focal length in pixels that makes the face's homography a rotation, or None.

    With K = diag(f, f, 1) after moving the principal point to the origin, the first two
    columns (a1, a2) of K^-1 H are orthogonal and equally long; each gives f^2.
    """
    width, height = image_size
    plane = _plane_coordinates(model_corners_m)
    homography = cv2.getPerspectiveTransform(plane.astype(np.float32), corners_px.astype(np.float32))
    a = np.array([[1, 0, -(width - 1) / 2], [0, 1, -(height - 1) / 2], [0, 0, 1]]) @ homography
    estimates = []
    orthogonal = a[2, 0] * a[2, 1]
    if abs(orthogonal) > 1e-12:
        estimates.append((abs(orthogonal), -(a[0, 0] * a[0, 1] + a[1, 0] * a[1, 1]) / orthogonal))
    equal = a[2, 0] ** 2 - a[2, 1] ** 2
    if abs(equal) > 1e-12:
        estimates.append((abs(equal), (a[0, 1] ** 2 + a[1, 1] ** 2 - a[0, 0] ** 2 - a[1, 0] ** 2) / equal))
    longer = max(width, height)
    usable = [
        (weight, np.sqrt(f2))
        for weight, f2 in estimates
        if f2 > 0 and _FOCAL_RANGE[0] * longer < np.sqrt(f2) < _FOCAL_RANGE[1] * longer
    ]
    return max(usable)[1] if usable else None


def _plane_coordinates(points_m: np.ndarray) -> np.ndarray:
    """Coplanar 3D points in an orthonormal 2D frame of their plane (origin at the first)."""
    x = points_m[1] - points_m[0]
    x /= np.linalg.norm(x)
    y = points_m[3] - points_m[0]
    y -= np.dot(y, x) * x
    y /= np.linalg.norm(y)
    relative = points_m - points_m[0]
    return np.column_stack([relative @ x, relative @ y])


def photo_camera(
    placement: PhotoPlacement, image_size: tuple[int, int], options: PictureOptions
) -> tuple[np.ndarray, float]:
    """(`camera_from_model` in OpenCV axes: x right, y down, z forward; focal length px)."""
    width, height = image_size
    focal = focal_from_corners(image_size, placement.model_corners_m, placement.corners_px)
    if focal is None:
        focal = max(width, height) / 2 / np.tan(np.radians(options.fallback_fov_deg) / 2)
    intrinsics = np.array([[focal, 0, (width - 1) / 2], [0, focal, (height - 1) / 2], [0, 0, 1]])
    # SQPnP finds the global optimum; OpenCV's IPPE went wrong here for planes far from the origin.
    ok, rvec, tvec = cv2.solvePnP(
        placement.model_corners_m.astype(np.float64),
        placement.corners_px.astype(np.float64),
        intrinsics,
        None,
        flags=cv2.SOLVEPNP_SQPNP,
    )
    camera_from_model = np.eye(4)
    camera_from_model[:3, :3] = cv2.Rodrigues(rvec)[0]
    camera_from_model[:3, 3] = tvec.ravel()
    depths = placement.model_corners_m @ camera_from_model[2, :3] + camera_from_model[2, 3]
    if not ok or not (depths > 0).all():
        raise InputError(f"{placement.photo}: cannot place the camera from the face's corners")
    return camera_from_model, focal


def three_quarter_camera(
    model: Model, image_size: tuple[int, int], towards: np.ndarray | None = None, fov_deg: float = 35.0
) -> tuple[np.ndarray, float]:
    """A camera framing the whole model from 35 deg to the right of `towards` (a point the
    photo was taken from; default: in front) and 30 deg above it."""
    mesh = model.world_mesh()
    centre = mesh.bounds.mean(axis=0)
    radius = float(np.linalg.norm(mesh.extents)) / 2
    ahead = np.array([1.0, 0.0, 0.0]) if towards is None else np.asarray(towards, dtype=np.float64) - centre
    heading = np.arctan2(ahead[1], ahead[0]) + np.radians(35.0)  # seen from there, right is +angle
    elevation = np.radians(30.0)
    direction = np.array([np.cos(elevation) * np.cos(heading), np.cos(elevation) * np.sin(heading), np.sin(elevation)])
    distance = radius / np.sin(np.radians(fov_deg) / 2) * 1.05
    camera_from_model = np.linalg.inv(world_from_camera_looking_at(centre + distance * direction, centre))
    focal = image_size[1] / 2 / np.tan(np.radians(fov_deg) / 2)
    return camera_from_model, focal


def render_model(
    model: Model,
    camera_from_model: np.ndarray,
    focal_px: float,
    image_size: tuple[int, int],
    options: PictureOptions,
    joint_positions: dict[str, float] | None = None,
) -> np.ndarray:
    """An RGB picture of the model (joints at zero unless given) through a pinhole camera,
    textures and colours lit evenly, as the photos' faces look; hinge lines in red."""
    with captured_c_output():  # VTK warns on stderr about the missing X display
        picture = _render(model, camera_from_model, focal_px, image_size, options, joint_positions)
    if options.hinge_lines:
        # Drawn over the render, not in the scene: a concealed hinge's line is behind its door.
        picture = np.ascontiguousarray(picture)
        for segment in hinge_line_segments(model, joint_positions):
            points = segment @ camera_from_model[:3, :3].T + camera_from_model[:3, 3]
            if (points[:, 2] <= 0).any():
                continue
            pixels = points[:, :2] / points[:, 2:] * focal_px + (np.asarray(image_size) - 1) / 2
            ends = [tuple(int(round(c)) for c in p) for p in pixels]
            cv2.line(picture, ends[0], ends[1], options.hinge_line_rgb, 2, cv2.LINE_AA)
    return picture


def hinge_line_segments(model: Model, joint_positions: dict[str, float] | None = None) -> list[np.ndarray]:
    """(2, 3) end points, in the model frame, of each revolute joint's axis where its child
    link spans it (a door's hinge line from its bottom to its top), 3 cm longer each end."""
    world_from_links = model.world_from_links(joint_positions)
    segments = []
    for joint in model.joints:
        if joint.type != "revolute":
            continue
        child = model.link(joint.child)
        if not child.visuals:
            continue
        world_from_joint = world_from_links[joint.child]
        axis = world_from_joint[:3, :3] @ joint.axis
        origin = world_from_joint[:3, 3]
        points = np.concatenate(
            [v.mesh.copy().apply_transform(world_from_joint @ v.link_from_visual).vertices for v in child.visuals]
        )
        along = (points - origin) @ axis
        segments.append(origin + np.outer([along.min() - 0.03, along.max() + 0.03], axis))
    return segments


def _render(
    model: Model,
    camera_from_model: np.ndarray,
    focal_px: float,
    image_size: tuple[int, int],
    options: PictureOptions,
    joint_positions: dict[str, float] | None,
) -> np.ndarray:
    import pyvista as pv

    width, height = image_size
    lighting = "light kit" if options.shaded else "none"
    plotter = pv.Plotter(off_screen=True, window_size=(width, height), lighting=lighting)
    light = {"ambient": 0.35, "diffuse": 0.7} if options.shaded else {"ambient": 0.75, "diffuse": 0.0}
    try:
        plotter.set_background([c / 255 for c in options.background_rgb])
        world_from_links = model.world_from_links(joint_positions)
        textures: dict[Path, pv.Texture] = {}
        for link in model.links:
            for visual in link.visuals:
                mesh = pv.wrap(
                    visual.mesh.copy().apply_transform(world_from_links[link.name] @ visual.link_from_visual)
                )
                texture_path = visual.material.texture
                if texture_path is not None and visual.uv is not None:
                    mesh.active_texture_coordinates = visual.uv.astype(np.float32)
                    if texture_path not in textures:
                        textures[texture_path] = pv.Texture(cv2.cvtColor(read_photo(texture_path), cv2.COLOR_BGR2RGB))
                    plotter.add_mesh(mesh, texture=textures[texture_path], ambient=1.0, diffuse=0.0)
                else:
                    plotter.add_mesh(mesh, color=_srgb(visual.material.rgba[:3]), **light)
        rotation, translation = camera_from_model[:3, :3], camera_from_model[:3, 3]
        position = -rotation.T @ translation
        plotter.camera.position = position.tolist()
        plotter.camera.focal_point = (position + rotation.T @ [0.0, 0.0, 1.0]).tolist()
        plotter.camera.up = (-rotation.T @ [0.0, 1.0, 0.0]).tolist()
        plotter.camera.view_angle = float(np.degrees(2 * np.arctan(height / 2 / focal_px)))
        plotter.camera.clipping_range = (0.01, 100.0)
        return np.asarray(plotter.screenshot(return_img=True))[..., :3]
    finally:
        plotter.close()


def _srgb(linear: tuple[float, ...]) -> tuple[float, float, float]:
    c = np.clip(np.asarray(linear, dtype=np.float64), 0, 1)
    return tuple(srgb_encode(c).tolist())


def comparison_picture(
    model: Model, placement: PhotoPlacement, out_path: Path, options: PictureOptions | None = None
) -> Path:
    """Write a PNG: the photo with its face outlined, the model from the photo's camera, and
    (optionally) a 3/4 view, all `panel_height_px` high."""
    options = options or PictureOptions()
    photo = read_photo(placement.photo)
    height, width = photo.shape[:2]
    scale = options.panel_height_px / height
    size = (max(int(round(width * scale)), 1), options.panel_height_px)
    camera_from_model, focal = photo_camera(placement, (width, height), options)
    same_view = render_model(model, camera_from_model, focal * scale, size, options)
    outlined = cv2.resize(photo, size, interpolation=cv2.INTER_AREA)
    corners = ((placement.corners_px + 0.5) * scale - 0.5).round().astype(np.int32)
    cv2.polylines(outlined, [corners.reshape(-1, 1, 2)], True, (0, 220, 0), 2, cv2.LINE_AA)
    panels = [outlined, cv2.cvtColor(same_view, cv2.COLOR_RGB2BGR)]
    if options.three_quarter_view:
        view_size = (options.panel_height_px, options.panel_height_px)
        photo_position = -camera_from_model[:3, :3].T @ camera_from_model[:3, 3]
        camera, view_focal = three_quarter_camera(model, view_size, towards=photo_position)
        panels.append(cv2.cvtColor(render_model(model, camera, view_focal, view_size, options), cv2.COLOR_RGB2BGR))
    gap = np.full((options.panel_height_px, 6, 3), 255, np.uint8)
    picture = np.hstack([p for panel in panels for p in (panel, gap)][:-1])
    ok, data = cv2.imencode(".png", picture, [cv2.IMWRITE_PNG_COMPRESSION, 9])
    if not ok:
        raise InputError(f"{out_path}: cannot encode the picture")
    write_bytes_atomic(Path(out_path), data.tobytes())
    return Path(out_path)


@dataclass(kw_only=True)
class PictureRow:
    """One photo's figures: its face, its texture, the camera found for it, its picture."""

    photo: str
    part: str
    face: str
    texture_px: tuple[int, int]
    texture_kb: float
    focal_px: float
    reprojection_px: float  # the face's corners through the recovered camera, against the photo's
    picture: str


def _reprojection_px(
    placement: PhotoPlacement, camera_from_model: np.ndarray, focal: float, size: tuple[int, int]
) -> float:
    points = placement.model_corners_m @ camera_from_model[:3, :3].T + camera_from_model[:3, 3]
    pixels = points[:, :2] / points[:, 2:] * focal + (np.asarray(size) - 1) / 2
    return float(np.linalg.norm(pixels - placement.corners_px, axis=1).max())


def comparison_pictures(
    model: Model, placements: list[PhotoPlacement], folder: Path, options: PictureOptions | None = None
) -> list[PictureRow]:
    """`comparison_<i>.png` in `folder` for each photo placement, and each photo's figures."""
    options = options or PictureOptions()
    rows = []
    for placement in placements:
        name = f"comparison_{placement.index}.png"
        comparison_picture(model, placement, folder / name, options)
        height, width = read_photo(placement.photo).shape[:2]
        camera_from_model, focal = photo_camera(placement, (width, height), options)
        texture = read_photo(placement.texture)
        rows.append(
            PictureRow(
                photo=str(placement.photo),
                part=placement.part,
                face=placement.face,
                texture_px=(texture.shape[1], texture.shape[0]),
                texture_kb=placement.texture.stat().st_size / 1024,
                focal_px=focal,
                reprojection_px=_reprojection_px(placement, camera_from_model, focal, (width, height)),
                picture=name,
            )
        )
    return rows
