"""`homemodel db`: a mixed manifest built on local worker processes; failures recorded, not
fatal; rebuilds by content key; repairs stated; queries, export, map add db:ID; a killed
client leaves a whole index and the next build finishes the job."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml
from partnet_sample import write_partnet_cabinet
from typer.testing import CliRunner

from homemodel.app.database import DatabaseBuildOptions, ModelIndex, build_database
from homemodel.app.database.dispatch import JOURNAL
from homemodel.cli import app

pytestmark = [pytest.mark.bpy, pytest.mark.slow]
ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()


def run(*args: str | Path):  # noqa: ANN201
    return runner.invoke(app, [str(a) for a in args], env={"COLUMNS": "200"})


def write_manifest(folder: Path) -> Path:
    """Every source, good and bad: two specs and a sweep with an impossible value, a PartNet
    cabinet that needs repairs, corrupt photos, a capture without its camera, a completion
    model that is not one."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "cup.yaml").write_bytes((ROOT / "examples/catalogue/cup.yaml").read_bytes())
    write_partnet_cabinet(folder / "cabinet")
    (folder / "photos").mkdir()
    for i in range(3):
        (folder / "photos" / f"{i}.jpg").write_bytes(b"\xff\xd8 not a jpeg " * 10)
    (folder / "capture" / "color").mkdir(parents=True)
    (folder / "query").mkdir()
    (folder / "query" / "depth.png").write_bytes(b"not a png")
    (folder / "query" / "camera.yaml").write_text("width: 4\nheight: 4\nfx: 1\nfy: 1\ncx: 2\ncy: 2\n")
    (folder / "completer.npz").write_bytes(b"not a model")
    entries = [
        {"id": "cup", "source": "spec", "path": "cup.yaml", "properties": {"colour": "white"}},
        {"id": "tall", "source": "spec", "path": "cup.yaml", "sweep": {"height_m": [0.11, -0.02]}},
        {"id": "cabinet", "source": "urdf", "path": "cabinet", "properties": {"room": "kitchen"}},
        {"id": "frog", "source": "photos", "path": "photos", "marker_size_m": 0.05},
        {"id": "scan", "source": "turntable", "path": "capture"},
        {"id": "guess", "source": "completion", "path": "query/depth.png", "completion_model": "completer.npz"},
    ]
    path = folder / "manifest.yaml"
    path.write_text(yaml.safe_dump({"entries": entries, "repair": {"density_kg_m3": 650.0}}))
    return path


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> tuple[Path, Path, object]:
    # The full suite has imported bpy before: the workers this process starts must still import it.
    import bpy  # noqa: F401

    root = tmp_path_factory.mktemp("db")
    manifest = write_manifest(root / "inputs")
    result = run("db", "build", manifest, "--db", root / "db", "--workers", "2")
    return manifest, root / "db", result


def rows(db: Path) -> dict:
    with ModelIndex(db) as index:
        return {row.id: row for row in index.rows()}


def test_every_entry_is_built_or_recorded_with_its_error(built) -> None:
    _, db, result = built
    assert result.exit_code == 0, result.output
    assert "built 7 (2 valid, 1 invalid, 4 failed), cached 0" in result.output
    got = rows(db)
    assert {i: r.status for i, r in got.items()} == {
        "cup": "valid", "tall_0": "valid", "tall_1": "failed", "cabinet": "invalid",
        "frog": "failed", "scan": "failed", "guess": "failed",
    }  # fmt: skip
    assert "height_m" in got["tall_1"].error and "cup.yaml" in got["tall_1"].error
    assert "--repair" in got["cabinet"].error and "inertial" in got["cabinet"].error
    assert "0.jpg" in got["frog"].error
    assert "camera.yaml" in got["scan"].error or "board.yaml" in got["scan"].error
    assert got["guess"].error
    assert got["tall_0"].properties["height_m"] == "0.11"
    assert got["cup"].category == "cup" and got["cup"].properties["colour"] == "white"
    # The build's own process (this one) built small entries while its worker started; the
    # reconstructions went to the worker only.
    pids = {i: int(r.worker.rsplit(":", 1)[1]) for i, r in got.items()}
    assert os.getpid() in {pids[i] for i in ("cup", "tall_0", "tall_1", "cabinet")}
    assert os.getpid() not in {pids[i] for i in ("frog", "scan", "guess")}


def test_stored_folders_are_whole_and_match_the_index(built) -> None:
    _, db, _ = built
    for row in rows(db).values():
        folder = db / "models" / row.id
        if row.path is None:
            assert not folder.exists()
            continue
        assert row.status == "valid"
        for name in ("model.urdf", "model.glb", "thumbnail.png", "entry.json"):
            assert (folder / name).is_file(), name
        assert json.loads((folder / "entry.json").read_text())["key"] == row.key
        thumb = cv2.imread(str(folder / "thumbnail.png"))
        assert thumb.shape == (160, 160, 3)
        assert (np.abs(thumb.astype(int) - 245).max(axis=2) > 10).mean() > 0.05  # the model, not only background
    # The sweep's spec is kept beside the model it built, with the swept value.
    assert yaml.safe_load((db / "models/tall_0/spec.yaml").read_text())["height_m"] == 0.11
    assert not [p for p in (db / "models").iterdir() if p.name.startswith(".")]


def test_a_rebuild_with_nothing_changed_builds_nothing(built) -> None:
    manifest, db, _ = built
    start = time.perf_counter()
    result = build_database(manifest, db, DatabaseBuildOptions(workers=1))
    assert time.perf_counter() - start < 5.0
    assert result.built == [] and len(result.cached) == 7


def test_a_changed_spec_and_repair_rebuild_only_those(built) -> None:
    manifest, db, _ = built
    spec = manifest.parent / "cup.yaml"
    spec.write_text(spec.read_text().replace("colour: white", "colour: blue"))
    before = rows(db)
    # As a build killed while it built `cup` itself leaves it: that entry now goes to a worker.
    (db / JOURNAL).write_text("cup")
    # The spec is shared by cup and the sweep: all three are rebuilt (tall_1 fails again), and
    # the cabinet because --repair changes how it is built; the rest are cached.
    result = build_database(manifest, db, DatabaseBuildOptions(workers=2, repair=True))
    assert sorted(r.id for r in result.built) == ["cabinet", "cup", "tall_0", "tall_1"]
    after = rows(db)
    assert int(after["cup"].worker.rsplit(":", 1)[1]) != os.getpid() and not (db / JOURNAL).exists()
    assert after["frog"].key == before["frog"].key and after["frog"].built_at == before["frog"].built_at
    assert after["cup"].key != before["cup"].key
    cabinet = after["cabinet"]
    assert cabinet.status == "valid" and cabinet.category == "cupboard"
    assert cabinet.grasp_points == 1 and cabinet.joints == 1
    assert any("650 kg/m^3" in r for r in cabinet.repairs) and any("effort set to 10" in r for r in cabinet.repairs)


def test_list_show_find_export_remove_and_map_add(built, tmp_path) -> None:
    manifest, db, _ = built
    build_database(manifest, db, DatabaseBuildOptions(workers=2, repair=True))  # whatever ran before
    listed = run("db", "list", "--db", db)
    assert listed.exit_code == 0 and "cabinet" in listed.output and "tall_1" in listed.output
    shown = run("db", "show", "cabinet", "--db", db)
    assert "repaired" in shown.output and "PASS  check_urdf" in shown.output
    found = run("db", "find", "--db", db, "--category", "cupboard", "--property", "room=kitchen")
    assert "cabinet" in found.output and "1 found" in found.output
    assert "0 found" in run("db", "find", "--db", db, "--property", "room=bathroom").output
    out = tmp_path / "exported"
    assert run("db", "export", "cabinet", "--db", db, "--out", out).exit_code == 0
    assert (out / "model.urdf").is_file() and (out / "model.glb").is_file()

    from semantic_map import SemanticMap
    from homemodel.exchange.map_xml import load_map, save_map

    smap = SemanticMap.new(apartment_id="flat", name="Flat")
    smap.add_room(room_id="kitchen", name="Kitchen")
    save_map(smap, tmp_path / "map.xml")
    added = run("map", "add", tmp_path / "map.xml", "db:cabinet", "--db", db, "--id", "cabinet_1", "--parent", "kitchen", "--parking", "1 0 3.14")
    assert added.exit_code == 0, added.output
    node = load_map(tmp_path / "map.xml").node("cabinet_1")
    assert node.type == "cupboard" and len(node.grasp_points) == 1 and len(node.joints) == 1
    refused = run("map", "add", tmp_path / "map.xml", "db:tall_1", "--db", db, "--id", "x", "--parent", "kitchen")
    assert refused.exit_code == 2 and "did not pass" in refused.output

    assert run("db", "remove", "tall_0", "--db", db).exit_code == 0
    assert "tall_0" not in rows(db) and not (db / "models/tall_0").exists()
    missing = run("db", "show", "tall_0", "--db", db)
    assert missing.exit_code == 2 and "no entry 'tall_0'" in missing.output


def test_a_bad_manifest_is_one_line_and_exit_2(tmp_path) -> None:
    (tmp_path / "m.yaml").write_text("entries:\n  - {id: a, source: spec, path: nowhere.yaml}\n")
    result = run("db", "build", tmp_path / "m.yaml", "--db", tmp_path / "db")
    assert result.exit_code == 2 and "entries.0.path: no such file" in result.output
    (tmp_path / "m.yaml").write_text("entries:\n  - {id: a, source: urdf, path: m.yaml, sweep: {x: [1]}}\n")
    result = run("db", "build", tmp_path / "m.yaml", "--db", tmp_path / "db")
    assert result.exit_code == 2 and "only spec entries can sweep" in result.output


def test_a_killed_client_leaves_a_whole_index_and_the_next_build_finishes(tmp_path) -> None:
    # Enough entries that the build is still running when the first row lands: an entry takes
    # about 0.2 s, and rows are committed in batches (6 entries all landed in one batch in CI).
    count = 30
    for i in range(count):
        write_partnet_cabinet(tmp_path / f"cabinet{i}")
    entries = [{"id": f"c{i:02d}", "source": "urdf", "path": f"cabinet{i}"} for i in range(count)]
    manifest = tmp_path / "manifest.yaml"
    manifest.write_text(yaml.safe_dump({"entries": entries}))
    db = tmp_path / "db"
    command = [sys.executable, "-m", "homemodel", "db", "build", str(manifest), "--db", str(db), "--workers", "2", "--repair"]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    client = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not ((db / "index.sqlite").exists() and rows(db)):
            time.sleep(0.2)
        assert time.monotonic() < deadline, "no entry was stored in 2 minutes"
    finally:
        os.killpg(client.pid, signal.SIGKILL)  # the client and its workers, mid-build
        client.wait()
    partial = rows(db)
    assert 0 < len(partial) < count
    # A folder may have been stored just before the kill, without its row: it is built again.
    for row in partial.values():
        assert (db / row.path / "model.urdf").is_file() and (db / row.path / "thumbnail.png").is_file()
    result = build_database(manifest, db, DatabaseBuildOptions(workers=2, repair=True))
    assert sorted(r.id for r in result.built) == sorted(set(f"c{i:02d}" for i in range(count)) - set(partial))
    final = rows(db)
    assert sorted(final) == [f"c{i:02d}" for i in range(count)] and all(r.status == "valid" for r in final.values())
    assert not [p for p in (db / "models").iterdir() if p.name.startswith(".")]
    assert np.all([(db / "models" / i / "model.glb").is_file() for i in final])


def _manifest_with(tmp_path: Path, entry: dict) -> Path:
    (tmp_path / "photos").mkdir(exist_ok=True)
    path = tmp_path / "m.yaml"
    path.write_text(yaml.safe_dump({"entries": [{"id": "kermit", "source": "photos", "path": "photos", **entry}]}))
    return path


def test_manifest_options_are_nested_and_reach_the_pipeline_unchanged(tmp_path) -> None:
    from homemodel.app.database.entry_build import _options
    from homemodel.app.database.manifest import load_manifest
    from photogrammetry.pipeline import ReconstructOptions
    from photogrammetry.sfm import SfmOptions

    entry = {"options": {"marker_size_m": 0.05, "sfm": {"max_num_features": 8192}, "dense": {"neighbours": 3}}}
    [job], _ = load_manifest(_manifest_with(tmp_path, entry))
    options = _options(ReconstructOptions, job, name=job.id, marker_size_m=job.marker_size_m)
    # The options' marker size is kept (the entry has none at the top level to put over it).
    assert options.marker_size_m == 0.05 and options.name == "kermit"
    assert options.sfm.max_num_features == 8192 and options.dense.neighbours == 3
    assert options.sfm.max_image_size_px == SfmOptions().max_image_size_px
    [job], _ = load_manifest(_manifest_with(tmp_path, {"marker_size_m": 0.07}))
    assert _options(ReconstructOptions, job, name=job.id, marker_size_m=job.marker_size_m).marker_size_m == 0.07


@pytest.mark.parametrize(
    ("entry", "said"),
    [
        ({"options": {"sfm": {"max_num_features": "many"}}}, "entries.0.options.sfm.max_num_features: expected a whole number"),
        ({"options": {"sfm": {"max_features": 10}}}, "entries.0.options.sfm.max_features: not a field of SfmOptions"),
        ({"options": {"texture": {"size_px": 1.5}}}, "entries.0.options.texture.size_px: expected a whole number"),
        ({"options": {"name": "other"}}, "entries.0.options.name: not an option here (the entry's id names the model)"),
        ({"marker_size_m": 0.05, "options": {"marker_size_m": 0.06}}, "entries.0.options.marker_size_m: given twice"),
    ],
)
def test_a_bad_manifest_option_is_named_by_its_path_and_exit_2(tmp_path, entry: dict, said: str) -> None:
    result = run("db", "build", _manifest_with(tmp_path, entry), "--db", tmp_path / "db")
    assert result.exit_code == 2 and said in result.output and "\n" not in result.output.strip(), result.output
    assert not (tmp_path / "db").exists()
