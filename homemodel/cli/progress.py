"""What every long command shows: a progress bar driven by the library's callback, and a
table of the figures it measured."""

from __future__ import annotations

import contextlib
import json
import os
import sys
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Literal

from rich import box
from rich.console import Console
from rich.measure import Measurement
from rich.progress import BarColumn, MofNCompleteColumn, TaskID, TextColumn, TimeElapsedColumn
from rich.progress import Progress as Bars
from rich.table import Table

from homemodel.core.progress import Progress


# The Blender extension runs commands without a terminal and reads their progress from the
# file this names: one JSON line {"stage", "done", "total"} per callback.
PROGRESS_FILE_ENV = "HOMEMODEL_PROGRESS_FILE"


def _also_to_file(progress: Progress) -> Progress:
    path = os.environ.get(PROGRESS_FILE_ENV)
    if not path:
        return progress

    def both(stage: str, done: int, total: int | None) -> None:
        with open(path, "a", encoding="utf-8") as f:
            f.write(json.dumps({"stage": stage, "done": done, "total": total}) + "\n")
        progress(stage, done, total)

    return both


def make_console() -> Console:
    # Piped into a file or CI log, rich would assume 80 columns and truncate the tables.
    return Console(width=None if sys.stdout.isatty() else 120)


def _bars(console: Console, label: str) -> Bars:
    """Bars labelled by `label` (a rich format of the task), gone once done, shown only on a
    terminal: piped, rich would leave a blank line behind each."""
    return Bars(
        TextColumn(label),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=console,
        transient=True,
        disable=not console.is_terminal,
    )


@contextlib.contextmanager
def progress_bar(console: Console, verb: str) -> Iterator[Progress]:
    """One bar, labelled `verb` and the current stage, and the `progress(stage, done, total)`
    callback the library calls to drive it (total None: not known yet)."""
    with _bars(console, f"[bold]{verb}[/] " + "{task.description:<24}") as bar:
        task = bar.add_task("starting", total=None)
        yield _also_to_file(lambda stage, done, total: bar.update(task, description=stage, completed=done, total=total))


@contextlib.contextmanager
def stage_bars(console: Console) -> Iterator[Progress]:
    """A bar per stage of a pipeline, each finished when the next one starts, and the
    `progress(stage, done, total)` callback that drives them."""
    with _bars(console, "[bold]{task.description:<14}") as bar:
        tasks: dict[str, TaskID] = {}

        def progress(stage: str, done: int, total: int | None) -> None:
            for other, task in tasks.items():
                if other != stage:
                    finished = bar.tasks[task].total or 1
                    bar.update(task, completed=finished, total=finished)
            if stage not in tasks:
                tasks[stage] = bar.add_task(stage, total=total)
            bar.update(tasks[stage], completed=done, total=total)

        yield _also_to_file(progress)


def figures_table(title: str, rows: list[tuple[str, str]]) -> Table:
    """A two-column table: what was measured, and its value."""
    table = Table(title=title, box=box.SIMPLE_HEAD)
    table.add_column("figure")
    table.add_column("value", justify="right")
    for name, value in rows:
        table.add_row(name, value)
    return table


@dataclass(frozen=True)
class Column:
    """A column of a `fitted_table`: `keep` columns (ids, kinds) are never dropped nor cut."""

    header: str
    justify: Literal["left", "right"] = "left"
    keep: bool = False


def fitted_table(
    console: Console, title: str, columns: Sequence[Column], rows: Sequence[Sequence[str]], drop: Sequence[str]
) -> Table:
    """A table that fits the console's width: the columns named in `drop` are left out, in
    that order, until it fits (an 80-column terminal, or a log), rather than cutting values
    to "tabl…"."""
    shown = list(range(len(columns)))
    for header in [None, *drop]:
        if header is not None:
            shown.remove(next(i for i in shown if columns[i].header == header))
        table = Table(title=title, box=box.SIMPLE_HEAD)
        for i in shown:
            table.add_column(columns[i].header, justify=columns[i].justify, no_wrap=columns[i].keep)
        for row in rows:
            table.add_row(*(row[i] for i in shown))
        # Measured without the console's limit, which would cap the width at the console's.
        if Measurement.get(console, console.options.update_width(1_000_000), table).maximum <= console.width:
            break
    return table
