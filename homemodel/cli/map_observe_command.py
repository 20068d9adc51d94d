"""`homemodel map observe MAP.xml OBS_DIR --out NEW_MAP.xml [--report REPORT.json]`: the map
updated by one depth image from the robot's camera (joint states, small objects' poses)."""

from __future__ import annotations

from pathlib import Path

import typer

from homemodel.cli.errors import exit_on_error
from homemodel.cli.map_commands import MAP_ARGUMENT, map_app


@map_app.command("observe")
def observe_command(
    map_path: Path = MAP_ARGUMENT,
    obs_dir: Path = typer.Argument(..., metavar="OBS_DIR", help="observation folder: depth.png (16-bit), camera.yaml (intrinsics and map_from_camera, the camera's 4x4 pose in the map), optional color.png"),
    out: Path = typer.Option(..., "--out", help="the updated map file (NEW_MAP.xml)"),
    report: Path | None = typer.Option(None, "--report", help="write what was seen, per object in view, as JSON here"),
) -> None:
    """Fit the map's models to one depth image; write the map with the joints and small objects it saw."""
    from homemodel.cli.progress import Column, fitted_table, make_console, stage_bars  # rich: not for `map find`
    from tracking import observe, write_observed

    console = make_console()
    with exit_on_error():
        _check_not_folders({"--out": (out, "kitchen_now.xml"), "--report": (report, "seen.json")})
        _check_report_replaces_no_map(report, {"MAP.xml": map_path, "--out": out})
        with stage_bars(console) as progress:
            result = observe(map_path, obs_dir, progress=progress)
        write_observed(result, map_path, out, report)
    if result.report.nothing_seen:
        typer.echo(f"nothing seen: {obs_dir} holds no depth reading; {out} is the map unchanged")
        return
    columns = [Column("object", keep=True), Column("what", keep=True), Column("estimate"), Column("support", justify="right")]
    # Large objects: simulate-view counts the small ones too, and they are rows under their parent here.
    count = len(result.report.objects)
    title = f"{count} large object{'' if count == 1 else 's'} in view"
    console.print(fitted_table(console, title, columns, result.report.table_rows(), drop=["support"]))
    typer.echo(f"map: {out}" + (f"\nreport: {report}" if report else ""))


def _check_not_folders(files: dict[str, tuple[Path | None, str]]) -> None:
    """Refuse a folder given where a file is written ({flag: (path, an example name)}), before the
    fit: the map would be written and the report's replace fail, half the output left."""
    from homemodel.core.errors import InputError

    for flag, (path, example) in files.items():
        if path is not None and path.is_dir():
            raise InputError(f"{flag} {path}: a folder; give the file to write, e.g. {path / example}")


def _check_report_replaces_no_map(report: Path | None, maps: dict[str, Path]) -> None:
    """Refuse a --report that names the input map or --out, before the fit: the JSON would be
    written over the map (the user's map lost, exit 0). --out over MAP.xml is allowed."""
    from homemodel.core.errors import InputError

    if report is None:
        return
    for name, path in maps.items():
        if report.resolve() == path.resolve():
            raise InputError(
                f"--report {report}: the same file as {name}; the report (JSON) would replace the map: "
                f"give it another name, e.g. {report.with_name('seen.json')}"
            )
