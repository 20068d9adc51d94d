"""Options objects to and from plain data (what YAML and JSON hold), field by field.

`options_from_dict(SfmOptions, {"max_num_features": 8192})` builds the options from their
defaults with only the given fields set; a nested options field takes a mapping of its own
fields (`{"sfm": {"max_num_features": 8192}}`), so one field of a nested object can be set
without restating the others. Every value is checked against its field's type hint and a
bad one is refused with its path (`entries.3.options.sfm.max_num_features: ...`).
`options_to_dict` is the inverse: plain data that `options_from_dict` reads back to equal
options. Works for `@dataclass` and pydantic options classes.
"""

from __future__ import annotations

import dataclasses
import enum
import math
import sys
import types
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

from homemodel.core.errors import InputError

_PLAIN = (bool, int, float, str)


def _is_pydantic(cls: object) -> bool:
    return isinstance(cls, type) and hasattr(cls, "model_fields") and hasattr(cls, "model_validate")


def is_options_class(cls: object) -> bool:
    return isinstance(cls, type) and (dataclasses.is_dataclass(cls) or _is_pydantic(cls))


@dataclasses.dataclass(frozen=True)
class _Unresolved:
    """A hint naming a type imported only for type checkers: only None can be set."""

    text: str


def _hints(cls: type) -> dict[str, Any]:
    """Field name -> type hint. When a hint names a type imported only for type checkers
    (modeller.build's `PictureOptions`), the others are still resolved, one by one."""
    try:
        return typing.get_type_hints(cls)
    except NameError:
        pass
    hints: dict[str, Any] = {}
    for klass in reversed(cls.__mro__):
        namespace = vars(sys.modules[klass.__module__])
        for name, text in klass.__dict__.get("__annotations__", {}).items():
            try:
                hints[name] = typing.get_type_hints(type("_", (), {"__annotations__": {name: text}}), namespace)[name]
            except NameError:
                hints[name] = _Unresolved(str(text))
    return hints


def _field_types(cls: type) -> dict[str, Any]:
    """Settable field name -> its resolved type hint."""
    hints = _hints(cls)
    if _is_pydantic(cls):
        return {name: hints.get(name, info.annotation) for name, info in cls.model_fields.items()}
    return {f.name: hints[f.name] for f in dataclasses.fields(cls) if f.init}


def options_to_dict(obj: object) -> dict[str, Any]:
    """Every field of the options object `obj` as plain data (nested options as mappings)."""
    if not is_options_class(type(obj)):
        raise TypeError(f"{type(obj).__name__} is not a dataclass or pydantic options class")
    return {name: _plain(getattr(obj, name)) for name in _field_types(type(obj))}


def _plain(value: Any) -> Any:
    if value is None or isinstance(value, _PLAIN):
        return value
    if is_options_class(type(value)):
        return options_to_dict(value)
    if isinstance(value, enum.Enum):
        return _plain(value.value)
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if hasattr(value, "tolist"):  # numpy arrays and scalars
        return _plain(value.tolist())
    raise TypeError(f"{type(value).__name__} value {value!r} has no plain-data form")


def options_from_dict(cls: type, data: Mapping[str, Any] | None, *, where: str = "options", base: object | None = None) -> Any:
    """`cls` from its defaults (or from `base`, an instance of it) with the fields in `data`
    set; raises InputError `"{where}.{field}: problem"` for an unknown field or a bad value."""
    if not is_options_class(cls):
        raise TypeError(f"{cls!r} is not a dataclass or pydantic options class")
    if data is None:
        data = {}
    if not isinstance(data, Mapping):
        raise InputError(f"{where}: expected a mapping of {cls.__name__}'s fields, got {_shown(data)}")
    types_ = _field_types(cls)
    values: dict[str, Any] = {}
    for name, value in data.items():
        if name not in types_:
            raise InputError(f"{where}.{name}: not a field of {cls.__name__} (its fields: {', '.join(types_)})")
        current = getattr(base, name) if base is not None else _default(cls, name)
        values[name] = _converted(types_[name], value, f"{where}.{name}", current)
    try:
        if base is not None:
            return dataclasses.replace(base, **values) if dataclasses.is_dataclass(cls) else base.model_copy(update=values)
        return cls(**values)
    except (TypeError, ValueError) as exc:  # pydantic's ValidationError is a ValueError
        said = " ".join(str(exc).split())
        raise InputError(f"{where}: {said}") from None


def _default(cls: type, name: str) -> Any:
    """The default of field `name` (None when it has none), so a nested mapping sets fields
    of the default the outer class gives, not of the nested class's own defaults."""
    if _is_pydantic(cls):
        info = cls.model_fields[name]
        return None if info.is_required() else info.get_default(call_default_factory=True)
    field = next(f for f in dataclasses.fields(cls) if f.name == name)
    if field.default is not dataclasses.MISSING:
        return field.default
    return field.default_factory() if field.default_factory is not dataclasses.MISSING else None


def _shown(value: Any) -> str:
    return f"{type(value).__name__} {value!r}"[:120]


def _converted(hint: Any, value: Any, where: str, current: Any = None) -> Any:
    """`value` as the type `hint` says, or InputError naming `where`."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if isinstance(hint, _Unresolved):
        if value is None and current is None:
            return None
        raise InputError(f"{where}: a {hint.text} cannot be set from plain data")
    if hint is Any:
        return value
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        choices = [a for a in args if a is not type(None)]
        if len(choices) == 1:
            return _converted(choices[0], value, where, current)
        problems = []
        # A mapping for `Options | None` sets fields of the current object (else of the defaults).
        for choice in choices:
            try:
                return _converted(choice, value, where, current)
            except InputError as exc:
                problems.append(str(exc).removeprefix(f"{where}: "))
        raise InputError(f"{where}: {' or '.join(dict.fromkeys(problems))}")
    if origin is Literal:
        if value in args and type(value) in {type(a) for a in args}:
            return value
        raise InputError(f"{where}: {value!r} is not one of {', '.join(map(repr, args))}")
    if is_options_class(hint):
        return options_from_dict(hint, value, where=where, base=current if isinstance(current, hint) else None)
    if hint is bool:
        if isinstance(value, bool):
            return value
        raise InputError(f"{where}: expected true or false, got {_shown(value)}")
    if hint is int:
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        if isinstance(value, float) and value.is_integer():
            return int(value)
        raise InputError(f"{where}: expected a whole number, got {_shown(value)}")
    if hint is float:
        if isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value):
            return float(value)
        raise InputError(f"{where}: expected a finite number, got {_shown(value)}")
    if hint is str:
        if isinstance(value, str):
            return value
        raise InputError(f"{where}: expected text, got {_shown(value)}")
    if hint is Path:
        if isinstance(value, str | Path) and str(value):
            return Path(value)
        raise InputError(f"{where}: expected a path, got {_shown(value)}")
    if isinstance(hint, type) and issubclass(hint, enum.Enum):
        try:
            return hint(value)
        except ValueError:
            raise InputError(f"{where}: {value!r} is not one of {', '.join(repr(m.value) for m in hint)}") from None
    if origin in (list, tuple) and isinstance(value, list | tuple):
        if origin is tuple and args and args[-1] is not Ellipsis:
            if len(value) != len(args):
                raise InputError(f"{where}: expected {len(args)} values, got {len(value)}")
            return tuple(_converted(a, v, f"{where}.{i}", None) for i, (a, v) in enumerate(zip(args, value)))
        item = args[0] if args else Any
        items = [_converted(item, v, f"{where}.{i}", None) for i, v in enumerate(value)]
        return tuple(items) if origin is tuple else items
    if origin is dict and isinstance(value, Mapping):
        key_hint, value_hint = args or (Any, Any)
        return {_converted(key_hint, k, where, None): _converted(value_hint, v, f"{where}.{k}", None) for k, v in value.items()}
    if origin in (list, tuple, dict):
        raise InputError(f"{where}: expected a {'mapping' if origin is dict else 'list'}, got {_shown(value)}")
    raise InputError(f"{where}: a {getattr(hint, '__name__', hint)} cannot be set from plain data")
