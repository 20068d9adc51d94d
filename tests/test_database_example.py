"""The database example runs on a fresh clone with the README's command and no prior step, and
a build's worker processes end cleanly (no crash printed when the local cluster closes)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from homemodel.app.database import ModelIndex
from homemodel.app.database.manifest import SOURCES, load_manifest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "database"
# What a crashed or failing process prints: Python's tracebacks, glog's and the kernel's words.
CRASH_WORDS = ("Traceback", "SIGSEGV", "Segmentation fault", "Aborted at", "Error", "Not freed memory")
# The cheap part of the example (its photo entry takes minutes): one of every other source.
CHEAP_IDS = ("kitchen_cupboard", "base_unit", "turntable_cup", "completed_cup", "partnet_cabinet")


def db_build(manifest: Path, db: Path, tmp: Path, *more: str) -> subprocess.CompletedProcess:
    """`homemodel db build MANIFEST --db DIR`, as the README says, in a fresh process whose
    temporary files (Blender's session folders among them) go to `tmp`."""
    tmp.mkdir(exist_ok=True)
    env = {**os.environ, "PYTHONPATH": str(ROOT), "TMPDIR": str(tmp), "COLUMNS": "200"}
    command = [sys.executable, "-m", "homemodel", "db", "build", str(manifest), "--db", str(db), *more]
    return subprocess.run(command, env=env, capture_output=True, text=True, timeout=600)


@pytest.mark.shared_data
def test_the_example_needs_no_prior_step() -> None:
    """Every input of the example is in the repository, but the shared Kermit photos (which the
    project reads from ../shared/data, never copies), and every source is there."""
    jobs, _ = load_manifest(EXAMPLE / "manifest.yaml")
    assert {job.source for job in jobs} == set(SOURCES)
    shared = (ROOT.parent / "shared" / "data").resolve()
    for job in jobs:
        for path in job.inputs.values():
            assert path.exists()
            assert path.is_relative_to(ROOT) or (job.source == "photos" and path.is_relative_to(shared)), path
    assert [job.id for job in jobs if job.repair] == ["partnet_cabinet"]


def _cheap_example(folder: Path) -> Path:
    """The example's manifest cut to CHEAP_IDS (the sweep to one width), its paths made absolute."""
    data = yaml.safe_load((EXAMPLE / "manifest.yaml").read_text())
    entries = [e for e in data["entries"] if e["id"] in CHEAP_IDS]
    for entry in entries:
        for role in ("path", "camera", "completion_model"):
            if role in entry:
                entry[role] = str((EXAMPLE / entry[role]).resolve())
        if "sweep" in entry:
            entry["sweep"]["width_m"] = entry["sweep"]["width_m"][:1]
    folder.mkdir()
    manifest = folder / "manifest.yaml"
    manifest.write_text(yaml.safe_dump({**data, "entries": entries}))
    return manifest


@pytest.mark.bpy
@pytest.mark.slow
def test_the_example_builds_with_the_readme_command(tmp_path) -> None:
    manifest = _cheap_example(tmp_path / "inputs")
    done = db_build(manifest, tmp_path / "db", tmp_path / "tmp")
    assert done.returncode == 0, done.stdout + done.stderr
    with ModelIndex(tmp_path / "db") as index:
        rows = {row.id: row for row in index.rows()}
    assert len(rows) == 7 and "built 7 (7 valid, 0 invalid, 0 failed), cached 0" in done.stdout
    assert {row.source for row in rows.values()} == {"spec", "turntable", "completion", "urdf"}
    # The PartNet cabinet is repaired because its entry asks, and each repair is stated.
    cabinet = rows["partnet_cabinet"]
    assert cabinet.category == "cupboard" and cabinet.grasp_points == 1
    assert any("no <inertial>;" in r and "at 500 kg/m^3" in r for r in cabinet.repairs) and any("effort set to 10" in r for r in cabinet.repairs)
    assert "repaired joint 'joint_0': effort set to 10, velocity set to 1" in done.stdout
    assert not [word for word in CRASH_WORDS if word in done.stderr], done.stderr
    again = db_build(manifest, tmp_path / "db", tmp_path / "tmp")
    assert "built 0 (0 valid, 0 invalid, 0 failed), cached 7" in again.stdout


@pytest.mark.bpy
@pytest.mark.slow
def test_workers_that_ran_blender_end_without_a_crash(tmp_path) -> None:
    """bpy ran on a Dask executor thread, and its module teardown crashed the worker when the
    cluster closed; pycolmap's glog (imported for a photo entry) printed the crash. A local
    worker runs its entries on its main thread: it must end as cleanly. With one worker, it
    builds every entry (the command's process builds none)."""
    folder = tmp_path / "inputs"
    (folder / "photos").mkdir(parents=True)
    for i in range(3):
        (folder / "photos" / f"{i}.jpg").write_bytes(b"\xff\xd8 not a jpeg " * 10)
    (folder / "cup.yaml").write_bytes((ROOT / "examples/catalogue/cup.yaml").read_bytes())
    entries = [
        {"id": "cup", "source": "spec", "path": "cup.yaml", "sweep": {"height_m": [0.08, 0.09]}},
        {"id": "frog", "source": "photos", "path": "photos"},
    ]
    (folder / "manifest.yaml").write_text(yaml.safe_dump({"entries": entries}))
    done = db_build(folder / "manifest.yaml", tmp_path / "db", tmp_path / "tmp", "--workers", "1")
    assert done.returncode == 0, done.stdout + done.stderr
    assert "built 3 (2 valid, 0 invalid, 1 failed)" in done.stdout
    with ModelIndex(tmp_path / "db") as index:
        assert len({row.worker for row in index.rows()}) == 1
    assert done.stderr.strip() == "", done.stderr
    # Blender's session folders (one per worker) are removed, as Blender's own exit would.
    assert not list((tmp_path / "tmp").glob("blender_*"))
