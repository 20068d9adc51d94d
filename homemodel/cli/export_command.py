"""`homemodel export MODEL --format mjcf|sdf|usd|urdf-ros --out DIR`: one model for a simulator,
from a model folder, a .urdf, or another simulator's file of one model (MJCF, SDF, USD)."""

from __future__ import annotations

from pathlib import Path

import typer

from homemodel.cli.errors import exit_on_error
from homemodel.cli.option_fields import field_option, from_options


@from_options
def export(
    model_dir: Path = typer.Argument(..., metavar="MODEL", help="model folder (model.urdf or mobility.urdf), a .urdf file, or an MJCF (.xml), SDF (.sdf) or USD (.usd, .usda, .usdc, .usdz) file of one model"),
    fmt: str = field_option("homemodel.exchange.simulator:export_model_for.fmt", "--format", help="mjcf (MuJoCo), sdf (Gazebo), usd (Isaac), urdf-ros (a ROS 2 package)"),
    out: Path = typer.Option(..., "--out", help="output folder"),
    package: str | None = typer.Option(None, "--package", help="urdf-ros: the ROS package name (default: the model's name)"),
    free: bool = typer.Option(False, "--free", help="a free body standing on a floor (a cup, a jar), not fixed to the world"),
    force: bool = typer.Option(False, "--force", help="replace a non-empty output folder"),
) -> None:
    """Export one model for a simulator, at the origin with its joints at zero.

    Fixed to the world, or with --free a body standing on a floor."""
    from homemodel.exchange.simulator import export_model_for
    from homemodel.exchange.simulator_read import SCENE_FILE_SUFFIXES, read_model
    from homemodel.exchange.urdf.read import find_urdf, load_urdf

    with exit_on_error():
        if model_dir.suffix.lower() in SCENE_FILE_SUFFIXES:
            model, source = read_model(model_dir), model_dir.parent
        else:
            urdf = find_urdf(model_dir)
            model, source = load_urdf(urdf), urdf.parent
        result = export_model_for(model, out, fmt, package=package, free=free, force=force, inputs=[source])
    summary = result.summary
    joints = sum(len(o.joints) for o in summary.objects)
    typer.echo(f"{result.file}: {summary.objects[0].links} links, {joints} joints, {summary.mesh_files} mesh files")
