"""The `homemodel` command: `homemodel PART VERB INPUT --out DIR`.

Subcommands import their heavy dependencies (bpy, pybullet, open3d) only when they run,
so `homemodel --help` stays fast.
"""

from __future__ import annotations

import logging

import typer

from homemodel.cli.build_command import build
from homemodel.cli.map_commands import map_app
from homemodel.cli.validate_command import validate

app = typer.Typer(
    name="homemodel",
    help="Model a home for a service robot: articulated furniture from measurements, URDF/glTF export, a semantic map.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
app.command()(build)
app.command()(validate)
app.add_typer(map_app, name="map", help="Show, query, extend and validate a hierarchical semantic map.")


def main() -> None:
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    app()
