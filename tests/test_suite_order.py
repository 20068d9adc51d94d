"""The suite's order under pytest-xdist: the longest test files first, each kept whole (conftest)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

from conftest import LONGEST_FIRST, longest_files_first

TESTS = Path(__file__).resolve().parent


def test_every_file_named_longest_first_is_a_test_file() -> None:
    """A renamed or removed file would silently drop back to name order."""
    missing = [name for name in LONGEST_FIRST if not (TESTS / name).is_file()]
    assert not missing, missing
    assert len(set(LONGEST_FIRST)) == len(LONGEST_FIRST)


def test_the_longest_files_go_first_and_every_file_stays_whole_and_in_order() -> None:
    names = ["test_a.py", "test_a.py", LONGEST_FIRST[1], LONGEST_FIRST[1], "test_b.py", LONGEST_FIRST[0]]
    items = [SimpleNamespace(path=TESTS / name, index=i) for i, name in enumerate(names)]
    longest_files_first(items)
    assert [(item.path.name, item.index) for item in items] == [
        (LONGEST_FIRST[0], 5),
        (LONGEST_FIRST[1], 2),
        (LONGEST_FIRST[1], 3),
        ("test_a.py", 0),
        ("test_a.py", 1),
        ("test_b.py", 4),
    ]
