"""networkx loaded when it is first used, not whenever trimesh is imported.

trimesh's import brings networkx (285 modules, about 0.08 CPU-s) into every process that makes a
mesh, though only its networkx graph engine, its 2D paths and a few repairs use it: a completion
query never does. trimesh imports networkx only inside `try` blocks, binding the module for later
use (and `networkx.Graph` in `trimesh.base`, for a return annotation). `defer_networkx()` makes the
first import of trimesh find a stand-in for networkx that refuses attribute requests while trimesh
itself is being imported (trimesh then goes on without `Graph`, as without networkx) and loads the
real networkx on the first attribute asked for afterwards.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys
import threading
import types
from collections.abc import Sequence
from typing import Any

_DEFERRED = "networkx"
_IMPORTER = "trimesh"
# Two threads' first uses at once: without it, one could take the real module the other just
# imported out of sys.modules again (a KeyError, or a second networkx whose classes differ).
_LOADING = threading.RLock()


def _importer_initialising() -> bool:
    """Whether trimesh's own import is running (CPython marks a module's spec while it executes)."""
    importer = sys.modules.get(_IMPORTER)
    return importer is not None and bool(getattr(getattr(importer, "__spec__", None), "_initializing", False))


class _LoadedOnFirstUse(types.ModuleType):
    """Stands for networkx in sys.modules until one of its attributes is asked for."""

    def __getattr__(self, attribute: str) -> Any:
        if _importer_initialising():
            raise AttributeError(f"module {self.__name__!r} is loaded on first use, after {_IMPORTER}'s import")
        with _LOADING:
            if sys.modules.get(_DEFERRED) is self:
                del sys.modules[_DEFERRED]
            real = importlib.import_module("networkx")
        return getattr(real, attribute)


class _BeforeTrimesh(importlib.abc.MetaPathFinder):
    """Puts the stand-in in place when trimesh is first imported, and only then: a command
    that makes no mesh has no networkx in sys.modules, real or not."""

    def find_spec(
        self, fullname: str, path: Sequence[str] | None, target: types.ModuleType | None = None
    ) -> importlib.machinery.ModuleSpec | None:
        if fullname == _IMPORTER:
            # A new list, not the one removed from: another thread's import may be going through it.
            sys.meta_path = [finder for finder in sys.meta_path if finder is not self]
            spec = importlib.util.find_spec(_DEFERRED)
            if spec is not None and _DEFERRED not in sys.modules:
                stand_in = _LoadedOnFirstUse(_DEFERRED)
                stand_in.__spec__ = spec  # what `find_spec("networkx")` asks of a module already in sys.modules
                sys.modules[_DEFERRED] = stand_in
        return None  # the usual finders import trimesh


def defer_networkx() -> None:
    """Load networkx on first use in this process (a no-op once trimesh or networkx is imported)."""
    if _IMPORTER in sys.modules or _DEFERRED in sys.modules:
        return
    if not any(isinstance(finder, _BeforeTrimesh) for finder in sys.meta_path):
        sys.meta_path.insert(0, _BeforeTrimesh())
