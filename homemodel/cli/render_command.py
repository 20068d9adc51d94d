"""`homemodel render SPEC --out DIR`: a textured model beside the photos it was textured from."""

from __future__ import annotations

from pathlib import Path

from typing import TYPE_CHECKING

import typer
from rich.console import Console
from rich.table import Table

from homemodel.cli.errors import exit_on_error
from homemodel.cli.option_fields import field_option
from homemodel.cli.progress import Column, fitted_table, make_console, progress_bar

if TYPE_CHECKING:
    from modeller.comparison_picture import PictureRow

COLUMNS = [Column("photo", keep=True), Column("part", keep=True), Column("face", keep=True)] + [
    Column(header, justify="right") for header in ("texture px", "texture KB", "focal px", "corner error px")
] + [Column("picture", keep=True)]
# Narrow terminals lose these first; names are never cut.
DROPPED_FIRST = ("texture KB", "texture px", "focal px")


def pictures_table(console: Console, title: str, rows: list[PictureRow]) -> Table:
    """One row per photo: where it went, its texture, the camera recovered for it, its picture."""
    cells = [
        [
            Path(row.photo).name,
            row.part,
            row.face,
            f"{row.texture_px[0]}x{row.texture_px[1]}",
            f"{row.texture_kb:.0f}",
            f"{row.focal_px:.0f}",
            f"{row.reprojection_px:.2f}",
            row.picture,
        ]
        for row in rows
    ]
    return fitted_table(console, title, COLUMNS, cells, DROPPED_FIRST)


def render(
    spec: Path = typer.Argument(..., help="measurement spec (YAML) with photos: on some faces"),
    out: Path = typer.Option(..., "--out", help="output model folder (model.urdf, model.glb, meshes/, pictures)"),
    force: bool = typer.Option(False, "--force", help="replace a non-empty output folder"),
    height: int = field_option(
        "modeller.comparison_picture:PictureOptions.panel_height_px",
        "--height",
        min=64,
        max=2048,
        help="height of each picture panel, pixels",
    ),
) -> None:
    """Build a spec's photo-textured model, validate it, and render it beside each photo."""
    from modeller import BuildOptions
    from modeller import build as run
    from modeller.comparison_picture import PictureOptions

    console = make_console()
    options = BuildOptions(pictures=PictureOptions(panel_height_px=height))
    with exit_on_error():
        with progress_bar(console, "render") as progress:
            result = run(spec, out, options, progress=progress, force=force)
    console.print(pictures_table(console, f"homemodel render {spec}", result.pictures))
    times = "  ".join(f"{stage} {seconds:.2f} s" for stage, seconds in result.times_s.items())
    console.print(f"{times}\nvalid: {'[green]yes[/]' if result.valid else '[red]NO[/]'}")
    for failure in result.failed_checks:
        console.print(f"[red]{failure}[/]")
    console.print(f"model and pictures: {result.out_dir}")
    if not result.valid:
        raise typer.Exit(1)
