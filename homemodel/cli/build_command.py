"""`homemodel build EXAMPLE_DIR --out DIR`: every spec of a home, validated, plus its map."""

from __future__ import annotations

from pathlib import Path

from typing import TYPE_CHECKING

import typer
from rich.console import Console
from rich.table import Table

from homemodel.cli.errors import exit_on_error
from homemodel.cli.progress import Column, fitted_table, make_console, progress_bar

if TYPE_CHECKING:
    from homemodel.core.home_summary import ObjectRow

COLUMNS = [Column("object", keep=True), Column("kind", keep=True), Column("parent", keep=True)] + [
    Column(header, justify="right") for header in ("links", "joints", "grasps", "triangles", "build s", "check s")
] + [Column("valid")]
# Narrow terminals lose these first; ids and kinds are never cut.
DROPPED_FIRST = ("triangles", "links", "check s", "build s")


def build_table(console: Console, title: str, rows: list[ObjectRow]) -> Table:
    """One row per object: its id, kind and parent, its parts, its times (building and
    exporting; the gate's checks), and whether it is valid."""
    cells = [
        [
            row.id,
            row.category,
            row.parent,
            str(row.links),
            str(row.joints),
            str(row.grasp_points),
            str(row.triangles),
            f"{row.times_s['build'] + row.times_s['export']:.2f}",
            f"{row.times_s['validate']:.2f}",
            "[green]yes[/]" if row.valid else "[red]NO[/]",
        ]
        for row in rows
    ]
    return fitted_table(console, title, COLUMNS, cells, DROPPED_FIRST)


def build(
    example_dir: Path = typer.Argument(..., help="folder with home.yaml and the measurement specs"),
    out: Path = typer.Option(..., "--out", help="output folder (models/, map.xml, home_summary.json)"),
    force: bool = typer.Option(False, "--force", help="replace a non-empty output folder"),
) -> None:
    """Build every object of a home from its measurements, validate each model, write the map."""
    from homemodel.app.home.build import build_home

    console = make_console()
    with exit_on_error():
        with progress_bar(console, "building") as progress:
            result = build_home(
                example_dir,
                out,
                force=force,
                progress=progress,
            )
    console.print(build_table(console, f"homemodel build {example_dir}", result.rows))
    for row in result.rows:
        for failure in row.failed_checks:
            console.print(f"[red]{row.id}[/]: {failure}")
        for warning in row.warnings:
            console.print(f"[yellow]{row.id}[/]: warning: {warning}")
    cached = [row.id for row in result.rows if row.cached]
    if cached:
        console.print(f"reused unchanged from the earlier output: {', '.join(cached)}")
    console.print(f"models: {result.out_dir / 'models'}\nmap:    {result.map_path}")
    if not result.ok:
        raise typer.Exit(1)
