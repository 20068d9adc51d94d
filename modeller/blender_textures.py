"""Put a spec's photos on the built parts in Blender: select the faces, UV-map them, texture them.

Runs after the builder. For each `FacePhoto` the part's modifiers are applied (so a
solidified wall's inner copy does not get the photo too), the faces making up the named
face are selected and given their own material slot with the rectified photo, and UVs:

- planar faces: a projection onto the face's plane, u along the photo's "right", v along
  its "up", (0, 0) and (1, 1) at the corners of the face's extent, so the rectified
  photo's corners land exactly on the face's corners;
- wrap: cylindrical, u the angle about the axis (`photo_texture.wrap_u`, the band's centre
  at 0.5, the seam opposite) and v the height; a face crossing the seam keeps its u
  continuous (beyond 0..1; the texture repeats), so no face smears the whole image.

Blender's unwrapping is not used: both projections are exact for the faces they select.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from homemodel.core.srgb import srgb_encode
from homemodel.core.yaml_specs import FieldError
from modeller.blender_scene import LINK_PROPERTY, texture_material
from modeller.photo_texture import (
    FaceTextureOptions,
    face_corners_px,
    read_photo,
    rectify_planar,
    rectify_wrap,
    texture_size_px,
    wrap_u,
    write_texture,
)
from modeller.specs.photos import FACE_AXES, FACE_DIRECTIONS, FacePhoto

if TYPE_CHECKING:
    import bmesh
    import bpy

# A face belongs to the named side when its normal is within this angle of the side's.
_PLANAR_NORMAL_COS = np.cos(np.radians(10.0))
# ... and it lies on the part's outermost plane that way, within this distance.
_PLANE_TOLERANCE_M = 1e-4
# A wrap face's normal points outward from the axis (cos to the radial direction) and
# across it (|cos| to the axis below the second figure).
_WRAP_RADIAL_COS = 0.5
_WRAP_AXIAL_COS = 0.3
# (axis, direction of angle 0, direction of angle 90 deg) for each wrap axis.
_WRAP_FRAMES = {
    "z": ((0, 0, 1), (1, 0, 0), (0, 1, 0)),
    "x": ((1, 0, 0), (0, 1, 0), (0, 0, 1)),
    "y": ((0, 1, 0), (0, 0, 1), (1, 0, 0)),
}


@dataclass(kw_only=True)
class PhotoPlacement:
    """Where a photo went: its corners in the photo and the same corners on the model.

    `model_corners_m` are the face's corners (top-left, top-right, bottom-right,
    bottom-left as seen looking at it) in the model frame with every joint at zero.
    """

    index: int
    photo: Path
    part: str
    face: str
    corners_px: np.ndarray
    model_corners_m: np.ndarray
    texture: Path
    material: str


@dataclass(kw_only=True)
class _FaceMapping:
    faces: list[bmesh.types.BMFace]
    uv: list[list[tuple[float, float]]]  # per face, per loop: (u, v)
    size_m: tuple[float, float]  # the texture's extent on the part (width, height)
    source_width_m: float  # how wide the photographed part of it is
    corners_m: np.ndarray  # (4, 3) in the part's frame


def apply_photos(photos: list[FacePhoto], texture_dir: Path, options: FaceTextureOptions) -> list[PhotoPlacement]:
    """Texture the scene's parts with `photos`; textures are written into `texture_dir`.

    Raises `FieldError` located at `photos.<i>.<field>`.
    """
    placements = []
    done: dict[tuple[str, str], int] = {}
    for i, photo in enumerate(photos):
        key = (photo.part, photo.face_axis)
        if key in done:
            raise FieldError(("photos", i, "face"), f"photos.{done[key]} already covers this face of {photo.part!r}")
        done[key] = i
        try:
            placements.append(_apply_photo(i, photo, texture_dir, options))
        except FieldError as exc:
            raise FieldError(("photos", i, *exc.loc), str(exc)) from None
    return placements


def _part(name: str) -> bpy.types.Object:
    import bpy

    parts = sorted(o.name for o in bpy.data.objects if o.type == "MESH" and LINK_PROPERTY in o)
    if name not in parts:
        raise FieldError(("part",), f"no part named {name!r}; this model's parts are {', '.join(parts)}")
    return bpy.data.objects[name]


def _apply_photo(index: int, photo: FacePhoto, texture_dir: Path, options: FaceTextureOptions) -> PhotoPlacement:
    import bmesh
    import bpy

    obj = _part(photo.part)
    image = read_photo(photo.photo)
    corners_px = face_corners_px(photo, image)
    base_rgba = tuple(obj.active_material.diffuse_color) if obj.active_material else (0.8, 0.8, 0.8, 1.0)
    _apply_modifiers(obj)

    bm = bmesh.new()
    bm.from_mesh(obj.data)
    try:
        mapping = _wrap_mapping(bm, photo) if photo.face == "wrap" else _planar_mapping(bm, photo)
        width_m, height_m = mapping.size_m
        size_px = texture_size_px(corners_px, width_m, height_m, options, source_width_m=mapping.source_width_m)
        if photo.face == "wrap":
            texture = rectify_wrap(image, corners_px, photo, size_px, _bgr8(base_rgba))
        else:
            texture = rectify_planar(image, corners_px, size_px)
        material_name = _material_name(photo)
        texture_path = write_texture(texture, texture_dir / f"{material_name}.jpg", options)
        obj.data.materials.append(texture_material(material_name, texture_path))
        slot = len(obj.data.materials) - 1
        uv_layer = bm.loops.layers.uv.active or bm.loops.layers.uv.new("UVMap")
        for face, face_uv in zip(mapping.faces, mapping.uv):
            face.material_index = slot
            for loop, uv in zip(face.loops, face_uv):
                loop[uv_layer].uv = uv
        bm.to_mesh(obj.data)
    finally:
        bm.free()
    world_from_part = np.array(obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).matrix_world)
    model_corners = mapping.corners_m @ world_from_part[:3, :3].T + world_from_part[:3, 3]
    return PhotoPlacement(
        index=index,
        photo=photo.photo,
        part=photo.part,
        face=photo.face,
        corners_px=corners_px,
        model_corners_m=model_corners,
        texture=texture_path,
        material=material_name,
    )


def _apply_modifiers(obj: bpy.types.Object) -> None:
    """Make the object's evaluated mesh (modifiers applied) its own mesh."""
    import bpy

    if not obj.modifiers:
        return
    depsgraph = bpy.context.evaluated_depsgraph_get()
    mesh = bpy.data.meshes.new_from_object(
        obj.evaluated_get(depsgraph), preserve_all_data_layers=True, depsgraph=depsgraph
    )
    obj.modifiers.clear()
    obj.data = mesh


def _material_name(photo: FacePhoto) -> str:
    """`photo_<part>_<face>`, the face by its name (`top`, not `+z`), so both spellings agree."""
    face = {axis: name for name, axis in FACE_AXES.items()}.get(photo.face_axis, photo.face_axis)
    return "photo_" + re.sub(r"[^A-Za-z0-9_]+", "_", f"{photo.part}_{face}")


def _bgr8(rgba_linear: tuple[float, ...]) -> tuple[int, int, int]:
    """A linear colour as the 8-bit sRGB BGR pixel an image holds."""
    linear = np.clip(np.asarray(rgba_linear[:3], dtype=np.float64), 0, 1)
    r, g, b = (int(round(c * 255)) for c in srgb_encode(linear))
    return b, g, r


def _planar_mapping(bm: bmesh.types.BMesh, photo: FacePhoto) -> _FaceMapping:
    normal, up = (np.asarray(v, dtype=np.float64) for v in FACE_DIRECTIONS[photo.face_axis])
    right = np.cross(up, normal)
    plane = max(float(np.dot(v.co, normal)) for v in bm.verts)
    faces = [
        f
        for f in bm.faces
        if np.dot(f.normal, normal) > _PLANAR_NORMAL_COS
        and np.dot(f.calc_center_median(), normal) > plane - _PLANE_TOLERANCE_M
    ]
    if not faces:
        raise FieldError(("face",), f"part {photo.part!r} has no outer surface facing {photo.face_axis} ({photo.face})")
    points = np.array([v.co for f in faces for v in f.verts], dtype=np.float64)
    across, along = points @ right, points @ up
    r0, r1, u0, u1 = across.min(), across.max(), along.min(), along.max()
    if r1 - r0 < _PLANE_TOLERANCE_M or u1 - u0 < _PLANE_TOLERANCE_M:
        raise FieldError(("face",), f"the {photo.face} face of {photo.part!r} has no area")
    uv = [
        [
            (float((np.dot(loop.vert.co, right) - r0) / (r1 - r0)), float((np.dot(loop.vert.co, up) - u0) / (u1 - u0)))
            for loop in f.loops
        ]
        for f in faces
    ]
    corners = np.array([[r0, u1], [r1, u1], [r1, u0], [r0, u0]])
    corners_m = corners[:, :1] * right + corners[:, 1:] * up + plane * normal
    return _FaceMapping(faces=faces, uv=uv, size_m=(r1 - r0, u1 - u0), source_width_m=r1 - r0, corners_m=corners_m)


def _wrap_mapping(bm: bmesh.types.BMesh, photo: FacePhoto) -> _FaceMapping:
    axis, e0, e90 = (np.asarray(v, dtype=np.float64) for v in _WRAP_FRAMES[photo.wrap_axis])
    centre_rad = np.radians(photo.wrap_centre_deg)

    def angle(point: np.ndarray) -> float:
        return float(np.arctan2(np.dot(point, e90), np.dot(point, e0)))

    def wrapped(angle_rad: float) -> float:
        return float((angle_rad + np.pi) % (2 * np.pi) - np.pi)

    faces = []
    for f in bm.faces:
        centre = np.asarray(f.calc_center_median(), dtype=np.float64)
        radial = centre - np.dot(centre, axis) * axis
        distance = np.linalg.norm(radial)
        if distance < 1e-9 or abs(np.dot(f.normal, axis)) > _WRAP_AXIAL_COS:
            continue
        if np.dot(f.normal, radial / distance) < _WRAP_RADIAL_COS:
            continue
        if (
            photo.wrap_range_m is not None
            and not photo.wrap_range_m[0] <= np.dot(centre, axis) <= photo.wrap_range_m[1]
        ):
            continue
        faces.append(f)
    if not faces:
        raise FieldError(("face",), f"part {photo.part!r} has no round side about its {photo.wrap_axis} axis")
    points = np.array([v.co for f in faces for v in f.verts], dtype=np.float64)
    heights = points @ axis
    radius = float(np.linalg.norm(points - np.outer(heights, axis), axis=1).max())
    low, high = photo.wrap_range_m if photo.wrap_range_m is not None else (float(heights.min()), float(heights.max()))
    uv = []
    for f in faces:
        # Each loop's angle relative to its face's, so a face across the seam stays whole.
        face_angle = angle(np.asarray(f.calc_center_median()))
        face_relative = wrapped(face_angle - centre_rad)
        face_uv = []
        for loop in f.loops:
            relative = face_relative + wrapped(angle(np.asarray(loop.vert.co)) - face_angle)
            face_uv.append((float(wrap_u(relative)), float((np.dot(loop.vert.co, axis) - low) / (high - low))))
        uv.append(face_uv)
    half = np.radians(photo.wrap_span_deg) / 2
    source_width = 2 * radius * np.sin(half) if photo.wrap_projection == "side_view" else radius * 2 * half

    def point(angle_rad: float, height: float) -> np.ndarray:
        return radius * (np.cos(angle_rad) * e0 + np.sin(angle_rad) * e90) + height * axis

    # Looking at the band from outside, "right" is the direction of increasing angle.
    left, right = centre_rad - half, centre_rad + half
    corners_m = np.array([point(left, high), point(right, high), point(right, low), point(left, low)])
    return _FaceMapping(
        faces=faces, uv=uv, size_m=(2 * np.pi * radius, high - low), source_width_m=source_width, corners_m=corners_m
    )
