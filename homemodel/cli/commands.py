"""The `homemodel` command's commands, one Typer app: `homemodel PART VERB INPUT --out DIR`.

Subcommands import their heavy dependencies (bpy, pybullet, open3d) only when they run,
so `homemodel --help` stays fast.
"""

from __future__ import annotations

import logging
import sys

import typer

from homemodel.cli.addon_commands import addon_app
from homemodel.cli.build_command import build
from homemodel.cli.completion_commands import completion_app
from homemodel.cli.db_commands import db_app
from homemodel.cli.errors import EXIT_INTERRUPTED, report_bug
from homemodel.cli.eval_commands import eval_app
from homemodel.cli.export_command import export
from homemodel.cli.map_commands import map_app
from homemodel.cli.map_observe_command import observe_command as _observe_command  # noqa: F401 (registers map observe)
from homemodel.cli.map_simulate_command import simulate_view as _simulate_view  # noqa: F401 (registers map simulate-view)
from homemodel.cli.photogrammetry_commands import photogrammetry_app
from homemodel.cli.render_command import render
from homemodel.cli.turntable_commands import turntable_app
from homemodel.cli.validate_command import validate

try:  # Typer 0.29 vends its own click; its usage errors derive from this
    from typer._click.exceptions import ClickException
except ImportError:
    from click import ClickException

app = typer.Typer(
    name="homemodel",
    help="Model a home for a service robot: articulated furniture from measurements, URDF/glTF export, a semantic map.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
app.command()(build)
app.command()(validate)
app.command()(render)
app.command()(export)
app.add_typer(map_app, name="map", help="Show, query, extend and validate a hierarchical semantic map.")
app.add_typer(turntable_app, name="turntable", help="AprilTag turntable: print a board, simulate a capture, reconstruct a mesh.")
app.add_typer(photogrammetry_app, name="photogrammetry", help="Photos to a textured, metric mesh through COLMAP.")
app.add_typer(completion_app, name="completion", help="A full mesh of a new object from one depth image.")
app.add_typer(addon_app, name="addon", help="Files for the Blender extension: spec forms, model and home documents.")
app.add_typer(db_app, name="db", help="The model database: batch builds from a manifest on Dask, queries, a web page.")
app.add_typer(eval_app, name="eval", help="Compare a reconstruction with ground truth: VoxelIOU, surface distance, F-score.")


def main() -> None:
    """Run the command; whatever happens, end with one line on stderr and an exit code."""
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    try:
        code = app(standalone_mode=False)  # so exceptions reach the handlers below
    except ClickException as exc:  # usage errors: click's own message, exit 2
        exc.show()
        code = exc.exit_code
    except (typer.Abort, KeyboardInterrupt):
        print("interrupted", file=sys.stderr)
        code = EXIT_INTERRUPTED
    except Exception as exc:  # the last line of defence: a bug, not a user's mistake
        code = report_bug(exc, sys.argv[1:])
    else:
        if code == EXIT_INTERRUPTED:  # Typer turns a Ctrl-C while it parses into this code
            print("interrupted", file=sys.stderr)
    sys.exit(code if isinstance(code, int) else 0)
