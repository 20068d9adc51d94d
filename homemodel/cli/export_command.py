"""`homemodel export MODEL_DIR --format mjcf|sdf|usd|urdf-ros --out DIR`: one model for a simulator."""

from __future__ import annotations

from pathlib import Path

import typer

from homemodel.cli.errors import exit_on_error
from homemodel.cli.option_fields import field_option, from_options


@from_options
def export(
    model_dir: Path = typer.Argument(..., metavar="MODEL_DIR", help="model folder (model.urdf or mobility.urdf) or a .urdf file"),
    fmt: str = field_option("homemodel.exchange.simulator:export_model_for.fmt", "--format", help="mjcf (MuJoCo), sdf (Gazebo), usd (Isaac), urdf-ros (a ROS 2 package)"),
    out: Path = typer.Option(..., "--out", help="output folder"),
    package: str | None = typer.Option(None, "--package", help="urdf-ros: the ROS package name (default: the model's name)"),
    free: bool = typer.Option(False, "--free", help="a free body standing on a floor (a cup, a jar), not fixed to the world"),
    force: bool = typer.Option(False, "--force", help="replace a non-empty output folder"),
) -> None:
    """Export one model for a simulator at the origin with its joints at zero: fixed to the
    world, or with --free a body standing on a floor."""
    from homemodel.exchange.simulator import export_model_for
    from homemodel.exchange.urdf.read import find_urdf, load_urdf

    with exit_on_error():
        urdf = find_urdf(model_dir)
        result = export_model_for(load_urdf(urdf), out, fmt, package=package, free=free, force=force, inputs=[urdf.parent])
    summary = result.summary
    joints = sum(len(o["joints"]) for o in summary["objects"])
    typer.echo(f"{result.file}: {summary['objects'][0]['links']} links, {joints} joints, {summary['mesh_files']} mesh files")
