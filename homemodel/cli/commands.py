"""The `homemodel` command's commands, one Typer app: `homemodel PART VERB INPUT --out DIR`.

Subcommands import their heavy dependencies (bpy, pybullet, open3d) only when they run,
so `homemodel --help` stays fast. `main` builds only the part its first argument names
(`homemodel completion run ...` imports the completion commands alone, about 0.2 CPU-s less
than all of them); `app` is the whole tree, made when first asked for.
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Callable, Iterable
from typing import Any

import typer

from homemodel.cli.errors import EXIT_INTERRUPTED, report_bug

try:  # Typer 0.29 vends its own click; its usage errors derive from this
    from typer._click.exceptions import ClickException
except ImportError:
    from click import ClickException


def _build(app: typer.Typer) -> None:
    from homemodel.cli.build_command import build

    app.command()(build)


def _validate(app: typer.Typer) -> None:
    from homemodel.cli.validate_command import validate

    app.command()(validate)


def _render(app: typer.Typer) -> None:
    from homemodel.cli.render_command import render

    app.command()(render)


def _export(app: typer.Typer) -> None:
    from homemodel.cli.export_command import export

    app.command()(export)


def _map(app: typer.Typer) -> None:
    from homemodel.cli.map_commands import map_app
    from homemodel.cli.map_observe_command import observe_command as _observe_command  # noqa: F401 (registers map observe)
    from homemodel.cli.map_simulate_command import simulate_view as _simulate_view  # noqa: F401 (registers map simulate-view)

    app.add_typer(map_app, name="map", help="Show, query, extend and validate a hierarchical semantic map.")


def _turntable(app: typer.Typer) -> None:
    from homemodel.cli.turntable_commands import turntable_app

    app.add_typer(turntable_app, name="turntable", help="AprilTag turntable: print a board, simulate a capture, reconstruct a mesh.")


def _photogrammetry(app: typer.Typer) -> None:
    from homemodel.cli.photogrammetry_commands import photogrammetry_app

    app.add_typer(photogrammetry_app, name="photogrammetry", help="Photos to a textured, metric mesh through COLMAP.")


def _completion(app: typer.Typer) -> None:
    from homemodel.cli.completion_commands import completion_app

    app.add_typer(completion_app, name="completion", help="A full mesh of a new object from one depth image.")


def _addon(app: typer.Typer) -> None:
    from homemodel.cli.addon_commands import addon_app

    app.add_typer(addon_app, name="addon", help="Files for the Blender extension: spec forms, model and home documents.")


def _db(app: typer.Typer) -> None:
    from homemodel.cli.db_commands import db_app

    app.add_typer(db_app, name="db", help="The model database: batch builds from a manifest on Dask, queries, a web page.")


def _eval(app: typer.Typer) -> None:
    from homemodel.cli.eval_commands import eval_app

    app.add_typer(eval_app, name="eval", help="Compare a reconstruction with ground truth: VoxelIOU, surface distance, F-score.")


# Each part of the command line, by the name it is called with, in the order --help lists them.
PARTS: dict[str, Callable[[typer.Typer], None]] = {
    "build": _build, "validate": _validate, "render": _render, "export": _export, "map": _map,
    "turntable": _turntable, "photogrammetry": _photogrammetry, "completion": _completion, "addon": _addon,
    "db": _db, "eval": _eval,
}  # fmt: skip


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
    for name, add in PARTS.items():
        if name in wanted:
            add(app)
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
