"""`homemodel db build|list|show|find|remove|export|serve`: the model database."""

from __future__ import annotations

import logging
import os
from pathlib import Path
from typing import TYPE_CHECKING

import typer
from rich.markup import escape

from homemodel.cli.errors import exit_on_error
from homemodel.cli.option_fields import field_option
from homemodel.cli.progress import Column, fitted_table, make_console

if TYPE_CHECKING:
    from rich.console import Console

    from homemodel.app.database import EntryRow

db_app = typer.Typer(no_args_is_help=True)

DB_OPTION = typer.Option(..., "--db", help="the database folder (models/, index.sqlite)")
BUILD = "homemodel.app.database.build:DatabaseBuildOptions"
SERVE = "homemodel.app.database.server:ServeOptions"
STATUS_STYLE = {"valid": "[green]valid[/]", "invalid": "[yellow]invalid[/]", "failed": "[red]failed[/]"}
COLUMNS = [Column("id", keep=True), Column("category", keep=True), Column("source"), Column("status", keep=True)] + [
    Column(h, justify="right") for h in ("links", "joints", "grasps", "triangles", "build s")
]
DROPPED_FIRST = ("links", "triangles", "grasps", "source")


def _number(value: int | None) -> str:
    return "-" if value is None else str(value)


def rows_table(console: Console, title: str, rows: list[EntryRow]):  # noqa: ANN201 (rich Table)
    cells = [
        [r.id, r.category or "-", r.source, STATUS_STYLE.get(r.status, r.status), _number(r.links), _number(r.joints),
         _number(r.grasp_points), _number(r.triangles), f"{r.build_s:.2f}"]
        for r in rows
    ]  # fmt: skip
    return fitted_table(console, title, COLUMNS, cells, DROPPED_FIRST)


def _entry_line(row: EntryRow, cached: bool) -> str:
    said = "cached" if cached else f"{row.build_s:6.2f} s"
    line = f"{STATUS_STYLE.get(row.status, row.status):<22} {escape(row.id)} ({row.source}, {said})"
    if row.status != "valid" and not cached:
        line += f": {escape(row.error or '; '.join(row.failed_checks))}"
    for repair in row.repairs if not cached else []:
        line += f"\n    repaired {escape(repair)}"
    return line


@db_app.command()
def build(
    manifest: Path = typer.Argument(..., help="the manifest: entries, their sources, options, categories"),
    db: Path = DB_OPTION,
    workers: int | None = field_option(
        f"{BUILD}.workers", help="local processes that build: this one and N - 1 worker processes, no Dask (default: one per core)"
    ),
    scheduler: str | None = field_option(f"{BUILD}.scheduler", help="an existing Dask scheduler, e.g. tcp://host:8786: the build runs on its cluster"),
    repair: bool = field_option(f"{BUILD}.repair", help="repair imported assets that lack only inertials or limit effort/velocity"),
    retry_failed: bool = field_option(f"{BUILD}.retry_failed", help="build failed entries again even if unchanged"),
    strict: bool = typer.Option(False, "--strict", help="exit 1 when an entry failed or is invalid"),
) -> None:
    """Build every entry of MANIFEST whose inputs, options or code changed; record failures."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from homemodel.app.database import DatabaseBuildOptions, build_database

    # Dask logs every worker's start and stop at INFO; the build prints its own lines. Set
    # through Dask's configuration, which it reads when (and only if) the build imports it,
    # and on its logger in case it was imported already.
    os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", "error")
    logging.getLogger("distributed").setLevel(logging.ERROR)
    console = make_console()
    options = DatabaseBuildOptions(workers=workers, scheduler=scheduler, repair=repair, retry_failed=retry_failed)
    # 4 redraws a second, not rich's 10: its drawing thread took 5 ms of CPU a second (loaded
    # machine) from a process that builds entries itself.
    with exit_on_error(), Progress(
        TextColumn("[bold]db build[/]"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(), console=console, transient=True,
        refresh_per_second=4,
    ) as bar:  # fmt: skip
        task = bar.add_task("entries", total=None)

        def on_start(todo: int, cached: int, dashboard: str | None) -> None:
            bar.update(task, total=todo)
            console.print(f"{todo} to build, {cached} cached")

        def on_dashboard(link: str) -> None:
            console.print(f"Dask dashboard: {link}")

        def on_entry(row: EntryRow, cached: bool) -> None:
            if not cached:
                console.print(_entry_line(row, cached))
                bar.advance(task)

        result = build_database(manifest, db, options, on_start=on_start, on_entry=on_entry, on_dashboard=on_dashboard)
    counts = {s: result.count(s) for s in ("valid", "invalid", "failed")}
    console.print(
        f"built {len(result.built)} ({counts['valid']} valid, {counts['invalid']} invalid, {counts['failed']} failed), "
        f"cached {len(result.cached)}, in {result.seconds:.1f} s; index: {db / 'index.sqlite'}"
    )
    if strict and (counts["invalid"] or counts["failed"]):
        raise typer.Exit(1)


@db_app.command("list")
def list_entries(db: Path = DB_OPTION) -> None:
    """Every entry: category, source, gate status, counts, build time."""
    from homemodel.app.database import ModelIndex

    console = make_console()
    with exit_on_error(), ModelIndex(db) as index:
        rows = index.rows()
    console.print(rows_table(console, f"{db}: {len(rows)} entries", rows))


@db_app.command()
def show(entry_id: str = typer.Argument(..., metavar="ID"), db: Path = DB_OPTION) -> None:
    """One entry: its figures, the gate's checks, repairs, error and files."""
    from homemodel.app.database import ModelIndex

    with exit_on_error(), ModelIndex(db) as index:
        row = index.require(entry_id)
    typer.echo(f"{row.id}: {row.category} from {row.source}, {row.status}, built {row.built_at} in {row.build_s:.2f} s on {row.worker}")
    typer.echo(f"  key        {row.key[:16]}")
    for role, path in row.inputs.items():
        typer.echo(f"  {role:<10} {path}")
    typer.echo(f"  folder     {db / row.path if row.path else '(not stored)'}")
    typer.echo(f"  counts     links {_number(row.links)}, joints {_number(row.joints)}, grasp points {_number(row.grasp_points)}, triangles {_number(row.triangles)}")
    typer.echo("  times      " + ", ".join(f"{k} {v:.2f} s" for k, v in row.times_s.items()))
    if row.properties:
        typer.echo("  properties " + ", ".join(f"{k}={v}" for k, v in sorted(row.properties.items())))
    for repair in row.repairs:
        typer.echo(f"  repaired   {repair}")
    if row.error:
        typer.echo(f"  error      {row.error}")
    for check in row.checks:
        typer.echo(f"  {'PASS' if check['passed'] else 'FAIL'}  {check['name']}: {check['detail']}")


@db_app.command()
def find(
    db: Path = DB_OPTION,
    category: str | None = typer.Option(None, "--category", help="e.g. cup (any case)"),
    properties: list[str] = typer.Option(
        [], "--property", help="name=value, name!=value or a range such as width_m>=0.7 (<, <=, >, >=); repeatable"
    ),
) -> None:
    """Entries of a category and with given properties: names and text in any case, numbers
    as numbers (width_m=0.80 finds 0.8)."""
    from homemodel.app.database.queries import PropertyCondition, find_entries

    console = make_console()
    with exit_on_error():
        conditions = [PropertyCondition.parse(p) for p in properties]
        rows = find_entries(db, category=category, conditions=conditions)
    console.print(rows_table(console, f"{len(rows)} found", rows))


@db_app.command()
def remove(entry_id: str = typer.Argument(..., metavar="ID"), db: Path = DB_OPTION) -> None:
    """Remove an entry's row and model folder."""
    from homemodel.app.database.queries import remove_entry

    with exit_on_error():
        row = remove_entry(db, entry_id)
    typer.echo(f"removed {row.id} ({row.category}, {row.status})")


@db_app.command()
def export(
    entry_id: str = typer.Argument(..., metavar="ID"),
    db: Path = DB_OPTION,
    out: Path = typer.Option(..., "--out", help="where to copy the model folder"),
    force: bool = typer.Option(False, "--force", help="replace a non-empty output folder"),
) -> None:
    """Copy an entry's model folder (model.urdf, model.glb, meshes/, ...) out of the database."""
    from homemodel.app.database.queries import export_entry

    with exit_on_error():
        export_entry(db, entry_id, out, force=force)
    typer.echo(f"exported {entry_id} to {out}")


@db_app.command()
def serve(
    db: Path = DB_OPTION,
    map_path: Path | None = typer.Option(None, "--map", help="a home's semantic map to show as a tree"),
    host: str = field_option(f"{SERVE}.host", help="address to listen on (::1 for IPv6 loopback)"),
    port: int = field_option(f"{SERVE}.port", help="port (0: any free one)"),
    allow_host: list[str] = field_option(
        f"{SERVE}.allow_hosts", "--allow-host", help="another name (or name:port) browsers may reach this server by (repeatable)"
    ),
    client_timeout_s: float = field_option(f"{SERVE}.client_timeout_s", help="seconds a client has to send a request"),
    max_connections: int = field_option(f"{SERVE}.max_connections", help="connections open at once (idle ones make room)"),
) -> None:
    """Serve a page to browse the database: a table, a 3D view with joint sliders, the gate's
    report, and a home's semantic map. Ctrl-C stops it."""
    from homemodel.app.database.server import ServeOptions, make_server

    options = ServeOptions(
        host=host, port=port, allow_hosts=allow_host, client_timeout_s=client_timeout_s, max_connections=max_connections
    )
    with exit_on_error():
        server = make_server(db, options, map_path=map_path)
    if not options.is_loopback:
        typer.echo(
            f"warning: --host {host} is reachable from other machines; anyone who can reach it can read the "
            "database's models and input paths (there is no login)",
            err=True,
        )
    # Every refused or failed request is one line on stderr (the command line's logging).
    shown = f"[{host.strip('[]')}]" if ":" in host else host
    typer.echo(f"serving {db} at http://{shown}:{server.port}/ (Ctrl-C to stop)")
    try:
        server.serve_forever()
    finally:
        server.close()
