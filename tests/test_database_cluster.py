"""`homemodel db build --scheduler`: a real Dask scheduler and two workers started as separate
processes on localhost, one worker killed mid-build; every entry is built and indexed exactly
once, the index is whole, and a rerun builds nothing."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from partnet_sample import write_partnet_cabinet

from homemodel.app.database import ModelIndex

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[1]
# Enough entries that the build is still running when the first row lands: an imported asset
# takes about 0.1 s, and the index commits its rows in batches every half second.
ENTRIES = 24


def _wait_for(what: str, ready, timeout_s: float = 120.0) -> None:  # noqa: ANN001
    deadline = time.monotonic() + timeout_s
    while not ready():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.2)


def _rows(db: Path) -> list:
    if not (db / "index.sqlite").exists():
        return []
    with ModelIndex(db) as index:
        return index.rows()


@pytest.fixture()
def cluster(tmp_path):  # noqa: ANN201
    """A scheduler and two single-threaded workers without nannies (a killed worker stays dead)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    scheduler_file = tmp_path / "scheduler.json"
    dask = [sys.executable, "-m", "distributed.cli.dask_scheduler"]
    procs = [subprocess.Popen([*dask, "--port", "0", "--no-dashboard", "--scheduler-file", str(scheduler_file)],
                              env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]  # fmt: skip
    _wait_for("the scheduler", scheduler_file.exists, 60)
    address = json.loads(scheduler_file.read_text())["address"]
    worker = [sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1", "--no-nanny", "--no-dashboard"]
    workers = [subprocess.Popen([*worker, "--name", f"w{i}"], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL) for i in range(2)]
    procs += workers
    try:
        from distributed import Client

        with Client(address, timeout="60s") as client:
            client.wait_for_workers(2, timeout=120)
        yield address, workers
    finally:
        for proc in procs:
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM if proc is procs[0] else signal.SIGKILL)
        for proc in procs:
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                proc.kill()


def test_a_killed_worker_loses_nothing_and_builds_nothing_twice(tmp_path, cluster) -> None:
    address, workers = cluster
    for i in range(ENTRIES):
        write_partnet_cabinet(tmp_path / f"asset{i}")
    manifest = tmp_path / "manifest.yaml"
    manifest.write_text(yaml.safe_dump({"entries": [{"id": f"e{i}", "source": "urdf", "path": f"asset{i}"} for i in range(ENTRIES)]}))
    db = tmp_path / "db"
    command = [sys.executable, "-m", "homemodel", "db", "build", str(manifest), "--db", str(db), "--scheduler", address, "--repair"]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    build = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    _wait_for("the first entry", lambda: len(_rows(db)) >= 1)
    from distributed import Client

    with Client(address, timeout="60s") as client:
        names = {addr: info["name"] for addr, info in client.scheduler_info()["workers"].items()}
        held = {names[addr]: keys for addr, keys in client.processing().items()}
    workers[0].kill()  # mid-build: the entry it holds goes to the other worker
    assert held.get("w0"), f"w0 held no entry when killed: {held}"
    output, _ = build.communicate(timeout=300)
    assert build.returncode == 0, output
    assert f"built {ENTRIES} ({ENTRIES} valid, 0 invalid, 0 failed)" in output
    rows = _rows(db)
    assert sorted(r.id for r in rows) == sorted(f"e{i}" for i in range(ENTRIES))
    assert all(r.status == "valid" for r in rows)
    assert {int(r.worker.rsplit(":", 1)[1]) for r in rows} <= {w.pid for w in workers}
    # Each folder once, whole, and the one the index names; nothing half-written left.
    folders = sorted(p.name for p in (db / "models").iterdir())
    assert folders == sorted(r.id for r in rows)
    for row in rows:
        assert json.loads((db / row.path / "entry.json").read_text())["key"] == row.key
        assert (db / row.path / "model.glb").is_file()
    again = subprocess.run(command, env=env, capture_output=True, text=True, timeout=300)
    assert f"built 0 (0 valid, 0 invalid, 0 failed), cached {ENTRIES}" in again.stdout
