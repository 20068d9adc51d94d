"""The scikit-learn estimator contract (parameters only in `__init__`, kept as attributes of the
same name; `fit` returns self; learned attributes end in `_`) without importing scikit-learn.

`sklearn.base` alone costs about 1.2 CPU-s to import, more than a whole completion query, and a
query needs only the trained arrays; scikit-learn is imported where training grows the trees.
"""

from __future__ import annotations

import inspect
from typing import Any


class Estimator:
    """`get_params` and `set_params` as scikit-learn's BaseEstimator gives them (no nested estimators)."""

    @classmethod
    def _param_names(cls) -> list[str]:
        parameters = inspect.signature(cls.__init__).parameters.values()
        return sorted(p.name for p in parameters if p.name != "self" and p.kind is not p.VAR_KEYWORD)

    def get_params(self, deep: bool = True) -> dict[str, Any]:
        return {name: getattr(self, name) for name in self._param_names()}

    def set_params(self, **params: Any) -> Estimator:
        names = self._param_names()
        for name, value in params.items():
            if name not in names:
                raise ValueError(f"{type(self).__name__} has no parameter {name!r} (it has {', '.join(names)})")
            setattr(self, name, value)
        return self

    def __repr__(self) -> str:
        defaults = {p.name: p.default for p in inspect.signature(type(self).__init__).parameters.values()}
        changed = {k: v for k, v in self.get_params().items() if defaults.get(k, inspect.Parameter.empty) != v}
        return f"{type(self).__name__}({', '.join(f'{k}={v!r}' for k, v in changed.items())})"
