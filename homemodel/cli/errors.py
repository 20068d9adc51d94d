"""Turn library errors into what a shell user expects: one line on stderr, exit code 2."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import typer

from homemodel.core.errors import HomemodelError

EXIT_ERROR = 2


def one_line(exc: BaseException) -> str:
    return " ".join(part.strip() for part in str(exc).splitlines() if part.strip()) or type(exc).__name__


@contextlib.contextmanager
def exit_on_error() -> Iterator[None]:
    """Print a HomemodelError as `error: ...` on stderr and exit with code 2.

    Use as `with exit_on_error(): ...` or as a decorator, `@exit_on_error()`, below the
    command decorator. Other exceptions are bugs and keep their traceback.
    """
    try:
        yield
    except HomemodelError as exc:
        typer.echo(f"error: {one_line(exc)}", err=True)
        raise typer.Exit(code=EXIT_ERROR) from None
