"""`homemodel build EXAMPLE_DIR --out DIR`: every spec of a home, validated, plus its map."""

from __future__ import annotations

from pathlib import Path

import typer
from rich import box
from rich.table import Table

from homemodel.cli.errors import exit_on_error
from homemodel.cli.progress import make_console, progress_bar


def build(
    example_dir: Path = typer.Argument(..., help="folder with home.yaml and the measurement specs"),
    out: Path = typer.Option(..., "--out", help="output folder (models/, map.xml, summary.json)"),
    force: bool = typer.Option(False, "--force", help="replace a non-empty output folder"),
) -> None:
    """Build every object of a home from its measurements, validate each model, write the map."""
    from homemodel.app.home_build import build_home

    console = make_console()
    with exit_on_error():
        with progress_bar(console, "building") as progress:
            result = build_home(
                example_dir,
                out,
                force=force,
                progress=progress,
            )
    table = Table(title=f"homemodel build {example_dir}", box=box.SIMPLE_HEAD)
    for column in ("object", "kind", "parent"):
        table.add_column(column)
    for column in ("links", "joints", "grasps", "triangles", "build s", "check s"):
        table.add_column(column, justify="right")
    table.add_column("valid")
    for row in result.rows:
        table.add_row(
            row.id,
            row.category,
            row.parent,
            str(row.links),
            str(row.joints),
            str(row.grasp_points),
            str(row.triangles),
            f"{row.build_s:.2f}",
            f"{row.validate_s:.2f}",
            "[green]yes[/]" if row.valid else "[red]NO[/]",
        )
    console.print(table)
    for row in result.rows:
        for failure in row.failed_checks:
            console.print(f"[red]{row.id}[/]: {failure}")
    console.print(f"models: {result.out_dir / 'models'}\nmap:    {result.map_path}")
    if not result.ok:
        raise typer.Exit(1)
