"""`homemodel photogrammetry reconstruct PHOTOS_DIR --out DIR`: photos to a textured, metric,
cleaned mesh through COLMAP on the CPU (D3.1 section 3.3.3, without 123D Catch's server)."""

from __future__ import annotations

import enum
from pathlib import Path

import typer
from rich import box
from rich.table import Table

from homemodel.cli.errors import exit_on_error
from homemodel.cli.progress import make_console, stage_bars

photogrammetry_app = typer.Typer(no_args_is_help=True)


class MatchingChoice(str, enum.Enum):
    auto = "auto"
    exhaustive = "exhaustive"
    sequential = "sequential"


class DictionaryChoice(str, enum.Enum):
    apriltag_36h11 = "apriltag_36h11"
    apriltag_25h9 = "apriltag_25h9"
    d4x4_50 = "4x4_50"
    d4x4_250 = "4x4_250"
    d5x5_100 = "5x5_100"
    d5x5_250 = "5x5_250"
    d6x6_250 = "6x6_250"


def _summary_table(title: str, summary: dict) -> Table:
    table = Table(title=title, box=box.SIMPLE_HEAD)
    table.add_column("figure")
    table.add_column("value", justify="right")
    scaled = summary["scaled"]
    unit = "mm" if scaled else "units"
    factor = 1000 if scaled else 1
    rows = [
        ("photos registered", f"{summary['registered']} of {summary['photos']}"),
        ("sparse points", str(summary["sparse_points"])),
        ("reprojection error", f"{summary['reprojection_error_px']:.3f} px"),
        ("dense method", summary["dense_method"]),
        ("dense points (fused)", str(summary["dense_points"])),
        ("object points", str(summary["object_points"])),
        ("support plane points removed", str(summary["support_plane_points_removed"])),
        ("free-space points removed", str(summary["free_space_points_removed"])),
        ("scale", f"markers {summary['markers']}" if scaled else "[yellow]unscaled (no markers)[/]"),
        ("levelled (z up from support)", "yes" if summary["levelled"] else "[yellow]no[/]"),
        ("size x y z", " x ".join(f"{e * factor:.1f}" for e in summary["extents"]) + f" {unit}"),
        ("mesh", f"{summary['faces']} faces, {'watertight' if summary['watertight'] else 'not watertight'}"),
        ("texture", f"{summary['texture_px']} px, {summary['texture_covered_share'] * 100:.0f}% seen"),
        ("mass", f"{summary['mass_kg']:.3f} kg" if scaled else "n/a (unscaled)"),
    ]
    rows += [(f"time {stage}", f"{seconds:.1f} s") for stage, seconds in summary["times_s"].items()]
    for name, value in rows:
        table.add_row(name, value)
    return table


@photogrammetry_app.command()
def reconstruct(
    photos_dir: Path = typer.Argument(..., help="folder of photos (JPEG, PNG, TIFF, BMP) taken around the object"),
    out: Path = typer.Option(..., "--out", help="model folder to write"),
    marker_size_m: float | None = typer.Option(
        None, "--marker-size-m", help="edge of the markers' black square (m); without it the model is unscaled"
    ),
    dictionary: DictionaryChoice = typer.Option(DictionaryChoice.apriltag_36h11, "--dictionary", help="marker family"),
    name: str = typer.Option("object", "--name", help="model name"),
    density_kg_m3: float = typer.Option(500.0, "--density-kg-m3", help="density for the inertial (kg/m^3)"),
    matching: MatchingChoice = typer.Option(
        MatchingChoice.auto, "--matching", help="auto: exhaustive up to 60 photos, sequential (by name) beyond"
    ),
    max_features: int = typer.Option(4096, "--max-features", help="SIFT features per photo"),
    sfm_image_px: int = typer.Option(1600, "--sfm-image-px", help="longer side photos are shrunk to for SfM"),
    depth_image_px: int = typer.Option(800, "--depth-image-px", help="longer side of the depth maps"),
    texture_px: int = typer.Option(2048, "--texture-px", help="texture atlas size"),
    max_faces: int = typer.Option(40_000, "--max-faces", help="faces of the final mesh"),
    picture: bool = typer.Option(False, "--picture", help="also write cameras.png: the cameras around the mesh"),
    map_path: Path | None = typer.Option(None, "--map", help="register the model into this semantic map (MAP.xml)"),
    parent: str | None = typer.Option(None, "--parent", help="with --map: a room, or the large object it stands on"),
    object_id: str | None = typer.Option(None, "--id", help="with --map: the object's id (default: --name)"),
    xyz: tuple[float, float, float] = typer.Option(
        (0.0, 0.0, 0.0), "--xyz", help="with --map: position in the parent (m)"
    ),
    force: bool = typer.Option(False, "--force", help="replace a non-empty output folder"),
) -> None:
    """Reconstruct a textured, cleaned mesh from photos; metric and levelled when markers are seen."""
    from articulation.naming import file_stem
    from homemodel.core.atomic import atomic_dir
    from homemodel.core.errors import InputError
    from photogrammetry.cleaning import CleaningOptions
    from photogrammetry.pipeline import (
        ReconstructOptions,
        temporary_work_dir,
        write_reconstruction,
    )
    from photogrammetry.pipeline import reconstruct as run
    from photogrammetry.sfm import SfmOptions
    from photogrammetry.stereo import DenseOptions
    from photogrammetry.texturing import TextureBakingOptions

    console = make_console()
    with exit_on_error():
        if (map_path is None) != (parent is None):
            raise InputError("--map and --parent go together")
        for option, value, low in (
            ("--max-features", max_features, 256), ("--sfm-image-px", sfm_image_px, 200),
            ("--depth-image-px", depth_image_px, 100), ("--texture-px", texture_px, 64),
        ):  # fmt: skip
            if value < low:
                raise InputError(f"{option} must be at least {low}, got {value}")
        if not (density_kg_m3 > 0 and density_kg_m3 < 1e5):
            raise InputError(f"--density-kg-m3 must be positive and plausible, got {density_kg_m3}")
        if file_stem(name) != name:
            raise InputError(f"--name {name!r}: use letters, digits and underscores")
        if map_path is not None:
            if marker_size_m is None:
                raise InputError("--map needs a metric model: give --marker-size-m and photograph markers")
            from semantic_map import load_map

            load_map(map_path).node(parent)  # a bad map or parent fails now, not after the reconstruction
        options = ReconstructOptions(
            sfm=SfmOptions(max_image_size_px=sfm_image_px, max_num_features=max_features, matching=matching.value),
            dense=DenseOptions(max_image_size_px=depth_image_px),
            cleaning=CleaningOptions(),
            texture=TextureBakingOptions(size_px=texture_px),
            marker_size_m=marker_size_m,
            dictionary=dictionary.value,
            max_faces=max_faces,
        )
        with stage_bars(console) as progress:
            with temporary_work_dir() as work, atomic_dir(out, force=force, inputs=[photos_dir]) as tmp:
                result = run(photos_dir, options, progress, work_dir=Path(work))
                summary = write_reconstruction(result, tmp, name=name, density_kg_m3=density_kg_m3)
                if picture:
                    from photogrammetry.picture import draw_cameras

                    draw_cameras(
                        result.mesh, result.views, tmp / "cameras.png", title=f"{name}: {len(result.views)} cameras"
                    )
    console.print(_summary_table(f"homemodel photogrammetry reconstruct {photos_dir}", summary))
    if summary["unregistered"]:
        console.print(f"[yellow]not registered[/]: {', '.join(summary['unregistered'])}")
    console.print(f"model: {out / 'model.urdf'}, {out / 'model.glb'}  summary: {out / 'summary.json'}")
    if map_path is not None:
        from homemodel.cli.map_commands import add

        add(
            map_path=map_path, model_dir=out, object_id=object_id or name, parent_id=parent, relation=None,
            xyz=xyz, rpy=(0.0, 0.0, 0.0), parking=[], properties=[], graspable=None, out=None, force=False,
        )  # fmt: skip
