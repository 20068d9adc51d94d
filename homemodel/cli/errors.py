"""Turn errors into what a shell user expects: one line on stderr and an exit code.

A HomemodelError (bad input, an output that cannot be written) is exit code 2; a file the
system refuses to write (a full disk, a read-only or immutable folder) is the same; Ctrl-C is
exit code 130. Anything else is a bug: `main` still prints one line naming the command, with
exit code 1, and writes the traceback to a log file whose path it prints.
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
import time
import traceback
from collections.abc import Iterator
from pathlib import Path

import typer

from homemodel.core.errors import WRITE_ERRNOS, HomemodelError

EXIT_ERROR = 2
EXIT_BUG = 1
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as shells report it


def one_line(exc: BaseException) -> str:
    return " ".join(part.strip() for part in str(exc).splitlines() if part.strip()) or type(exc).__name__


@contextlib.contextmanager
def exit_on_error() -> Iterator[None]:
    """Print a HomemodelError, or an OSError the system raised on a file, as `error: ...` on
    stderr and exit with code 2.

    Use as `with exit_on_error(): ...` or as a decorator, `@exit_on_error()`, below the
    command decorator. Other exceptions are bugs, for `main`'s last line of defence.
    """
    try:
        yield
    except HomemodelError as exc:
        typer.echo(f"error: {one_line(exc)}", err=True)
        raise typer.Exit(code=EXIT_ERROR) from None
    except OSError as exc:
        if exc.errno not in WRITE_ERRNOS:
            raise
        where = f"{exc.filename}: " if exc.filename else ""
        typer.echo(f"error: {where}{exc.strerror}", err=True)
        raise typer.Exit(code=EXIT_ERROR) from None


def log_folder() -> Path:
    """Where tracebacks of unexpected errors go: $XDG_STATE_HOME/homemodel, else ~/.local/state/homemodel."""
    base = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(base) / "homemodel"


def report_bug(exc: BaseException, argv: list[str]) -> int:
    """One line naming the command and its input; the traceback to a log file. Returns EXIT_BUG."""
    text = "".join(traceback.format_exception(exc))
    command = " ".join(["homemodel", *argv])
    log = None
    for folder in (log_folder(), Path(tempfile.gettempdir())):
        with contextlib.suppress(OSError):
            folder.mkdir(parents=True, exist_ok=True)
            log = folder / f"homemodel-error-{time.strftime('%Y%m%d-%H%M%S')}-{os.getpid()}.log"
            log.write_text(f"{command}\n\n{text}", encoding="utf-8")
            break
    where = f"; traceback in {log}" if log else ""
    print(
        f"error: `{command}` failed unexpectedly: {type(exc).__name__}: {one_line(exc)[:300]}"
        f" (a bug in homemodel{where})",
        file=sys.stderr,
    )
    return EXIT_BUG
