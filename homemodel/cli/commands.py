"""The `homemodel` command's commands, one Typer app: `homemodel PART VERB INPUT --out DIR`.

Subcommands import their heavy dependencies (bpy, pybullet, open3d) only when they run,
so `homemodel --help` stays fast. `main` builds only the part its first argument names
(`homemodel completion run ...` imports the completion commands alone, about 0.2 CPU-s less
than all of them); `app` is the whole tree, made when first asked for.
"""

from __future__ import annotations

import importlib
import logging
import sys
from collections.abc import Iterable
from typing import Any

import typer

from homemodel.cli.errors import EXIT_INTERRUPTED, report_bug

try:  # Typer 0.29 vends its own click; its usage errors derive from this
    from typer._click.exceptions import ClickException
except ImportError:
    from click import ClickException


# Each part of the command line, by the name it is called with, in the order --help lists them:
# the module that defines it, its command (help None) or its sub-app, and the sub-app's help.
PARTS: dict[str, tuple[str, str, str | None]] = {
    "build": ("homemodel.cli.build_command", "build", None),
    "validate": ("homemodel.cli.validate_command", "validate", None),
    "render": ("homemodel.cli.render_command", "render", None),
    "export": ("homemodel.cli.export_command", "export", None),
    "map": ("homemodel.cli.map_commands", "map_app", "Show, query, extend and validate a hierarchical semantic map; update it from a depth camera's view."),
    "turntable": ("homemodel.cli.turntable_commands", "turntable_app", "AprilTag turntable: print a board, capture from a RealSense or import a recording, reconstruct a mesh."),
    "photogrammetry": ("homemodel.cli.photogrammetry_commands", "photogrammetry_app", "Photos to a textured, metric mesh through COLMAP."),
    "completion": ("homemodel.cli.completion_commands", "completion_app", "A full mesh of a new object from one depth image."),
    "addon": ("homemodel.cli.addon_commands", "addon_app", "Files for the Blender extension: spec forms, model and home documents."),
    "db": ("homemodel.cli.db_commands", "db_app", "The model database: batch builds from a manifest on Dask, queries, a web page."),
    "eval": ("homemodel.cli.eval_commands", "eval_app", "Compare a reconstruction with ground truth: VoxelIOU, surface distance, F-score."),
}  # fmt: skip

# Modules that register further commands on a part's sub-app when imported.
REGISTERS_ON: dict[str, tuple[str, ...]] = {
    "map": ("homemodel.cli.map_observe_command", "homemodel.cli.map_simulate_command"),
}


def _add_part(app: typer.Typer, name: str) -> None:
    module_name, attribute, help_text = PARTS[name]
    part = getattr(importlib.import_module(module_name), attribute)
    for module in REGISTERS_ON.get(name, ()):
        importlib.import_module(module)
    if help_text is None:
        app.command()(part)
    else:
        app.add_typer(part, name=name, help=help_text)


def _no_options() -> None:
    """The command's top level takes no options of its own."""


def make_app(parts: Iterable[str] | None = None) -> typer.Typer:
    """The command line with `parts` (names in PARTS; None: all of them)."""
    app = typer.Typer(
        name="homemodel",
        help="Model a home for a service robot: articulated furniture from measurements, URDF/glTF export, a semantic map.",
        no_args_is_help=True,
        add_completion=False,
        pretty_exceptions_enable=False,
    )
    # A Typer app with one command and no callback runs that command directly (`homemodel X.urdf`),
    # so the group always has a callback: `homemodel validate X.urdf` parses the same with one part.
    app.callback()(_no_options)
    wanted = set(PARTS if parts is None else parts)
    for name in PARTS:
        if name in wanted:
            _add_part(app, name)
    return app


def __getattr__(name: str) -> Any:
    if name == "app":  # the whole tree, for `homemodel.cli.app` (tests, the add-on's documents)
        globals()["app"] = make_app()
        return globals()["app"]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def main() -> None:
    """Run the command; whatever happens, end with one line on stderr and an exit code."""
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    named = sys.argv[1] if len(sys.argv) > 1 else None
    app = make_app([named] if named in PARTS else None)  # --help, or a misspelt part: all of them
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
