"""Photo textures: rectification against known warps, face detection, UVs that sample the
right texels in the exported OBJ and GLB, the real clients on textured models, refusals."""

from __future__ import annotations

import copy
import json
import shutil
import struct
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest
from spec_edits import read_spec, write_spec

from homemodel.core.errors import SpecError
from homemodel.core.transforms import transform_points, world_from_camera_looking_at
from homemodel.geometry.camera import Camera
from modeller import load_spec
from modeller.photo_texture import detect_quad, rectify_planar, rectify_wrap
from modeller.specs.photos import FacePhoto

FOCAL_PX = 700.0
# The kitchen cupboard's left door: its front face in the model frame, corners TL, TR, BR, BL.
DOOR_FACE_M = np.array([[0.245, -0.398, 0.738], [0.245, -0.002, 0.738], [0.245, -0.002, 0.102], [0.245, -0.398, 0.102]])
MARKERS_BGR = {"TL": (0, 0, 255), "TR": (0, 255, 0), "BR": (255, 0, 0), "BL": (0, 255, 255)}


# ---------------------------------------------------------------------------- synthetic photos


def _smooth_pattern(rng: np.random.Generator, width: int, height: int) -> np.ndarray:
    """A colourful pattern without hard edges, so resampling errors measure geometry, not aliasing."""
    coarse = rng.integers(0, 256, (height // 25 + 2, width // 25 + 2, 3)).astype(np.float32)
    return cv2.resize(coarse, (width, height), interpolation=cv2.INTER_CUBIC).clip(0, 255).astype(np.uint8)


def _paste(photo: np.ndarray, design: np.ndarray, corners: np.ndarray) -> None:
    """Warp `design` (outer edges at -0.5 .. size - 0.5) onto `corners` of `photo`."""
    h, w = design.shape[:2]
    source = np.float32([[-0.5, -0.5], [w - 0.5, -0.5], [w - 0.5, h - 0.5], [-0.5, h - 0.5]])
    homography = cv2.getPerspectiveTransform(source, corners.astype(np.float32))
    size = (photo.shape[1], photo.shape[0])
    warped = cv2.warpPerspective(design, homography, size, flags=cv2.INTER_LINEAR)
    mask = cv2.warpPerspective(np.ones((h, w), np.float32), homography, size, flags=cv2.INTER_LINEAR)[..., None]
    photo[:] = (mask * warped + (1 - mask) * photo).round().astype(np.uint8)


def _project(points_m: np.ndarray, eye_m: tuple, target_m: tuple, size_px: tuple[int, int]) -> np.ndarray:
    width, height = size_px
    camera = Camera(width=width, height=height, fx=FOCAL_PX, fy=FOCAL_PX, cx=(width - 1) / 2, cy=(height - 1) / 2)
    return camera.project(transform_points(np.linalg.inv(world_from_camera_looking_at(eye_m, target_m)), points_m))


def _marked_checkerboard(width: int, height: int) -> np.ndarray:
    """Grey/white squares with a coloured square in each corner (as seen looking at the face)."""
    y, x = np.mgrid[0:height, 0:width]
    board = np.where(((x // 44) + (y // 53)) % 2 == 0, 235, 120).astype(np.uint8)
    board = np.repeat(board[..., None], 3, axis=2)
    m = 44
    board[:m, :m], board[:m, -m:] = MARKERS_BGR["TL"], MARKERS_BGR["TR"]
    board[-m:, -m:], board[-m:, :m] = MARKERS_BGR["BR"], MARKERS_BGR["BL"]
    return board


@pytest.fixture(scope="module")
def door_photo(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, np.ndarray]:
    """A checkerboard door front photographed by a 700 px pinhole from the front left."""
    size = (520, 640)
    photo = np.full((size[1], size[0], 3), 90, np.uint8)
    corners = _project(DOOR_FACE_M, (1.0, -0.6, 0.55), (0.245, -0.2, 0.42), size)
    _paste(photo, _marked_checkerboard(396, 636), corners)
    path = tmp_path_factory.mktemp("photos") / "door.png"
    cv2.imwrite(str(path), photo)
    return path, corners


@pytest.fixture(scope="module")
def cupboard_spec(kitchen_dir: Path) -> Callable[[Path, list[dict]], Path]:
    """Writes the kitchen cupboard's spec with these photos as `cupboard.yaml` into a folder."""
    data = read_spec(kitchen_dir / "cupboard.yaml")
    return lambda folder, photos: write_spec(folder, {**data, "photos": photos}, "cupboard.yaml")


# ---------------------------------------------------------------------------- rectification (no bpy)


def test_rectified_face_matches_the_pattern_warped_by_a_known_homography() -> None:
    rng = np.random.default_rng(3)
    pattern = _smooth_pattern(rng, 300, 200)
    photo = rng.integers(0, 256, (480, 640, 3)).astype(np.uint8)
    corners = np.array([[102.3, 80.7], [521.9, 121.2], [498.4, 402.6], [131.1, 431.8]])
    _paste(photo, pattern, corners)
    texture = rectify_planar(photo, corners, (300, 200))
    inner = (slice(3, -3), slice(3, -3))  # the outermost texels mix in the background
    error = np.abs(texture.astype(np.float64) - pattern)[inner].mean()
    assert error < 2.0, f"mean abs error {error:.2f} of 255"


def test_face_outline_is_detected_within_a_pixel(door_photo: tuple[Path, np.ndarray]) -> None:
    path, corners = door_photo
    found = detect_quad(cv2.imread(str(path)), (20, 5, 500, 635))
    assert found is not None
    assert np.abs(found - corners).max() < 1.0, np.abs(found - corners).max()


def test_unrolled_wrap_matches_the_label_of_a_side_view() -> None:
    """A cylinder seen side-on shows its label at x = sin(angle): unrolling must undo that."""
    rng = np.random.default_rng(5)
    label = _smooth_pattern(rng, 400, 300)  # half the circumference: 180 deg
    radius_px, height_px = 150, 300
    angle = np.arcsin((np.arange(2 * radius_px) + 0.5) / radius_px - 1)
    map_x = np.tile(((angle / np.pi + 0.5) * 400 - 0.5).astype(np.float32), (height_px, 1))
    map_y = np.tile(np.arange(height_px, dtype=np.float32)[:, None], (1, 2 * radius_px))
    photo = np.zeros((340, 400, 3), np.uint8)
    photo[20:320, 50:350] = cv2.remap(label, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    corners = np.array([[49.5, 19.5], [349.5, 19.5], [349.5, 319.5], [49.5, 319.5]])
    spec = FacePhoto(part="body", face="wrap", photo=Path("p.png"), corners_px=corners.tolist(), wrap_span_deg=180)
    texture = rectify_wrap(photo, corners, spec, (800, 300), fill_bgr=(1, 2, 3))
    band = texture[:, 200:600]  # u 0.25 .. 0.75: the photographed half
    # Near the silhouette one photo pixel spans many degrees; compare where it resolves the label.
    middle = slice(60, 340)
    error = np.abs(band[:, middle].astype(np.float64) - label[:, middle]).mean()
    assert error < 3.0, f"mean abs error {error:.2f} of 255"
    assert (texture[:, :190] == (1, 2, 3)).all() and (texture[:, 610:] == (1, 2, 3)).all()


def test_the_camera_is_recovered_from_the_face_corners(door_photo: tuple[Path, np.ndarray]) -> None:
    from modeller.blender_textures import PhotoPlacement
    from modeller.comparison_picture import (
        PictureOptions,
        focal_from_corners,
        photo_camera,
    )

    path, corners = door_photo
    assert abs(focal_from_corners((520, 640), DOOR_FACE_M, corners) - FOCAL_PX) < 0.01 * FOCAL_PX
    placement = PhotoPlacement(
        index=0,
        photo=path,
        part="door_0",
        face="front",
        corners_px=corners,
        model_corners_m=DOOR_FACE_M,
        texture=path,
        material="m",
    )
    camera_from_model, _ = photo_camera(placement, (520, 640), PictureOptions())
    eye = -camera_from_model[:3, :3].T @ camera_from_model[:3, 3]
    assert np.linalg.norm(eye - (1.0, -0.6, 0.55)) < 0.01


# ---------------------------------------------------------------------------- refusals (no bpy)


def _refusal(cupboard_spec: Callable[[Path, list[dict]], Path], folder: Path, photo: dict) -> str:
    entry = {"part": "door_0", "face": "front", "photo": "door.png", **photo}
    entry = {k: v for k, v in entry.items() if v is not None}
    with pytest.raises(SpecError) as caught:
        load_spec(cupboard_spec(folder, [entry]))
    message = str(caught.value)
    assert "\n" not in message
    return message


GOOD_CORNERS = [[90, 30], [394, 66], [381, 529], [110, 599]]


@pytest.mark.parametrize(
    ("photo", "field", "words"),
    [
        ({"corners_px": [[90, 30], [381, 529], [394, 66], [110, 599]]}, "corners_px", "convex"),
        ({"corners_px": [[90, 30], [110, 599], [381, 529], [394, 66]]}, "corners_px", "anticlockwise"),
        ({"corners_px": [[90, 30], [91, 30], [91, 31], [90, 31]]}, "corners_px", "1.0 px apart"),
        ({"corners_px": [[90, 30], [394, 66], [381, 529], [110, 599], [0, 0]]}, "corners_px", "at most 4"),
        ({"corners_px": [[90, 30], [394, 66], [381, 529], [110, 699]]}, "corners_px.3", "bottom-left corner"),
        ({"corners_px": None}, "corners_px", "give the face's corners_px or a region_px"),
        ({"region_px": [0, 0, 10, 10]}, "corners_px", "not both"),
        ({"corners_px": None, "region_px": [0, 0, 600, 600]}, "region_px", "reaches outside the 520x640 photo"),
        ({"corners_px": None, "region_px": [5, 5, 60, 60]}, "region_px", "no convex four-cornered outline"),
        ({"photo": "missing.png"}, "photo", "no such file"),
        ({"photo": "garbage.png"}, "photo", "not an image file"),
        ({"photo": "truncated.png"}, "photo", "not a readable image: truncated"),
        ({"face": "inside"}, "face", "'front'"),
        ({"wrap_span_deg": 90}, "wrap_span_deg", "only for face: wrap"),
        ({"face": "wrap", "wrap_span_deg": 270}, "wrap_span_deg", "at most 180 deg"),
        ({"face": "wrap", "wrap_range_m": [0.5, 0.1]}, "wrap_range_m", "not below"),
        ({"colour": "red"}, "colour", "Extra inputs"),
    ],
)
def test_bad_photo_is_refused_naming_file_and_field(
    tmp_path: Path, door_photo: tuple[Path, np.ndarray], cupboard_spec, photo: dict, field: str, words: str
) -> None:
    (tmp_path / "door.png").write_bytes(door_photo[0].read_bytes())
    (tmp_path / "garbage.png").write_bytes(b"this is not an image" * 10)
    (tmp_path / "truncated.png").write_bytes(door_photo[0].read_bytes()[:300])
    message = _refusal(cupboard_spec, tmp_path, {"corners_px": GOOD_CORNERS, **photo})
    assert message.startswith(f"{tmp_path / 'cupboard.yaml'}: photos.0.{field}: "), message
    assert words in message, message


def test_photo_paths_are_taken_from_the_spec_folder(
    tmp_path: Path, door_photo: tuple[Path, np.ndarray], cupboard_spec
) -> None:
    (tmp_path / "pics").mkdir()
    (tmp_path / "pics" / "door.png").write_bytes(door_photo[0].read_bytes())
    spec = load_spec(
        cupboard_spec(
            tmp_path, [{"part": "door_0", "face": "front", "photo": "pics/door.png", "corners_px": GOOD_CORNERS}]
        )
    )
    assert spec.photos[0].photo == (tmp_path / "pics" / "door.png").absolute()


# ---------------------------------------------------------------------------- built and exported (bpy)


@pytest.fixture(scope="module")
def textured_cupboard(tmp_path_factory: pytest.TempPathFactory, door_photo: tuple[Path, np.ndarray], cupboard_spec):
    """The kitchen cupboard with the checkerboard photo on door 0, built and exported."""
    from homemodel.exchange.model_files import export_model
    from modeller.build import build_textured

    folder = tmp_path_factory.mktemp("cupboard")
    path, corners = door_photo
    shutil.copy(path, folder / "door.png")  # a spec's photos lie in its folder
    spec_path = cupboard_spec(
        folder, [{"part": "door_0", "face": "front", "photo": "door.png", "corners_px": corners.round(3).tolist()}]
    )
    built = build_textured(load_spec(spec_path), "cupboard", spec_path=spec_path)
    export_model(built.model, folder / "model")
    return built, folder / "model"


def _sample(texture: np.ndarray, uv: np.ndarray, v_down: bool = False) -> np.ndarray:
    """The texel at each (u, v): OpenGL v up (OBJ) or glTF v down."""
    height, width = texture.shape[:2]
    x = np.clip(uv[:, 0] * width - 0.5, 0, width - 1).round().astype(int)
    y_down = uv[:, 1] if v_down else 1 - uv[:, 1]
    y = np.clip(y_down * height - 0.5, 0, height - 1).round().astype(int)
    return texture[y, x].astype(np.int64)


def _door_corner_uvs(vertices: np.ndarray, uv: np.ndarray, model, v_down: bool = False) -> np.ndarray:
    """The UVs at the door's four face corners, each moved 4% towards the face's centre."""
    link_from_model = np.linalg.inv(model.world_from_links()["door_0"])
    corners = DOOR_FACE_M @ link_from_model[:3, :3].T + link_from_model[:3, 3]
    nearest = [int(np.argmin(np.linalg.norm(vertices - c, axis=1))) for c in corners]
    assert np.linalg.norm(vertices[nearest] - corners, axis=1).max() < 1e-3
    corner_uv = uv[nearest]
    return corner_uv + 0.04 * (corner_uv.mean(axis=0) - corner_uv) / np.abs(corner_uv.mean(axis=0) - corner_uv)


def _assert_markers(colours: np.ndarray) -> None:
    for colour, name in zip(colours, ("TL", "TR", "BR", "BL")):
        assert np.abs(colour - MARKERS_BGR[name]).max() < 60, (name, colour.tolist())


@pytest.mark.bpy
def test_obj_uvs_put_the_photo_corners_on_the_face_corners(textured_cupboard) -> None:
    built, folder = textured_cupboard
    mtl = (folder / "meshes" / "door_0_door_0.photo_door_0_front.mtl").read_text()
    texture_name = next(line.split()[1] for line in mtl.splitlines() if line.startswith("map_Kd"))
    texture = cv2.imread(str(folder / "meshes" / texture_name))
    assert (folder / "meshes" / texture_name).stat().st_size < 300_000
    lines = (folder / "meshes" / "door_0_door_0.photo_door_0_front.obj").read_text().splitlines()
    vertices = np.array([[float(v) for v in line.split()[1:]] for line in lines if line.startswith("v ")])
    uv = np.array([[float(v) for v in line.split()[1:]] for line in lines if line.startswith("vt ")])
    _assert_markers(_sample(texture, _door_corner_uvs(vertices, uv, built.model)))
    # The texture has the face's metric aspect ratio (0.396 x 0.636 m).
    assert abs(texture.shape[1] / texture.shape[0] - 0.396 / 0.636) < 0.01


def _glb_primitive(glb: Path, mesh_name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(positions, glTF uv, decoded base colour texture) of the textured primitive of a mesh."""
    data = glb.read_bytes()
    json_length = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20 : 20 + json_length])
    blob = data[20 + json_length + 8 :]

    def array(accessor_index: int, width: int) -> np.ndarray:
        accessor = doc["accessors"][accessor_index]
        view = doc["bufferViews"][accessor["bufferView"]]
        raw = blob[view["byteOffset"] : view["byteOffset"] + view["byteLength"]]
        return np.frombuffer(raw, dtype=np.float32).reshape(accessor["count"], width).astype(np.float64)

    mesh = next(m for m in doc["meshes"] if m["name"] == mesh_name)
    primitive = next(
        p for p in mesh["primitives"] if "baseColorTexture" in doc["materials"][p["material"]]["pbrMetallicRoughness"]
    )
    texture_index = doc["materials"][primitive["material"]]["pbrMetallicRoughness"]["baseColorTexture"]["index"]
    view = doc["bufferViews"][doc["images"][doc["textures"][texture_index]["source"]]["bufferView"]]
    image = cv2.imdecode(np.frombuffer(blob[view["byteOffset"] : view["byteOffset"] + view["byteLength"]], np.uint8), 1)
    return array(primitive["attributes"]["POSITION"], 3), array(primitive["attributes"]["TEXCOORD_0"], 2), image


@pytest.mark.bpy
def test_glb_uvs_put_the_photo_corners_on_the_face_corners(textured_cupboard) -> None:
    built, folder = textured_cupboard
    positions, uv, texture = _glb_primitive(folder / "model.glb", "door_0")
    corner_uv = _door_corner_uvs(positions, uv, built.model)
    _assert_markers(_sample(texture, corner_uv, v_down=True))


def _extent_m(link) -> np.ndarray:
    return np.ptp(np.vstack([v.mesh.vertices for v in link.visuals]), axis=0)


@pytest.mark.bpy
def test_textured_models_pass_the_gate_and_keep_their_shape_and_mass(textured_cupboard, kitchen_dir: Path) -> None:
    from homemodel.model_folder.gate.validate import validate_path
    from modeller import build_model

    built, folder = textured_cupboard
    report = validate_path(folder)
    assert report.ok, report.format()
    assert any(c.name == "glTF validator" and c.passed for c in report.checks)
    plain = build_model(kitchen_dir / "cupboard.yaml")
    for link in plain.links:
        textured = built.model.link(link.name)
        assert np.allclose(textured.inertial.com_m, link.inertial.com_m, atol=1e-9)
        assert np.allclose(textured.inertial.inertia_kgm2, link.inertial.inertia_kgm2, rtol=1e-9, atol=1e-12)
        assert np.allclose(_extent_m(textured), _extent_m(link), atol=1e-6)


@pytest.mark.bpy
def test_blender_reads_the_textured_glb_back_with_its_texture(textured_cupboard) -> None:
    import bpy

    from homemodel.core.c_stdio_capture import captured_c_output
    from homemodel.geometry.cycles_scene import reset_to_empty_scene
    from modeller.blender_scene import material_texture_path

    _, folder = textured_cupboard
    reset_to_empty_scene()
    with captured_c_output():
        bpy.ops.import_scene.gltf(filepath=str(folder / "model.glb"))
    textured = [
        m
        for m in bpy.data.materials
        if m.node_tree is not None and any(n.type == "TEX_IMAGE" for n in m.node_tree.nodes)
    ]
    assert [m.name for m in textured] == ["photo_door_0_front"]
    image = next(n.image for n in textured[0].node_tree.nodes if n.type == "TEX_IMAGE")
    expected = cv2.imread(str(next((folder / "meshes").glob("photo_door_0_front*"))))
    assert tuple(image.size) == (expected.shape[1], expected.shape[0])
    assert material_texture_path(textured[0]) is not None or image.packed_file is not None


@pytest.mark.bpy
def test_cup_wrap_puts_the_label_centre_where_the_camera_looked(tmp_path: Path, textured_dir: Path) -> None:
    """The example mug: its label's red circle faces -x (wrap_centre_deg 180), the handle side stays white."""
    from homemodel.exchange.model_files import export_model
    from homemodel.model_folder.gate.validate import validate_path
    from modeller import build_model

    model = build_model(textured_dir / "cup.yaml")
    export_model(model, tmp_path / "cup")
    assert validate_path(tmp_path / "cup").ok
    import trimesh

    visual = next(v for v in model.link("body").visuals if v.material.texture is not None)
    texture = cv2.imread(str(visual.material.texture))
    # On -x (where the camera looked from) in the circle above the lettering; on +x at the same height.
    points = np.array([[-0.0425, 0.0, 0.068], [0.0425, 0.0, 0.068]])
    _, _, triangles = trimesh.proximity.closest_point(visual.mesh, points)
    corners = visual.mesh.vertices[visual.mesh.faces[triangles]]
    weights = trimesh.triangles.points_to_barycentric(corners, points)
    uv = np.einsum("nk,nkd->nd", weights, visual.uv[visual.mesh.faces[triangles]])
    assert abs(uv[0, 0] - 0.5) < 0.01 and abs(uv[0, 1] - 0.68) < 0.01, uv[0]
    red, white = _sample(texture, uv)
    assert red[2] > 150 and red[0] < 90, red.tolist()  # the label's red circle (BGR)
    assert (white > 200).all(), white.tolist()  # the cup's own white, opposite the photo


@pytest.mark.bpy
def test_packet_example_has_three_textured_faces_of_its_size(tmp_path: Path, textured_dir: Path) -> None:
    from homemodel.exchange.model_files import export_model
    from homemodel.model_folder.gate.validate import validate_path
    from modeller import build_model

    model = build_model(textured_dir / "packet.yaml")
    textured = {v.material.name: v for v in model.link("body").visuals if v.material.texture is not None}
    assert sorted(textured) == ["photo_body_front", "photo_body_right", "photo_body_top"]
    # Each textured face spans the packet's measured face (0.07 x 0.19 x 0.28 m) within 1 mm.
    spans = {name: np.ptp(v.mesh.vertices, axis=0) for name, v in textured.items()}
    assert np.allclose(spans["photo_body_front"], (0, 0.19, 0.28), atol=1e-3)
    assert np.allclose(spans["photo_body_right"], (0.07, 0, 0.28), atol=1e-3)
    assert np.allclose(spans["photo_body_top"], (0.07, 0.19, 0), atol=1e-3)
    export_model(model, tmp_path / "packet")
    assert validate_path(tmp_path / "packet").ok


@pytest.mark.bpy
def test_unknown_part_and_missing_face_are_refused_after_building(tmp_path: Path, door_photo, cupboard_spec) -> None:
    from modeller import build_model

    path, corners = door_photo
    shutil.copy(path, tmp_path / "door.png")  # a spec's photos lie in its folder
    for part, extra, field, words in [
        ("door_9", {"face": "front"}, "part", "no part named 'door_9'; this model's parts are body, body.plinth"),
        ("door_0_handle", {"face": "wrap", "wrap_range_m": [5, 6]}, "face", "part 'door_0_handle' has no round side"),
    ]:
        entry = {"part": part, **extra, "photo": "door.png", "corners_px": corners.round(3).tolist()}
        spec_path = cupboard_spec(tmp_path, [entry])
        with pytest.raises(SpecError) as caught:
            build_model(spec_path)
        assert str(caught.value).startswith(f"{spec_path}: photos.0.{field}: {words}"), str(caught.value)


@pytest.mark.bpy
def test_render_writes_a_validated_model_and_pictures_that_match_the_photo(tmp_path: Path, textured_dir: Path) -> None:
    from modeller import BuildOptions, build
    from modeller.comparison_picture import PictureOptions

    out = tmp_path / "render"
    result = build(textured_dir / "cupboard.yaml", out, BuildOptions(pictures=PictureOptions(panel_height_px=640)))
    assert result.valid, result.failed_checks
    assert {"model.urdf", "model.glb", "model.blend", "summary.json", "comparison_0.png", "comparison_1.png"} <= {
        p.name for p in out.iterdir()
    }
    assert json.loads((out / "summary.json").read_text())["gate"]["valid"] is True
    for row in result.pictures:
        assert abs(row.focal_px - FOCAL_PX) < 0.01 * FOCAL_PX and row.reprojection_px < 0.5
    # The middle panel (the model through the recovered camera) shows the door where the photo does.
    photo = cv2.imread(str(textured_dir / "photos" / "cupboard_door.jpg"))
    picture = cv2.imread(str(out / "comparison_0.png"))
    render = picture[:, photo.shape[1] + 6 : 2 * photo.shape[1] + 6]
    mask = np.zeros(photo.shape[:2], np.uint8)
    corners = np.array(read_spec(textured_dir / "cupboard.yaml")["photos"][0]["corners_px"])
    cv2.fillConvexPoly(mask, cv2.convexHull(corners.round().astype(np.int32)), 1)
    mask = cv2.erode(mask, np.ones((9, 9), np.uint8)).astype(bool)
    error = np.abs(render.astype(np.float64) - photo)[mask].mean()
    assert error < 20, f"mean abs error {error:.1f} of 255 inside the door"


def test_example_specs_with_photos_are_valid(textured_dir: Path) -> None:
    for path in sorted(textured_dir.glob("*.yaml")):
        spec = load_spec(path)
        assert spec.photos and all(p.photo.is_file() for p in spec.photos)
        assert all(p.photo.stat().st_size < 200_000 for p in spec.photos)
    assert copy.deepcopy(spec) == spec
