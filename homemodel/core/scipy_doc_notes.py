"""SciPy's import without the notes its decorators write into docstrings.

As SciPy 1.16's modules are imported, its decorators (`_apply_over_batch` on most of
`scipy.linalg`, `xp_capabilities`, `_transition_to_rng`, the deprecation of positional
arguments) parse each decorated function's whole docstring with `FunctionDoc`, add a note and
write it back: 147 docstrings in a completion query, about 0.07 of its 0.69 CPU-s of imports
(5 alternating import runs; in the whole command, 0.01-0.05 in alternating runs at load 9-14,
within their noise). A command reads none of them. `skip_scipy_doc_notes()` makes the first
import of SciPy's `_docscrape` leave `FunctionDoc` unparsed for those decorators: each function
keeps the docstring it was written with, and its code is untouched.
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import importlib.util
import sys
import types
from collections.abc import Sequence
from typing import Any

_DOCSCRAPE = "scipy._lib._docscrape"


def _unparsed(function_doc: type) -> type:
    """A `FunctionDoc` that parses nothing: every section reads empty, what is written to it is
    dropped, and its text is the function's own docstring (the decorators take it from after the
    first line, where `FunctionDoc` puts the signature)."""

    class UnparsedFunctionDoc(function_doc):  # type: ignore[misc, valid-type]
        def __init__(self, func: Any, role: str = "func", doc: str | None = None, config: Any = None) -> None:
            self._f = func
            self._doc = doc

        def __getitem__(self, key: str) -> list:
            return []

        def __setitem__(self, key: str, value: Any) -> None:
            pass

        def __str__(self) -> str:
            return "\n" + (self._doc if self._doc is not None else getattr(self._f, "__doc__", None) or "")

    return UnparsedFunctionDoc


class _WhenDocscrapeLoads(importlib.abc.MetaPathFinder):
    """Replaces `FunctionDoc` as soon as `_docscrape` has run, before the modules that import it."""

    def find_spec(
        self, fullname: str, path: Sequence[str] | None, target: types.ModuleType | None = None
    ) -> importlib.machinery.ModuleSpec | None:
        if fullname != _DOCSCRAPE:
            return None
        # A new list, not the one removed from: another thread's import may be going through it.
        sys.meta_path = [finder for finder in sys.meta_path if finder is not self]
        spec = importlib.util.find_spec(fullname)
        if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return spec
        run = spec.loader.exec_module

        def exec_module(module: types.ModuleType) -> None:
            run(module)
            if isinstance(getattr(module, "FunctionDoc", None), type):
                module.FunctionDoc = _unparsed(module.FunctionDoc)

        spec.loader.exec_module = exec_module  # type: ignore[method-assign]
        return spec


def skip_scipy_doc_notes() -> None:
    """SciPy's decorators leave docstrings unparsed in this process (a no-op once SciPy's
    `_docscrape` is imported)."""
    if _DOCSCRAPE in sys.modules or any(isinstance(finder, _WhenDocscrapeLoads) for finder in sys.meta_path):
        return
    sys.meta_path.insert(0, _WhenDocscrapeLoads())
