"""Progress reports and stage times: the one callback shape every pipeline takes, and the
clock that times each stage for the summaries (`times_s`: stage name -> seconds)."""

from __future__ import annotations

import time
from collections.abc import Callable

from homemodel.core.interrupts import raise_if_interrupted

Progress = Callable[[str, int, int | None], None]
"""`progress(stage, done, total)`: `done` of `total` steps of `stage`; `total` is None while
the stage cannot say how far it is. Only the command line draws it (homemodel/cli/progress.py)."""


def no_progress(stage: str, done: int, total: int | None) -> None:
    """A Progress that reports nowhere, for callers that pass none."""


class StageClock:
    """Times per stage and the progress callback, in one place.

    `start(stage)` ends the running stage and reports the next one at 0 steps; a stage
    started twice adds up. `times_s` is what the summaries write under the key `times_s`.
    """

    def __init__(self, progress: Progress | None = None) -> None:
        self.progress: Progress = progress or no_progress
        self.times_s: dict[str, float] = {}
        self._stage: str | None = None
        self._start = 0.0

    def start(self, stage: str, total: int | None = None) -> None:
        raise_if_interrupted()  # each stage is a point where a swallowed Ctrl-C stops the run
        self.stop()
        self._stage, self._start = stage, time.perf_counter()
        self.progress(stage, 0, total)

    def tick(self, done: int, total: int | None) -> None:
        """Report progress within the running stage."""
        if self._stage is not None:
            self.progress(self._stage, done, total)

    def stop(self) -> None:
        if self._stage is not None:
            self.times_s[self._stage] = self.times_s.get(self._stage, 0.0) + time.perf_counter() - self._start
            self._stage = None
