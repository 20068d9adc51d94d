"""Build one database entry, in a worker: its pipeline (through the pipeline's entry
function), the validation gate and a thumbnail, stored whole under `DIR/models/<id>/` or not
at all. Any failure is caught and returned as a "failed" row: one bad entry never stops a build.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import copy
import dataclasses
import functools
import json
import logging
import os
import socket
import tempfile
import time
import traceback
from dataclasses import asdict, dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from homemodel.model_folder.gate.report import Check, ValidationReport
from articulation.model import Model
from homemodel.app.database.index import MODELS_DIR, EntryRow
from homemodel.app.database.manifest import Job, RepairSpec
from homemodel.app.database.build_request import BuildRequest
from homemodel.app.database.thumbnail import thumbnail_png
from homemodel.core.atomic import atomic_dir
from homemodel.core.c_stdio_capture import captured_c_output
from homemodel.core.errors import HomemodelError, SpecError
from homemodel.core.model_summary import read_summary
from homemodel.core.options_data import options_from_dict
from homemodel.core.yaml_specs import read_yaml_mapping, write_yaml

log = logging.getLogger(__name__)

ENTRY_FILE = "entry.json"
THUMBNAIL_FILE = "thumbnail.png"
FSYNC_THREADS = 3  # an entry's records: its thumbnail, entry.json and (a sweep's) spec.yaml


@dataclass(kw_only=True)
class _Built:
    report: ValidationReport
    times_s: dict[str, float]
    repairs: list[str]
    model: Model | None = None  # in memory when the pipeline hands it over (else read back from the URDF)
    records: dict[str, bytes] = field(default_factory=dict)  # files stored beside the model (file name: bytes)


def _options(cls: type, job: Job, **fixed: Any) -> Any:
    """The source's options from the manifest's `options` (nested fields included), with the
    fields the entry decides set over them; a fixed field given as None leaves the options'
    own value (an absent top-level `marker_size_m` must not erase the options')."""
    options = options_from_dict(cls, job.options, where=f"entry {job.id!r}: options")
    return dataclasses.replace(options, **{name: value for name, value in fixed.items() if value is not None})


@functools.lru_cache(maxsize=64)
def _spec_mapping(spec_path: Path, size: int, mtime_ns: int) -> dict:
    """A swept spec's file, parsed once per worker while it is unchanged (a sweep's entries
    share it; parsing it again was a good part of what an entry cost beyond its build)."""
    return read_yaml_mapping(spec_path)


def _swept_spec(job: Job, folder: Path) -> Path:
    """The spec with the sweep's values set, written into `folder` (photo paths made absolute)."""
    spec_path = job.inputs["path"]
    stat = spec_path.stat()
    data = copy.deepcopy(_spec_mapping(spec_path, stat.st_size, stat.st_mtime_ns))
    for name in job.overrides:
        if name not in data and name not in _spec_fields(spec_path):
            raise SpecError(f"{spec_path}: sweep field {name!r} is not a field of this spec")
    data.update(job.overrides)
    for photo in data.get("photos") or []:
        if isinstance(photo, dict) and "photo" in photo:
            photo["photo"] = str((spec_path.parent / photo["photo"]).resolve())
    path = folder / f"{job.id}.yaml"
    write_yaml(path, data)
    return path


def _spec_fields(spec_path: Path) -> set[str]:
    from modeller import load_spec

    return set(type(load_spec(spec_path)).model_fields)


def _build_spec(job: Job, out: Path) -> _Built:
    from modeller import BuildOptions, build

    with tempfile.TemporaryDirectory(prefix="homemodel-sweep-") as work:
        spec = _swept_spec(job, Path(work)) if job.overrides else job.inputs["path"]
        try:
            built = build(spec, out, _options(BuildOptions, job, name=job.id), force=True)
        except SpecError as exc:
            if not job.overrides:
                raise
            # Name the user's spec and the swept values, not the temporary file.
            said = str(exc).replace(str(spec), f"{job.inputs['path']} with {job.overrides}")
            raise SpecError(said) from None
        records = {"spec.yaml": Path(spec).read_bytes()} if job.overrides else {}  # what was built, for the record
    return _Built(report=built.validation, times_s=dict(built.times_s), repairs=[], model=built.model, records=records)


def _written(out: Path, repairs: list[str] | None = None) -> _Built:
    """What the pipeline's model folder says of itself: the gate ran when it was written."""
    from homemodel.model_folder.write import report_from_summary

    summary = read_summary(out)
    return _Built(report=report_from_summary(summary, out), times_s=dict(summary.times_s), repairs=repairs or [])


def _build_turntable(job: Job, out: Path) -> _Built:
    from turntable.reconstruct import reconstruct
    from turntable.reconstruction import ReconstructOptions

    reconstruct(job.inputs["path"], out, _options(ReconstructOptions, job, name=job.id, workers=1), force=True)
    return _written(out)


def _build_photos(job: Job, out: Path) -> _Built:
    from photogrammetry import ReconstructOptions, reconstruct

    options = _options(ReconstructOptions, job, name=job.id, marker_size_m=job.marker_size_m)
    reconstruct(job.inputs["path"], out, options, force=True)
    return _written(out)


def _build_completion(job: Job, out: Path) -> _Built:
    from shape_completion import CompletionOptions, complete

    options = _options(CompletionOptions, job, name=job.id, camera_path=job.inputs["camera"])
    complete(job.inputs["completion_model"], job.inputs["path"], out, options, force=True)
    return _written(out)


def _build_import(job: Job, out: Path, repair: RepairSpec | None) -> _Built:
    from homemodel.model_folder.asset_import import ImportOptions, import_model_folder
    from homemodel.model_folder.gate import validate_path
    from homemodel.model_folder.repair import RepairOptions

    start = time.perf_counter()
    options = _options(ImportOptions, job)
    repair_options = RepairOptions(**repair.model_dump()) if repair is not None else None
    done = import_model_folder(job.inputs["path"], out, name=job.id, options=options, repair_options=repair_options, force=True)
    if done.folder is None:
        # The asset as given fails the gate for want of what it needs: say so, and how to repair.
        imported = done.imported
        report = validate_path(imported.urdf, package_paths=options.package_paths) if imported.urdf is not None else ValidationReport(path=job.inputs["path"])
        said = "; ".join(imported.gaps.describe()) + " (rerun with --repair, or set `repair: true` on the entry)"
        report.checks.insert(0, Check("repairable", False, said))
        return _Built(report=report, times_s={"validate": time.perf_counter() - start}, repairs=[])
    written = done.folder
    return _Built(report=written.validation, times_s=dict(written.summary.times_s), repairs=done.repairs, model=written.model)


def _run_source(request: BuildRequest, out: Path) -> _Built:
    job = request.job
    if job.source == "spec":
        return _build_spec(job, out)
    if job.source == "turntable":
        return _build_turntable(job, out)
    if job.source == "photos":
        return _build_photos(job, out)
    if job.source == "completion":
        return _build_completion(job, out)
    return _build_import(job, out, request.repair)


def _counts(model: Model) -> dict[str, int]:
    return {
        "links": len(model.links),
        "joints": len(model.movable_joints),
        "grasp_points": len(model.grasp_points),
        "triangles": sum(len(v.mesh.faces) for link in model.links for v in link.visuals),
    }


def _worker_name() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


def build_entry(request: BuildRequest, c_output_fds: tuple[int, ...] = (1, 2)) -> EntryRow:
    """Build `request.job` into `db_dir/models/<id>/` (replacing what was there only when the
    new folder is whole) and return its index row; never raises for a bad entry. What C code
    prints to `c_output_fds` meanwhile is logged at debug level, not shown."""
    from homemodel.exchange.urdf.read import load_urdf
    from homemodel.app.database.blender_exit import note_blender_thread

    job = request.job
    start = time.perf_counter()
    row = EntryRow(
        id=job.id,
        category=job.category or "",
        source=job.source,
        key=request.key,
        status="failed",
        inputs={role: str(path) for role, path in job.inputs.items()},
        properties=dict(job.properties),
        worker=_worker_name(),
    )
    final = Path(request.db_dir) / MODELS_DIR / job.id
    try:
        with atomic_dir(final, force=True) as tmp:
            # COLMAP, Blender and pybullet print from C; in a worker that would bury the build's lines.
            with captured_c_output(c_output_fds) as said:
                built = _run_source(request, tmp)
            log.debug("entry %s printed:\n%s", job.id, "\n".join(said[-50:]))
            built.report.path = final  # where the model will be, not the temporary folder
            row.checks = [{"name": c.name, "passed": c.passed, "detail": c.detail} for c in built.report.checks]
            row.repairs = built.repairs
            row.times_s = {stage: round(s, 4) for stage, s in built.times_s.items()}
            if not (tmp / "model.urdf").is_file():
                # The gate refused the asset as given (an import without --repair): nothing to store.
                row.status = "invalid"
                raise _NothingToStore
            model = built.model or load_urdf(tmp / "model.urdf")
            row.category = job.category or model.category
            row.properties = {**model.properties, **job.properties}
            for name, value in _counts(model).items():
                setattr(row, name, value)
            thumb_start = time.perf_counter()
            thumbnail = thumbnail_png(model)
            row.times_s["thumbnail"] = round(time.perf_counter() - thumb_start, 4)
            row.status = "valid" if built.report.ok else "invalid"
            row.path = f"{MODELS_DIR}/{job.id}"
            row.thumbnail = f"{MODELS_DIR}/{job.id}/{THUMBNAIL_FILE}"
            row.build_s = round(time.perf_counter() - start, 4)
            row.built_at = datetime.now(timezone.utc).isoformat(timespec="seconds")
            record = json.dumps({**asdict(row), "validation": built.report.format()}, indent=2) + "\n"
            _store_together(tmp, {**built.records, THUMBNAIL_FILE: thumbnail, ENTRY_FILE: record.encode()})
    except _NothingToStore:
        row.error = "; ".join(row.failed_checks) or "not stored"
    except Exception as exc:  # noqa: BLE001 (a bad entry is recorded, whatever it raised)
        log.debug("entry %s failed:\n%s", job.id, traceback.format_exc())
        row.status = "failed"
        # Our own errors say what is wrong; anything else is named by its type too.
        said = " ".join(str(exc).split())
        row.error = said if isinstance(exc, HomemodelError) else f"{type(exc).__name__}: {said}"
        row.path = row.thumbnail = None
    note_blender_thread()  # a worker that ran bpy must end without Python's module teardown
    row.build_s = round(time.perf_counter() - start, 4)
    row.built_at = row.built_at or datetime.now(timezone.utc).isoformat(timespec="seconds")
    return row


def _store_together(folder: Path, files: dict[str, bytes]) -> None:
    """Write `files` into `folder`, an atomic folder not yet in place (its rename publishes
    them whole, so no temporary file each), and flush them to disk at once before that rename:
    the file system's journal takes fsyncs made together in one commit (two files: 4.7 ms
    against 11.6 one after the other on the loaded development disk; the entry's process
    waits for them, its core idle)."""
    with contextlib.ExitStack() as stack:
        handles = [stack.enter_context(open(folder / name, "xb")) for name in files]
        for handle, data in zip(handles, files.values()):
            handle.write(data)
            handle.flush()
        syncs = [_fsync_pool().submit(os.fsync, handle.fileno()) for handle in handles]
        concurrent.futures.wait(syncs)  # all of them, before their files close
        for sync in syncs:
            sync.result()  # raises what an fsync raised


@functools.cache
def _fsync_pool() -> concurrent.futures.ThreadPoolExecutor:
    """The threads that flush an entry's records, kept for the process's life: starting three
    threads an entry cost it 1-2 ms of CPU."""
    return concurrent.futures.ThreadPoolExecutor(FSYNC_THREADS, thread_name_prefix="homemodel-db-fsync")


class _NothingToStore(Exception):
    """Leaves the atomic folder without storing it (its contents are not a model)."""
