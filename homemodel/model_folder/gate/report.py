"""The result of the validation gate: one named check per line, passed or failed."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

# Long problem lists would bury the report; the first few name the fault.
MAX_PROBLEMS_SHOWN = 5


@dataclass(frozen=True)
class Check:
    name: str
    passed: bool
    detail: str


@dataclass
class ValidationReport:
    path: Path
    checks: list[Check] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return all(c.passed for c in self.checks)

    def format(self) -> str:
        width = max((len(c.name) for c in self.checks), default=0)
        lines = [f"validate {self.path}"]
        lines += [f"{'PASS' if c.passed else 'FAIL'}  {c.name:<{width}}  {c.detail}" for c in self.checks]
        failed = sum(not c.passed for c in self.checks)
        if failed:
            lines.append(f"FAILED: {failed} of {len(self.checks)} checks failed")
        else:
            lines.append(f"OK: all {len(self.checks)} checks passed")
        return "\n".join(lines)


def count(n: int, noun: str) -> str:
    """`n` and `noun`, plural unless n is 1: "1 joint", "2 joints"."""
    return f"{n} {noun}{'' if n == 1 else 's'}"


def check_from_problems(name: str, problems: Sequence[str], ok_detail: str) -> Check:
    """A check that fails listing the first problems, or passes with `ok_detail`."""
    if not problems:
        return Check(name, True, ok_detail)
    shown = "; ".join(problems[:MAX_PROBLEMS_SHOWN])
    more = len(problems) - MAX_PROBLEMS_SHOWN
    return Check(name, False, shown + (f"; and {more} more" if more > 0 else ""))
