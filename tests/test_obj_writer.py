"""The OBJ writer formats whole blocks at once: its text must equal, byte for byte, the text of
one `numbers.fixed` call per number, on the values where that formatting has edges."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from homemodel.exchange.numbers import fixed
from homemodel.exchange.obj import obj_text
from homemodel.geometry.mesh_ops import zero_area_faces

EDGES = [0.0, -0.0, -4e-7, 4e-7, 5e-7, -5e-7, 1.0, -1.0, 10.0, 100.0, 1e20, -1e-20, 0.1, 0.1000005, 123.4560001,
         2.5e-6, -2.5e-6, 1.5e-6, 1e6, -1e6, 0.4999996, -0.04999996, float("nan"), float("inf"), -float("inf")]  # fmt: skip


def reference_obj(mesh: trimesh.Trimesh, *, mtl_file, material, uv) -> str:
    """The writer's format spelt out a number at a time."""
    coordinates = [[fixed(c) for c in vertex] for vertex in np.asarray(mesh.vertices)]
    written = np.array(coordinates, dtype=np.float64).reshape(-1, 3)
    faces = np.asarray(mesh.faces)[~zero_area_faces(written, mesh.faces)] + 1
    lines = ["# homemodel"] + ([f"mtllib {mtl_file}"] if mtl_file else [])
    lines += [f"v {x} {y} {z}" for x, y, z in coordinates]
    lines += [f"vt {fixed(u)} {fixed(v)}" for u, v in uv] if uv is not None else []
    lines += [f"usemtl {material}"] if material else []
    lines += [f"f {a}/{a} {b}/{b} {c}/{c}" if uv is not None else f"f {a} {b} {c}" for a, b, c in faces]
    return "\n".join(lines) + "\n"


@pytest.mark.filterwarnings("ignore:invalid value:RuntimeWarning")  # the NaN and inf edges
def test_block_formatting_equals_one_fixed_call_per_number() -> None:
    rng = np.random.default_rng(0)
    for trial in range(120):
        n = int(rng.integers(0, 40))
        vertices = rng.normal(size=(n, 3)) * 10.0 ** rng.integers(-7, 4)
        vertices[rng.random((n, 3)) < 0.3] = rng.choice(EDGES)
        if trial % 3 == 0:
            vertices = vertices.astype(np.float32)
        faces = rng.integers(0, max(n, 1), size=(int(rng.integers(0, 60)) if n else 0, 3))
        mesh = trimesh.Trimesh(vertices, faces, process=False)
        uv = None
        if trial % 2:
            uv = rng.random((n, 2))
            uv[rng.random((n, 2)) < 0.3] = rng.choice(EDGES)
        options = {"mtl_file": "a.mtl" if trial % 4 == 0 else None, "material": "m" if trial % 5 == 0 else None, "uv": uv}
        assert obj_text(mesh, **options) == reference_obj(mesh, **options), trial


def test_a_sliver_that_rounding_flattens_is_left_out() -> None:
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.5, 2e-7, 0.0]])
    text = obj_text(trimesh.Trimesh(vertices, [[0, 1, 2], [0, 1, 3]], process=False), mtl_file=None, material=None, uv=None)
    assert text.splitlines()[-1] == "f 1 2 3" and text.count("\nf ") == 1
    assert "v 0.5 0 0" in text
