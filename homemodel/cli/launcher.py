"""The first code the `homemodel` command runs: a Ctrl-C while the command line's modules are
still being imported ends quietly too (exit code 130), as it does once a command runs."""

from __future__ import annotations

import sys


def main() -> None:
    try:
        from homemodel.core.deferred_imports import defer_networkx
        from homemodel.core.interrupts import raise_if_interrupted, remember_interrupts

        remember_interrupts()
        defer_networkx()  # trimesh's import without networkx's 0.08 CPU-s, for what never uses it
        from homemodel.cli.commands import main as run_command_line

        raise_if_interrupted()
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        sys.exit(130)
    run_command_line()
