"""How `db build` hands its entries out: small entries a few to a worker's task when there are
many and to the build's own process, long ones alone, first and to the workers only, an entry
that crashed the build's process to the workers only; and the build process free of the
pipelines' imports, and of Dask's on a local build."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from homemodel.app.database.build import largest_first
from homemodel.app.database.manifest import Job
from homemodel.app.database.build_request import BuildRequest
from homemodel.app.database.dispatch import JOURNAL, Dispatch, crashed_here
from homemodel.app.database.tasks import MAX_BATCH, TASKS_PER_WORKER, task_key

ROOT = Path(__file__).resolve().parents[1]


def _requests(source: str, count: int, prefix: str) -> list[BuildRequest]:
    return [
        BuildRequest(job=Job(id=f"{prefix}{i}", source=source, inputs={"path": Path(f"/in/{prefix}{i}")}), key=f"k{i}", db_dir=Path("/db"), repair=None)
        for i in range(count)
    ]


def _tasks(dispatch: Dispatch) -> list[list[BuildRequest]]:
    """What the workers would get, task by task, if they took everything."""
    tasks = []
    while batch := dispatch._next_task():
        tasks.append(batch)
    return tasks


def test_small_entries_are_batched_only_when_there_are_enough_to_share() -> None:
    photos, specs = _requests("photos", 3, "p"), _requests("spec", 200, "s")
    tasks = _tasks(Dispatch(None, photos + specs, here=False, processes=2, db_dir=Path("/db")))
    # The long ones alone, first; every entry once, in manifest order.
    assert [t[0].job.id for t in tasks[:3]] == ["p0", "p1", "p2"] and all(len(t) == 1 for t in tasks[:3])
    assert [r.job.id for t in tasks for r in t] == [r.job.id for r in photos + specs]
    # MAX_BATCH to a task while there are many; fewer as the queue runs down, so all end together.
    sizes = [len(t) for t in tasks[3:]]
    assert sizes[0] == MAX_BATCH and sizes[-1] == 1 and sizes == sorted(sizes, reverse=True)
    assert sum(size == MAX_BATCH for size in sizes) >= (200 - 2 * TASKS_PER_WORKER * MAX_BATCH) // MAX_BATCH
    # Few entries per process: one to a task, so the processes still share them evenly.
    few = _requests("urdf", 2 * TASKS_PER_WORKER * 2 - 1, "u")
    assert {len(t) for t in _tasks(Dispatch(None, few, here=False, processes=2, db_dir=Path("/db")))} == {1}
    assert len(_tasks(Dispatch(None, few, here=False, processes=1, db_dir=Path("/db")))[0]) == 3  # 31 // 8


def test_an_entry_that_crashed_the_build_process_goes_to_workers_only(tmp_path) -> None:
    specs = _requests("spec", 3, "s")
    assert crashed_here(tmp_path) == set()
    (tmp_path / JOURNAL).write_text("s1")  # what a build killed while building s1 leaves
    workers_only = crashed_here(tmp_path)
    assert workers_only == {"s1"} and not (tmp_path / JOURNAL).exists()
    dispatch = Dispatch(None, specs, here=True, processes=2, db_dir=tmp_path, workers_only=workers_only)
    assert [r.job.id for r in (dispatch._next_here(), dispatch._next_here())] == ["s0", "s2"]
    assert dispatch._next_here() is None and [r.job.id for t in _tasks(dispatch) for r in t] == ["s1"]
    # Without this process building, the journal changes nothing.
    assert [r.job.id for t in _tasks(Dispatch(None, specs, here=False, processes=2, db_dir=tmp_path, workers_only={"s1"})) for r in t] == ["s0", "s1", "s2"]


def test_entries_go_longest_first_by_their_last_build_and_new_ones_before_them() -> None:
    jobs = [Job(id=name, source="spec", inputs={"path": Path(f"/in/{name}.yaml")}) for name in ("cup", "new_a", "cupboard", "bowl", "new_b")]
    last_build_s = {"cup": 0.12, "cupboard": 0.9, "bowl": 0.2, "gone": 5.0}
    assert [job.id for job in largest_first(jobs, last_build_s)] == ["new_a", "new_b", "cupboard", "bowl", "cup"]
    # Dispatch keeps that order: the build's own process and the workers take from the front.
    requests = [BuildRequest(job=job, key="k", db_dir=Path("/db"), repair=None) for job in largest_first(jobs, last_build_s)]
    dispatch = Dispatch(None, requests, here=True, processes=2, db_dir=Path("/db"))
    assert [dispatch._next_here().job.id for _ in range(3)] == ["new_a", "new_b", "cupboard"]
    assert [r.job.id for r in dispatch._next_task()] == ["bowl"]


def test_a_task_key_changes_with_any_entry_key() -> None:
    batch = _requests("spec", 3, "s")
    key = task_key(batch)
    assert key.startswith("homemodel-db-s0+2-")
    batch[2].key = "changed"
    assert task_key(batch) != key and task_key(batch[:1]).startswith("homemodel-db-s0-")


def test_the_build_process_does_not_import_the_pipelines_or_dask() -> None:
    """The process that submits the tasks imports the entry build (trimesh, the gate, bpy) only
    when it builds entries itself (a local build): never for a remote one. A local build never
    imports Dask: half a second of CPU, and its scheduler a second more, that two plain
    processes do not spend. Nor does a remote build before it connects (`ClusterStart.start`)."""
    code = (
        "import sys; import homemodel.app.database.build, homemodel.app.database.tasks, homemodel.app.database.dispatch; "
        "from homemodel.app.database.cluster import ClusterStart; from homemodel.app.database.local_workers import LocalWorkers; "
        "workers = LocalWorkers(1, ()); assert workers.submit(sum, [1, 2], key='t').result(timeout=60) == 3; workers.close(); "
        "ClusterStart('tcp://127.0.0.1:1', ('spec',)).close(); "
        "print(sorted(m for m in ('trimesh', 'bpy', 'open3d', 'distributed', 'homemodel.app.database.entry_build') if m in sys.modules))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT, timeout=120)
    assert done.stdout.strip() == "[]"
