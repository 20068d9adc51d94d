"""How `db build` hands its entries to Dask: small entries a few to a task when there are many,
long ones alone and first, and the build process free of the pipelines' imports."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from homemodel.app.database.manifest import Job
from homemodel.app.database.build_request import BuildRequest
from homemodel.app.database.tasks import MAX_BATCH, TASKS_PER_WORKER, batches, task_key

ROOT = Path(__file__).resolve().parents[1]


def _requests(source: str, count: int, prefix: str) -> list[BuildRequest]:
    return [
        BuildRequest(job=Job(id=f"{prefix}{i}", source=source, inputs={"path": Path(f"/in/{prefix}{i}")}), key=f"k{i}", db_dir=Path("/db"), repair=None)
        for i in range(count)
    ]


def test_small_entries_are_batched_only_when_there_are_enough_to_share() -> None:
    photos, specs = _requests("photos", 3, "p"), _requests("spec", 200, "s")
    tasks = batches(photos + specs, workers=2)
    # The long ones alone, first; every entry once, in manifest order.
    assert [t[0].job.id for t in tasks[:3]] == ["p0", "p1", "p2"] and all(len(t) == 1 for t in tasks[:3])
    assert [r.job.id for t in tasks for r in t] == [r.job.id for r in photos + specs]
    assert {len(t) for t in tasks[3:]} == {MAX_BATCH}
    # Few entries per worker: one to a task, so the workers still share them evenly.
    few = _requests("urdf", 2 * TASKS_PER_WORKER * 2 - 1, "u")
    assert {len(t) for t in batches(few, workers=2)} == {1}
    assert {len(t) for t in batches(few, workers=1)} == {3, 1}  # 31 // 8 = 3 to a task


def test_a_task_key_changes_with_any_entry_key() -> None:
    batch = _requests("spec", 3, "s")
    key = task_key(batch)
    assert key.startswith("homemodel-db-s0+2-")
    batch[2].key = "changed"
    assert task_key(batch) != key and task_key(batch[:1]).startswith("homemodel-db-s0-")


def test_the_build_process_does_not_import_the_pipelines() -> None:
    """Only the workers import the entry build (trimesh, the gate, bpy): in the process that
    submits the tasks it cost 1.2 s of CPU before the first entry."""
    code = (
        "import sys; import homemodel.app.database.build, homemodel.app.database.tasks; "
        "print(sorted(m for m in ('trimesh', 'bpy', 'open3d', 'homemodel.app.database.entry_build') if m in sys.modules))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert done.stdout.strip() == "[]"
