"""The gate parses each mesh file of a model once (`homemodel.geometry.mesh_io.meshes_read_once`),
hands every check its own copy, re-reads a file that changed, and still refuses a bad mesh."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from articulation.scan_model import scan_model
from homemodel.core.errors import InputError
from homemodel.exchange.model_files import write_model_files
from homemodel.geometry import mesh_io
from homemodel.geometry.mesh_io import load_mesh, meshes_read_once
from homemodel.model_folder.gate import mesh_files
from homemodel.model_folder.gate.validate import validate_path


def _counting_reads(monkeypatch: pytest.MonkeyPatch, module=mesh_io, name: str = "read_mesh_file") -> dict[Path, int]:
    reads: dict[Path, int] = {}
    real = getattr(module, name)

    def counted(path: Path) -> trimesh.Trimesh:
        reads[Path(path)] = reads.get(Path(path), 0) + 1
        return real(path)

    monkeypatch.setattr(module, name, counted)
    return reads


def test_a_scanned_boxs_meshes_are_each_parsed_once_by_the_gate(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    folder = tmp_path / "box"
    write_model_files(scan_model(trimesh.creation.box((0.1, 0.06, 0.04)), name="box_scan", density_kg_m3=500.0), folder)
    objs = sorted((folder / "meshes").glob("*.obj"))
    assert len(objs) == 2  # the visual and its hull, each read by three of the gate's checks
    reads = _counting_reads(monkeypatch, mesh_files, "read_gate_mesh")
    report = validate_path(folder)
    assert report.ok, report.format()
    assert set(reads) == set(objs) and set(reads.values()) == {1}, reads


def test_each_reader_gets_its_own_copy_and_a_changed_file_is_read_again(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "box.obj"
    trimesh.creation.box((1.0, 1.0, 1.0)).export(path)
    reads = _counting_reads(monkeypatch)
    with meshes_read_once():
        first = load_mesh(path)
        first.apply_translation((5.0, 0.0, 0.0))  # a reader moving its copy changes no one else's
        second = load_mesh(path)
        assert reads[path] == 1 and np.allclose(second.bounds, [[-0.5] * 3, [0.5] * 3])
        trimesh.creation.box((2.0, 2.0, 2.0)).export(path)
        assert np.allclose(load_mesh(path).bounds, [[-1.0] * 3, [1.0] * 3]) and reads[path] == 2
    load_mesh(path)  # outside the block nothing is kept
    assert reads[path] == 3


def test_a_cached_mesh_with_nan_is_still_refused_where_finite_vertices_are_required(tmp_path: Path) -> None:
    path = tmp_path / "nan.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 nan 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\n")
    with meshes_read_once():
        assert not np.all(np.isfinite(load_mesh(path, require_finite=False).vertices))
        with pytest.raises(InputError, match="non-finite"):
            load_mesh(path)
