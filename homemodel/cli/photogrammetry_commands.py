"""`homemodel photogrammetry reconstruct PHOTOS_DIR --out DIR`: photos to a textured, metric,
cleaned mesh through COLMAP on the CPU (D3.1 section 3.3.3, without 123D Catch's server)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import typer

from homemodel.cli.errors import exit_on_error
from homemodel.cli.map_flags import (
    ID_OPTION,
    MAP_OPTION,
    PARENT_OPTION,
    XYZ_OPTION,
    echo_registration,
    map_entry_from_flags,
)
from homemodel.cli.option_fields import field_option, from_options
from homemodel.cli.progress import figures_table, make_console, stage_bars

if TYPE_CHECKING:
    from homemodel.core.model_summary import ModelSummary

photogrammetry_app = typer.Typer(no_args_is_help=True)

OPTIONS = "photogrammetry.pipeline:ReconstructOptions"


def _summary_rows(summary: ModelSummary) -> list[tuple[str, str]]:
    """The figures table: the pipeline's own figures, then the size, mass and times of the
    model folder as summary.json records them."""
    figures = summary.photogrammetry
    scaled = summary.metric
    unit = "mm" if scaled else "units"
    factor = 1000 if scaled else 1
    extents = summary.extents_m if scaled else figures.extents_sfm_units
    rows = [
        ("photos registered", f"{figures.registered} of {figures.photos}"),
        ("matching", f"{figures.matching}, {figures.cameras} camera model(s)"),
        ("SIFT features per photo (median)", str(figures.features_per_photo)),
        ("sparse points", str(figures.sparse_points)),
        ("reprojection error", f"{figures.reprojection_error_px:.3f} px"),
        ("dense method", f"{figures.dense_method}, views of {figures.dense_image_px} px"),
        ("dense points (fused)", str(figures.dense_points)),
        ("object points", str(figures.object_points)),
        ("support plane points removed", str(figures.support_plane_points_removed)),
        ("free-space points removed", str(figures.free_space_points_removed)),
        ("scale", f"markers {figures.markers}" if scaled else "[yellow]unscaled (no markers)[/]"),
        ("levelled (z up from support)", "yes" if figures.levelled else "[yellow]no[/]"),
        ("size x y z", " x ".join(f"{e * factor:.1f}" for e in extents) + f" {unit}"),
        ("mesh", f"{figures.faces} faces, {'watertight' if figures.watertight else 'not watertight'}"),
        ("texture", f"{figures.texture_px} px, {figures.texture_covered_share * 100:.0f}% seen"),
        ("mass", f"{summary.mass_kg:.3f} kg" if scaled else "n/a (unscaled)"),
    ]
    return rows + [(f"time {stage}", f"{seconds:.1f} s") for stage, seconds in summary.times_s.items()]


@photogrammetry_app.command()
@from_options
def reconstruct(
    photos_dir: Path = typer.Argument(..., help="folder of photos (JPEG, PNG, TIFF, BMP) taken around the object"),
    out: Path = typer.Option(..., "--out", help="model folder to write"),
    marker_size_m: float | None = field_option(
        f"{OPTIONS}.marker_size_m", help="edge of the markers' black square (m); without it the model is unscaled"
    ),
    dictionary: str = field_option(f"{OPTIONS}.dictionary", help="marker family"),
    name: str = field_option(f"{OPTIONS}.name", help="model name"),
    density_kg_m3: float = field_option(f"{OPTIONS}.density_kg_m3", help="density for the inertial (kg/m^3)"),
    matching: str = field_option(
        f"{OPTIONS}.sfm.matching",
        help="auto: preemptive up to 120 photos (every pair tried on its 100 largest features, any order; "
        "each photo matched in full with up to 10 partners sharing 3 or more, and at least its 8 best), "
        "image retrieval beyond",
    ),
    max_features: int = field_option(f"{OPTIONS}.sfm.max_num_features", "--max-features", help="SIFT features per photo"),
    sfm_image_px: int = field_option(
        f"{OPTIONS}.sfm.max_image_size_px", "--sfm-image-px", help="longer side photos are shrunk to for SfM"
    ),
    first_octave: int | None = field_option(
        f"{OPTIONS}.sfm.first_octave", "--first-octave",
        help="SIFT's first octave: -1 doubles the photos first (finds small features at 4x the cost), 0 takes "
        "them as they are (default: -1 on photos under 1200 px)",
    ),
    depth_image_px: int | None = field_option(
        f"{OPTIONS}.dense.max_image_size_px", "--depth-image-px",
        help="longer side of the depth maps (default: from the photos' focal length, size and count)",
    ),
    texture_size_px: int = field_option(
        f"{OPTIONS}.texture.size_px", "--texture-size-px", old=("--texture-px",), help="texture atlas size"
    ),
    max_faces: int = field_option(f"{OPTIONS}.max_faces", help="faces of the final mesh"),
    picture: bool = field_option(f"{OPTIONS}.picture", help="also write cameras.png: the cameras around the mesh"),
    map_path: Path | None = MAP_OPTION,
    parent: str | None = PARENT_OPTION,
    object_id: str | None = ID_OPTION,
    xyz: tuple[float, float, float] = XYZ_OPTION,
    force: bool = typer.Option(False, "--force", help="replace a non-empty output folder"),
    verbose: bool = field_option(
        f"{OPTIONS}.sfm.verbose", help="show COLMAP's log and the image libraries' warnings"
    ),
) -> None:
    """Reconstruct a textured, cleaned mesh from photos; metric and levelled when markers are seen."""
    from photogrammetry import ReconstructOptions
    from photogrammetry import reconstruct as run
    from photogrammetry.sfm import SfmOptions
    from photogrammetry.stereo import DenseOptions
    from photogrammetry.texturing import TextureBakingOptions

    console = make_console()
    with exit_on_error():
        map_entry = map_entry_from_flags(map_path, parent, object_id or name, xyz)
        options = ReconstructOptions(
            sfm=SfmOptions(max_image_size_px=sfm_image_px, max_num_features=max_features, matching=matching,
                          first_octave=first_octave, verbose=verbose),  # fmt: skip
            dense=DenseOptions(max_image_size_px=depth_image_px),
            texture=TextureBakingOptions(size_px=texture_size_px),
            marker_size_m=marker_size_m,
            dictionary=dictionary,
            max_faces=max_faces,
            name=name,
            density_kg_m3=density_kg_m3,
            picture=picture,
            map_entry=map_entry,
        )
        with stage_bars(console) as progress:
            result = run(photos_dir, out, options, progress=progress, force=force)
    console.print(figures_table(f"homemodel photogrammetry reconstruct {photos_dir}", _summary_rows(result.summary)))
    if result.figures["unregistered"]:
        console.print(f"[yellow]not registered[/]: {', '.join(result.figures['unregistered'])}")
    console.print(f"model: {out / 'model.urdf'}, {out / 'model.glb'}  summary: {out / 'summary.json'}")
    if result.registration is not None:
        echo_registration(result.registration)
