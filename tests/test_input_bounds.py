"""Every input is bounded where it enters: a small file cannot ask for unbounded time or
memory. Each refusal is one line naming the file, the limit and the variable that raises it."""

from __future__ import annotations

import shutil
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
from cli_promise import assert_refused, listing, run_cli
from typer.testing import CliRunner

from homemodel.app.home.build import load_home
from homemodel.cli import app
from homemodel.core.errors import InputError
from homemodel.core.images import read_image
from homemodel.core.yaml_specs import read_yaml_mapping
from homemodel.exchange.urdf.read import load_urdf
from homemodel.geometry.mesh_io import load_mesh
from modeller import load_spec
from shape_completion.shape_codes import ShapeBasis

runner = CliRunner()


def _alias_bomb(levels: int = 3, fan_out: int = 200) -> str:
    """A room listed `fan_out` times, each with `fan_out` objects, each with `fan_out` more: a
    few KB that stand for fan_out**levels objects."""
    lines = ["apartment: {id: flat, name: Flat}", "x0: &x0 {id: cup, spec: red_cup.yaml}"]
    for level in range(1, levels + 1):
        lines.append(f"x{level}: &x{level} [" + ", ".join([f"*x{level - 1}"] * fan_out) + "]")
    lines.append(f"rooms: *x{levels}")
    return "\n".join(lines) + "\n"


def test_an_alias_bomb_home_is_refused_at_once_under_4_gib(tmp_path: Path, kitchen_dir: Path) -> None:
    example = tmp_path / "home"
    shutil.copytree(kitchen_dir, example)
    (example / "home.yaml").write_text(_alias_bomb())
    assert (example / "home.yaml").stat().st_size < 4096
    before = listing(tmp_path)
    run = run_cli("build", example, "--out", tmp_path / "out", timeout_s=90)
    assert_refused(run, names=example / "home.yaml", out=tmp_path / "out", watch=tmp_path, before=before)
    assert "HOMEMODEL_MAX_YAML_NODES" in run.stderr


@pytest.mark.parametrize(
    "text",
    [
        "a: " + "[" * 100_000 + "]" * 100_000,  # flow sequences
        "a: " + "{b: " * 100_000 + "}" * 100_000,  # flow mappings
        "".join(f"{'  ' * i}k{i}:\n" for i in range(2_000)) + "  " * 2_000 + "v: 1\n",  # block mappings
        "a:\n  " + "- " * 5_000 + "1\n",  # block sequences on one line
    ],
    ids=["flow sequences", "flow mappings", "block mappings", "block sequences"],
)
def test_deep_nesting_is_refused_without_recursion(tmp_path: Path, text: str) -> None:
    for name in ("spec.yaml", "home.yaml"):
        path = tmp_path / name
        path.write_text(text)
        with pytest.raises(InputError, match=rf"{name}: .* levels of YAML nesting .*HOMEMODEL_MAX_YAML_DEPTH"):
            read_yaml_mapping(path)


def test_the_bounds_are_raised_or_lowered_by_environment(tmp_path: Path, kitchen_dir: Path, monkeypatch) -> None:
    assert len(load_home(kitchen_dir).rooms) == 2
    monkeypatch.setenv("HOMEMODEL_MAX_YAML_NODES", "50")
    with pytest.raises(InputError, match="home.yaml: .* over the limit of 50 .*HOMEMODEL_MAX_YAML_NODES"):
        load_home(kitchen_dir)
    monkeypatch.setenv("HOMEMODEL_MAX_YAML_NODES", "lots")
    with pytest.raises(InputError, match="HOMEMODEL_MAX_YAML_NODES='lots': must be a whole number"):
        load_home(kitchen_dir)


def test_a_home_of_too_many_objects_is_refused_before_any_build(tmp_path: Path, kitchen_dir: Path) -> None:
    example = tmp_path / "home"
    shutil.copytree(kitchen_dir, example)
    objects = "\n".join(
        f"      - {{id: o{i}, spec: table.yaml, parking: [{{name: p, xy: [0, 0]}}]}}" for i in range(2_001)
    )
    (example / "home.yaml").write_text(f"apartment: {{id: a, name: A}}\nrooms:\n  - id: r\n    name: R\n    objects:\n{objects}\n")
    result = runner.invoke(app, ["build", str(example), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    assert "home.yaml: 2001 objects is over the limit of 2000 (set HOMEMODEL_MAX_OBJECTS" in result.output
    assert not (tmp_path / "out").exists()


def _chain_urdf(joints: int) -> str:
    links = "".join(f'<link name="l{i}"/>' for i in range(joints + 1))
    chain = "".join(
        f'<joint name="j{i}" type="revolute"><parent link="l{i}"/><child link="l{i + 1}"/>'
        f'<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        for i in range(joints)
    )
    return f'<robot name="chain">{links}{chain}</robot>'


def test_a_urdf_of_too_many_joints_is_refused_where_it_enters(tmp_path: Path) -> None:
    urdf = tmp_path / "chain.urdf"
    urdf.write_text(_chain_urdf(1_000))
    with pytest.raises(InputError, match=r"chain.urdf: 1001 links is over the limit of 1000 \(set HOMEMODEL_MAX_LINKS"):
        load_urdf(urdf)
    run = run_cli("validate", urdf, timeout_s=60)
    assert run.returncode == 1 and "FAIL  safe XML" in run.stdout and "HOMEMODEL_MAX_LINKS" in run.stdout


def test_meshes_over_the_triangle_bound_are_refused_before_parsing(tmp_path: Path) -> None:
    obj = tmp_path / "soup.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n" + "f 1 2 3\n" * 1_000_001)
    with pytest.raises(InputError, match=r"soup.obj: 1000001 triangles is over the limit .*HOMEMODEL_MAX_TRIANGLES"):
        load_mesh(obj)
    stl = tmp_path / "claims.stl"
    stl.write_bytes(b"\0" * 80 + struct.pack("<I", 4_000_000_000) + b"\0" * 50)
    with pytest.raises(InputError, match="claims.stl: 4000000000 triangles is over the limit"):
        load_mesh(stl)
    ply = tmp_path / "claims.ply"
    ply.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                    b"property float z\nelement face 3000000000\nproperty list uchar int vertex_indices\nend_header\n")
    with pytest.raises(InputError, match="claims.ply: 3000000000 triangles"):
        load_mesh(ply)


def _png_header(width: int, height: int) -> bytes:
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"")) + chunk(b"IEND", b"")


def test_an_image_claiming_gigapixels_is_refused_before_decoding(tmp_path: Path) -> None:
    bomb = tmp_path / "bomb.png"
    bomb.write_bytes(_png_header(100_000, 100_000))
    with pytest.raises(InputError, match=r"bomb.png: 100000x100000: .* pixels is over the limit .*HOMEMODEL_MAX_PIXELS"):
        read_image(bomb)


@pytest.mark.parametrize(
    "option, value, message",
    [
        ("--samples", "2000000000", "n_samples: 2000000000 surface samples is over the limit"),
        ("--f-threshold", "inf", "threshold_fraction: must lie in"),
        ("--f-threshold", "nan", "threshold_fraction: must lie in"),
        ("--f-threshold", "1e300", "threshold_fraction: must lie in"),
    ],
)
def test_evaluation_options_are_checked_before_the_meshes_are_read(tmp_path: Path, option, value, message) -> None:
    result = runner.invoke(app, ["eval", "surface-distance", str(tmp_path / "a.obj"), str(tmp_path / "b.obj"), option, value])
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {message}"), result.output


def test_a_huge_render_is_refused_before_blender_starts(tmp_path: Path) -> None:
    """In this process (tests/test_blender_addon.py runs `turntable simulate` as a child process)."""
    mesh = tmp_path / "box.obj"
    mesh.write_text("v 0 0 0\nv .1 0 0\nv 0 .1 0\nv 0 0 .1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    result = runner.invoke(app, ["turntable", "simulate", str(mesh), "--out", str(tmp_path / "capture"), "--width", "100000"])
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "HOMEMODEL_MAX_RENDER_PIXELS" in lines[0], result.output
    assert not (tmp_path / "capture").exists()


@pytest.mark.parametrize("value", ["1e300", "1e20", "-1e300", ".inf", ".nan", "101"])
def test_measurements_beyond_any_home_are_refused_by_field(tmp_path: Path, catalogue_dir: Path, value: str) -> None:
    spec = tmp_path / "cup.yaml"
    spec.write_text((catalogue_dir / "cup.yaml").read_text().replace("height_m: 0.075", f"height_m: {value}"))
    with pytest.raises(InputError, match=r"cup.yaml: height_m: "):
        load_spec(spec)


def test_a_shape_basis_fits_a_library_with_fewer_views_than_features() -> None:
    """One class of two meshes with few views gave NMF fewer rows than shape features."""
    occupancies = (np.random.default_rng(0).random((8, 4096)) > 0.5).astype(float)
    basis = ShapeBasis(n_components=12, random_state=0).fit(occupancies)
    assert basis.components_.shape == (8, 4096)
    assert basis.codes(occupancies).shape == (8, 8)


def test_deeply_nested_json_is_an_input_error(tmp_path: Path) -> None:
    from homemodel.exchange.cameras import read_cameras

    cameras = tmp_path / "cameras.json"
    cameras.write_text("[" * 200_000 + "]" * 200_000)
    with pytest.raises(InputError, match="cameras.json: not a cameras file: RecursionError"):
        read_cameras(cameras)
