"""What every long command shows: a progress bar driven by the library's callback, and a
table of the figures it measured."""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Callable, Iterator

from rich import box
from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TaskID,
    TextColumn,
    TimeElapsedColumn,
)
from rich.table import Table

ProgressCallback = Callable[[str, int, int | None], None]


def make_console() -> Console:
    # Piped into a file or CI log, rich would assume 80 columns and truncate the tables.
    return Console(width=None if sys.stdout.isatty() else 120)


@contextlib.contextmanager
def progress_bar(console: Console, verb: str) -> Iterator[ProgressCallback]:
    """One bar, labelled `verb` and the current stage, and the `progress(stage, done, total)`
    callback the library calls to drive it (total None: not known yet)."""
    with Progress(
        TextColumn(f"[bold]{verb}[/] " + "{task.description:<24}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=console,
        transient=True,
    ) as bar:
        task = bar.add_task("starting", total=None)
        yield lambda stage, done, total: bar.update(task, description=stage, completed=done, total=total)


@contextlib.contextmanager
def stage_bars(console: Console) -> Iterator[ProgressCallback]:
    """A bar per stage of a pipeline, each finished when the next one starts, and the
    `progress(stage, done, total)` callback that drives them."""
    with Progress(
        TextColumn("[bold]{task.description:<14}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=console,
        transient=True,
    ) as bar:
        tasks: dict[str, TaskID] = {}

        def progress(stage: str, done: int, total: int | None) -> None:
            for other, task in tasks.items():
                if other != stage:
                    finished = bar.tasks[task].total or 1
                    bar.update(task, completed=finished, total=finished)
            if stage not in tasks:
                tasks[stage] = bar.add_task(stage, total=total)
            bar.update(tasks[stage], completed=done, total=total)

        yield progress


def figures_table(title: str, rows: list[tuple[str, str]]) -> Table:
    """A two-column table: what was measured, and its value."""
    table = Table(title=title, box=box.SIMPLE_HEAD)
    table.add_column("figure")
    table.add_column("value", justify="right")
    for name, value in rows:
        table.add_row(name, value)
    return table
