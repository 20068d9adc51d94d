"""Export a scene, or one model, for a simulator: the one entry the commands call.

Every export is a folder written atomically (whole or not at all) with the scene file,
its `meshes/`, and `export_summary.json` (`homemodel.core.export_summary`: format, file,
objects, joints, meshes, seconds).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from articulation.model import Model
from articulation.scene import Scene, single_model_scene
from homemodel.core.atomic import atomic_dir, write_json
from homemodel.core.errors import InputError
from homemodel.core.export_summary import (
    EXPORT_SUMMARY_FILE,
    MODEL_FORMATS,
    SCENE_FORMATS,
    ExportedObject,
    ExportSummary,
    ModelFormat,
)
# URDF has one root: its scene fixes the small objects where the map puts them (glTF has no physics).
FIXED_ONLY_FORMATS: tuple[str, ...] = ("urdf", "glb", "urdf-ros")


def _writer(fmt: str) -> Callable[[Scene, Path], Path]:
    if fmt == "mjcf":
        from homemodel.exchange.mjcf import write_mjcf

        return write_mjcf
    if fmt == "sdf":
        from homemodel.exchange.sdf import write_sdf

        return write_sdf
    if fmt == "usd":
        from homemodel.exchange.usd import write_usd

        return write_usd
    if fmt == "urdf":
        from homemodel.exchange.urdf.scene import write_scene_urdf

        return write_scene_urdf
    if fmt == "glb":
        from homemodel.exchange.urdf.scene import write_scene_glb

        return write_scene_glb
    raise InputError(f"--format {fmt!r}: expected one of {', '.join(SCENE_FORMATS)}")


@dataclass(kw_only=True)
class SimulatorExport:
    out_dir: Path
    file: Path  # the scene file (or the ROS package's URDF)
    summary: ExportSummary


def _write_summary(
    scene: Scene, fmt: str, file: Path, out_dir: Path, seconds: float, package: str | None = None
) -> ExportSummary:
    """`out_dir/export_summary.json` of the export just written there."""
    meshes = out_dir / "meshes"
    summary = ExportSummary(
        format=fmt,
        file=file.relative_to(out_dir).as_posix(),
        package=package,
        objects=[
            ExportedObject(
                id=o.id,
                model=o.model.name,
                free=o.free and fmt not in FIXED_ONLY_FORMATS,
                links=len(o.model.links),
                joints={o.name(j.name): o.position(j.name) for j in o.model.movable_joints},
            )
            for o in scene.objects
        ],
        walls=len(scene.walls),
        floor=scene.floor,
        mesh_files=sum(1 for p in meshes.rglob("*.obj")) if meshes.is_dir() else 0,
        times_s={"export": round(seconds, 3)},
    )
    write_json(out_dir / EXPORT_SUMMARY_FILE, summary.model_dump(mode="json"))
    return summary


def export_scene(
    scene: Scene, out_dir: Path, fmt: str, *, force: bool = False, inputs: Sequence[Path] = ()
) -> SimulatorExport:
    """Write `scene` in `fmt` (one of SCENE_FORMATS) to `out_dir`, atomically; `out_dir` may
    not hold or lie in any of `inputs` (the files the scene was read from)."""
    write = _writer(fmt)
    out_dir = Path(out_dir)
    start = time.perf_counter()
    with atomic_dir(out_dir, force=force, inputs=inputs) as tmp:
        file = write(scene, tmp)
        summary = _write_summary(scene, fmt, file, tmp, time.perf_counter() - start)
    return SimulatorExport(out_dir=out_dir, file=out_dir / file.relative_to(tmp), summary=summary)


def export_model_for(
    model: Model,
    out_dir: Path,
    fmt: ModelFormat,
    *,
    package: str | None = None,
    free: bool = False,
    force: bool = False,
    inputs: Sequence[Path] = (),
) -> SimulatorExport:
    """One model at the origin in `fmt` (one of MODEL_FORMATS): fixed, or `free` on a floor
    (mjcf, sdf, usd); `urdf-ros` writes a ROS 2 package named `package` (default: the model's
    name)."""
    if fmt not in MODEL_FORMATS:
        raise InputError(f"--format {fmt!r}: expected one of {', '.join(MODEL_FORMATS)}")
    if package is not None and fmt != "urdf-ros":
        raise InputError("--package goes with --format urdf-ros")
    if free and fmt in FIXED_ONLY_FORMATS:
        raise InputError(f"--free: a {fmt} model is fixed; use mjcf, sdf or usd for a free body")
    if fmt != "urdf-ros":
        return export_scene(single_model_scene(model, free=free), out_dir, fmt, force=force, inputs=inputs)
    from homemodel.exchange.urdf.ros_package import check_package_name, write_ros_package

    name = check_package_name(package or model.name)
    out_dir = Path(out_dir)
    start = time.perf_counter()
    with atomic_dir(out_dir, force=force, inputs=inputs) as tmp:
        urdf = write_ros_package(model, tmp, name)
        summary = _write_summary(single_model_scene(model), fmt, urdf, tmp, time.perf_counter() - start, package=name)
    return SimulatorExport(out_dir=out_dir, file=out_dir / urdf.relative_to(tmp), summary=summary)
