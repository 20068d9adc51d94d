"""The strict OBJ reader gives the gate and the URDF reader the same vertices and faces as
trimesh's OBJ parser on the files they read (the repository's OBJs, homemodel's own writer's
output, hand-written forms), and refuses malformed or hostile files with the file and line."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from homemodel.core.errors import InputError
from homemodel.exchange.obj import mtl_text, obj_text, read_obj
from homemodel.exchange.urdf.read import read_mesh_parts
from homemodel.geometry.mesh_io import read_mesh_file
from homemodel.model_folder.gate.mesh_files import read_gate_mesh

REPO = Path(__file__).resolve().parents[1]
REPO_OBJS = sorted(REPO.glob("examples/**/*.obj"))


def _writer_objs(folder: Path) -> list[Path]:
    """homemodel's OBJ writer on hulls, an icosphere, a capsule (unreferenced vertices after its
    zero-area faces go), with and without a material line, and uv-textured (trimesh's reading)."""
    rng = np.random.default_rng(7)
    meshes = [trimesh.convex.convex_hull(rng.normal(size=(60, 3)) * 0.1) for _ in range(3)]
    meshes += [trimesh.creation.icosphere(2, radius=0.05), trimesh.creation.capsule(0.1, 0.02, count=[6, 6])]
    paths = []
    for k, mesh in enumerate(meshes):
        for name, kwargs in {
            "hull": dict(mtl_file=None, material=None, uv=None),
            "coloured": dict(mtl_file=f"m{k}.mtl", material="paint", uv=None),
            "textured": dict(mtl_file=f"m{k}.mtl", material="paint", uv=np.asarray(mesh.vertices)[:, :2]),
        }.items():
            path = folder / f"{name}_{k}.obj"
            path.write_text(obj_text(mesh, **kwargs))
            paths.append(path)
        # `d 0.5`: trimesh's material ignores it (its diffuse stays opaque), and so must the reader.
        (folder / f"m{k}.mtl").write_text(mtl_text("paint", (0.75, 0.05, 0.05, 0.5), None))
    return paths


HAND_WRITTEN = {
    "comments_names_groups": "# x\no thing\nv 0 0 0\nv 1 0 0 # trailing\nv 0 1 0\nv 0 0 1\ng a\ns off\nf 1 2 3\ng b\nf 1 2 4\n",
    "unreferenced_vertex": "v 9 9 9\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 2 3 4\nf 2 3 5\n",
    "negative_after_all": "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf -4 -3 -2\nf -4 -3 -1\n",
    "one_material": "mtllib none.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nusemtl red\nf 1 2 3\nf 1 2 4\n",
    "material_not_in_its_mtl": "mtllib m0.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl blue\nf 1 2 3",
    "interleaved": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nv 0 0 1\nf 1 2 4\n",
    "crlf_double_space": "v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nv 0 0 1\r\nf 1 2 3\r\nf 1  2 4\r\n",
    "quads": "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nf 1 2 3 4\nf 1 2 5\n",
    "normals": "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvn 0 0 1\nf 1//1 2//1 3//1\nf 1//1 2//1 4//1\n",
    "uv_normals": "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nf 1/1/1 2/2/1 3/3/1\n",
}


@pytest.fixture(scope="module")
def objs(tmp_path_factory) -> list[Path]:
    folder = tmp_path_factory.mktemp("objs")
    hand = []
    for name, text in HAND_WRITTEN.items():
        (folder / f"{name}.obj").write_text(text)
        hand.append(folder / f"{name}.obj")
    return REPO_OBJS + _writer_objs(folder) + hand


def test_the_gate_reads_every_obj_to_trimeshs_vertices_and_faces(objs: list[Path]) -> None:
    assert len(REPO_OBJS) >= 3
    plain = 0
    for path in objs:
        ours, theirs = read_gate_mesh(path), read_mesh_file(path)
        assert np.array_equal(ours.vertices, theirs.vertices), path.name
        assert np.array_equal(ours.faces, theirs.faces), path.name
        plain += read_obj(path.read_bytes(), path).is_plain() and b"/" not in path.read_bytes()
    assert plain >= 10  # the strict reader, not trimesh's, read most of them


def test_the_urdf_reader_reads_every_obj_as_trimesh_did(objs: list[Path]) -> None:
    for path in objs:
        ours = read_mesh_parts(path)
        loaded = trimesh.load(path, process=False, maintain_order=True)
        theirs = [loaded] if isinstance(loaded, trimesh.Trimesh) else list(loaded.geometry.values())
        assert len(ours) == len(theirs), path.name
        for (name, mesh), reference in zip(ours, theirs):
            assert np.array_equal(mesh.vertices, reference.vertices), path.name
            assert np.array_equal(mesh.faces, reference.faces), path.name
            assert _visual_fields(mesh.visual) == _visual_fields(reference.visual), path.name


def _visual_fields(visual) -> tuple:  # noqa: ANN001
    """What the URDF reader takes from a mesh's visual: its kind, uv and material."""
    material = getattr(visual, "material", None)
    fields = ("name", "diffuse", "ambient", "specular", "glossiness", "kwargs")
    uv = getattr(visual, "uv", None)
    return (type(visual).__name__, None if uv is None else np.asarray(uv).tolist(),
            None if material is None else tuple(repr(getattr(material, f, None)) for f in fields))


def test_the_urdf_reader_reads_an_obj_of_one_colour_without_trimeshs_parser(objs: list[Path], monkeypatch) -> None:
    """homemodel's visuals (one untextured material, its MTL beside): the strict reader, the
    material from trimesh's MTL parser (the test above: the same as trimesh's loader gives)."""
    def refused(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
        raise AssertionError("trimesh's OBJ parser was used")

    monkeypatch.setattr(trimesh, "load", refused)
    coloured = [path for path in objs if path.name.startswith("coloured_")]
    assert len(coloured) == 5
    for path in coloured:
        (_, mesh), = read_mesh_parts(path)
        assert mesh.visual.material.name == "paint" and list(mesh.visual.material.diffuse) == [191, 13, 13, 255]


def _triangle_soup(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """The triangles as point triples, whatever corner each starts at and whatever their order."""
    triangles = np.asarray(vertices)[np.asarray(faces)].round(9).tolist()
    return np.array(sorted(sorted(map(tuple, triangle)) for triangle in triangles))


def test_every_corner_form_and_polygon_gives_trimeshs_triangles(objs: list[Path]) -> None:
    """v/vt, v//vn, v/vt/vn and quads, which the gate leaves to trimesh: the reader's triangles are
    still the same (trimesh splits corners and orders quads' halves differently)."""
    for path in objs:
        obj = read_obj(path.read_bytes(), path)
        reference = trimesh.load(path, process=False, force="mesh")
        assert np.allclose(_triangle_soup(obj.vertices, obj.faces), _triangle_soup(reference.vertices, reference.faces))
    uv = read_obj(HAND_WRITTEN["uv_normals"].encode(), Path("uv.obj"))
    assert uv.face_texcoords.tolist() == [[0, 1, 2]] and uv.face_normals.tolist() == [[0, 0, 0]]
    fan = read_obj(b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0.5 2 0\nv 0 1 0\nf 1 2 3 4 5\n", Path("fan.obj"))
    assert fan.faces.tolist() == [[0, 1, 2], [0, 2, 3], [0, 3, 4]] and fan.polygons and not fan.is_plain()


def test_negative_indices_count_back_from_the_face_not_the_file_end() -> None:
    obj = read_obj(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 0 0 1\nf 1 2 -1\n", Path("rel.obj"))
    assert obj.faces.tolist() == [[0, 1, 2], [0, 1, 3]]


@pytest.mark.parametrize(
    ("text", "line", "problem"),
    [
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", 4, "names v 4, but 3 are defined"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", 4, "names v 0"),
        ("v 0 0 0\nv 1 0 zero\nv 0 1 0\nf 1 2 3\n", 2, "not a number"),
        ("v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", 1, "needs 3 or 4 or 6 or 7 numbers"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", 4, "at least three corners"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3.5\n", 4, "whole numbers"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\n", 4, "names vt 1, but 0 are defined"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/// 2 3\n", 4, "bad face corner"),
        ("v 0 0 0\n<html>\n", 2, "unknown OBJ statement"),
    ],
)
def test_a_malformed_obj_is_refused_naming_the_file_and_line(tmp_path: Path, text: str, line: int, problem: str) -> None:
    path = tmp_path / "bad.obj"
    path.write_text(text)
    # Corners with "/" are left to trimesh by the gate and the URDF reader (it refuses them its way).
    readers = [lambda p: read_obj(p.read_bytes(), p)] + ([read_gate_mesh, read_mesh_parts] if "/" not in text else [])
    for read in readers:
        with pytest.raises(InputError) as error:
            read(path)
        assert str(error.value).startswith(f"{path}: line {line}: ") and problem in str(error.value), str(error.value)


def test_a_file_without_faces_or_text_is_refused(tmp_path: Path) -> None:
    empty, binary = tmp_path / "points.obj", tmp_path / "binary.obj"
    empty.write_text("v 0 0 0\nv 1 0 0\n")
    binary.write_bytes(b"v 0 0 0\n\xff\xfe\x00f 1 1 1\n")
    with pytest.raises(InputError, match=f"^{re.escape(str(empty))}: the file holds no triangles"):
        read_obj(empty.read_bytes(), empty)
    with pytest.raises(InputError, match=f"^{re.escape(str(binary))}: not UTF-8"):
        read_gate_mesh(binary)


OBJ_NOISE = st.text(alphabet=list("vtnfogsu/-+.e0123456789 #\n\t\r"), max_size=30)


@settings(max_examples=300, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])  # fmt: skip
@given(base=st.sampled_from(sorted(HAND_WRITTEN.values())), cut=st.integers(0, 200), noise=OBJ_NOISE)
def test_a_hostile_obj_gives_a_mesh_within_bounds_or_one_line_of_error(tmp_path: Path, base: str, cut: int, noise: str) -> None:
    """Noise spliced into a valid file: the reader returns faces inside the arrays it returns,
    or an InputError of one line naming the file; never another exception."""
    path = tmp_path / "fuzzed.obj"
    path.write_text(base[:cut] + noise + base[cut:])
    try:
        read_gate_mesh(path)
    except InputError as exc:
        assert str(exc).startswith(str(path)) and "\n" not in str(exc)
    try:
        obj = read_obj(path.read_bytes(), path)
    except InputError as exc:
        assert str(exc).startswith(str(path)) and "\n" not in str(exc)
        return
    assert obj.faces.shape[1] == 3 and 0 <= obj.faces.min() and obj.faces.max() < len(obj.vertices)
    for table, values in ((obj.face_texcoords, obj.texcoords), (obj.face_normals, obj.normals)):
        assert table is None or (0 <= table.min() and table.max() < len(values))


def test_an_mtl_past_the_mesh_files_bound_is_refused_naming_it(tmp_path: Path, monkeypatch) -> None:
    """The MTL beside a one-colour OBJ is read within the mesh files' byte bound, as the OBJ is
    (it was read whole: a huge or device-linked MTL beside a small OBJ)."""
    import homemodel.exchange.urdf.read as urdf_read

    obj = tmp_path / "part.obj"
    obj.write_text("mtllib part.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl paint\nf 1 2 3\n")
    (tmp_path / "part.mtl").write_text(mtl_text("paint", (0.75, 0.05, 0.05, 1.0), None) + "# padding\n" * 200)
    monkeypatch.setattr(urdf_read, "MAX_MESH_BYTES", 1000)  # over the OBJ, under the MTL
    with pytest.raises(InputError, match=r"part\.mtl: larger than the 1000-byte bound"):
        read_mesh_parts(obj)
