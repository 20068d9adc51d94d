"""`homemodel validate PATH`: the validation gate on a model folder, a .urdf or a .glb."""

from __future__ import annotations

from pathlib import Path

import typer

from homemodel.cli.errors import exit_on_error

# Keyed by the first word of a report line.
_COLOURS = {
    "PASS": typer.colors.GREEN,
    "OK:": typer.colors.GREEN,
    "FAIL": typer.colors.RED,
    "FAILED:": typer.colors.RED,
}


def validate(
    path: Path = typer.Argument(..., help="A model folder (model.urdf, optional model.glb), a .urdf or a .glb file."),
    package_paths: list[Path] = typer.Option(
        [], "--package-path", help="where package://NAME/... meshes find ROS package NAME (repeatable; after the package holding the URDF, before ROS_PACKAGE_PATH)"
    ),
) -> None:
    """Check a model with our rules, check_urdf, yourdfpy, pybullet and the Khronos glTF validator."""
    # Imported here so `homemodel --help` does not pay for trimesh and lxml.
    from homemodel.model_folder.gate.validate import validate_path

    with exit_on_error():
        report = validate_path(path, package_paths=package_paths)
    for line in report.format().splitlines():
        colour = _COLOURS.get(line.split(" ", 1)[0])
        typer.echo(typer.style(line, fg=colour) if colour else line)
    raise typer.Exit(0 if report.ok else 1)
