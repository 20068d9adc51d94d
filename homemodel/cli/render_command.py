"""`homemodel render SPEC --out DIR`: a textured model beside the photos it was textured from."""

from __future__ import annotations

from pathlib import Path

import typer
from rich import box
from rich.table import Table

from homemodel.cli.errors import exit_on_error
from homemodel.cli.progress import make_console, progress_bar


def render(
    spec: Path = typer.Argument(..., help="measurement spec (YAML) with photos: on some faces"),
    out: Path = typer.Option(..., "--out", help="output model folder (model.urdf, model.glb, meshes/, pictures)"),
    force: bool = typer.Option(False, "--force", help="replace a non-empty output folder"),
    height: int = typer.Option(360, "--height", min=64, max=2048, help="height of each picture panel, pixels"),
) -> None:
    """Build a spec's photo-textured model, validate it, and render it beside each photo."""
    from modeller.comparison_picture import PictureOptions, render_spec

    console = make_console()
    with exit_on_error():
        with progress_bar(console, "render") as progress:
            result = render_spec(
                spec,
                out,
                force=force,
                options=PictureOptions(panel_height_px=height),
                progress=progress,
            )
    table = Table(title=f"homemodel render {spec}", box=box.SIMPLE_HEAD)
    for column in ("photo", "part", "face", "texture px", "texture KB", "focal px", "corner error px", "picture"):
        table.add_column(column, justify="right" if column.endswith(("px", "KB")) else "left")
    for row in result.rows:
        table.add_row(
            Path(row.photo).name,
            row.part,
            row.face,
            f"{row.texture_px[0]}x{row.texture_px[1]}",
            f"{row.texture_kb:.0f}",
            f"{row.focal_px:.0f}",
            f"{row.reprojection_px:.2f}",
            row.picture,
        )
    console.print(table)
    times = "  ".join(f"{stage.removesuffix('_s')} {seconds:.2f} s" for stage, seconds in result.times_s.items())
    console.print(f"{times}\nvalid: {'[green]yes[/]' if result.valid else '[red]NO[/]'}")
    for failure in result.failed_checks:
        console.print(f"[red]{failure}[/]")
    console.print(f"model and pictures: {result.out_dir}")
    if not result.valid:
        raise typer.Exit(1)
