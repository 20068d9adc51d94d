"""The `homemodel` command: `homemodel PART VERB INPUT --out DIR`.

The commands are registered in `homemodel.cli.commands`; `homemodel.cli.launcher` starts
them. This module stays light, so the launcher is running before the commands' imports
begin, and `app` and `main` are looked up there when first asked for.
"""

from __future__ import annotations

from typing import Any

_FROM_COMMANDS = ("app", "main")


def __getattr__(name: str) -> Any:
    if name in _FROM_COMMANDS:
        from homemodel.cli import commands

        return getattr(commands, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
