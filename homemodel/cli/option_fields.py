"""Command-line options taken from the options classes: a flag's default, its choices (a
`Literal` field) and, where the command gives none, its help (the field's trailing comment)
come from the field it sets, so no value is written twice.

`field_option("photogrammetry.sfm:SfmOptions.max_num_features", "--max-features")` is the
`typer.Option` of that field. A path may go through nested options
(`photogrammetry.pipeline:ReconstructOptions.sfm.matching`, through the field's
`default_factory`) and may name a function's or a method's keyword parameter
(`turntable.board:grid_board.first_id`, `shape_completion.pipeline:ShapeCompleter.__init__.n_views`).
An option has one spelling in `--help`; `old=("--texture-px",)` (or `old_spellings` on a plain
`typer.Option`) keeps earlier spellings working as hidden aliases.

The field is read from the module's source, not imported: the options classes live beside
the pipelines, whose imports (numpy, trimesh, open3d, scipy) take seconds, and every command
line pays for the options of every command when Typer builds its commands. Defaults must be
literals (numbers, strings, tuples, None) or a `field(default=...)`/`default_factory` of
`list`, `dict` or an options class. tests/test_cli_options.py checks every flag against the
imported classes.
"""

from __future__ import annotations

import ast
import copy
import functools
import importlib.util
import inspect
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, Optional, TypeVar

import typer
from typer.models import OptionInfo

Command = TypeVar("Command", bound=Callable[..., Any])
REQUIRED = ...  # the default of a field without one: its flag must be given


@dataclass(frozen=True)
class FieldSpec:
    """One options field as its source defines it."""

    ref: str  # "module:Owner.field" as given to `field_option`
    default: Any  # REQUIRED when the field has none
    choices: tuple[str, ...] | None  # the values of a Literal field
    comment: str | None  # the field's trailing comment


@dataclass(frozen=True)
class _Module:
    name: str
    tree: ast.Module
    lines: list[str]


@functools.cache
def _module(name: str) -> _Module:
    """The parsed source of module `name`, found without importing it or its packages."""
    top, *rest = name.split(".")
    spec = importlib.util.find_spec(top)  # a top-level name: its package is not imported
    if spec is None or spec.origin is None:
        raise LookupError(f"{name}: no such module")
    path = Path(spec.origin)
    if rest:  # a module inside the package whose __init__ is `spec.origin`
        path = path.parent.joinpath(*rest)
        path = path / "__init__.py" if path.is_dir() else path.with_suffix(".py")
    source = path.read_text(encoding="utf-8")
    return _Module(name=name, tree=ast.parse(source, str(path)), lines=source.splitlines())


def _definition(module: _Module, name: str) -> tuple[_Module, ast.AST]:
    """The class, function or assignment `name` defines in `module`, following imports."""
    for node in module.tree.body:
        if isinstance(node, ast.ClassDef | ast.FunctionDef) and node.name == name:
            return module, node
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == name for t in node.targets):
            return module, node
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            for alias in node.names:
                if (alias.asname or alias.name) == name:
                    return _definition(_module(node.module), alias.name)
    raise LookupError(f"{module.name}: defines no {name}")


def _choices(module: _Module, annotation: ast.expr | None) -> tuple[str, ...] | None:
    """The values of a `Literal[...]` annotation (through an alias, with `| None`), or None."""
    if annotation is None:
        return None
    if isinstance(annotation, ast.Constant) and isinstance(annotation.value, str):  # a quoted annotation
        annotation = ast.parse(annotation.value, mode="eval").body
    if isinstance(annotation, ast.BinOp) and isinstance(annotation.op, ast.BitOr):
        return _choices(module, annotation.left) or _choices(module, annotation.right)
    if isinstance(annotation, ast.Subscript) and isinstance(annotation.value, ast.Name):
        if annotation.value.id == "Literal":
            values = annotation.slice.elts if isinstance(annotation.slice, ast.Tuple) else [annotation.slice]
            return tuple(ast.literal_eval(v) for v in values)
        if annotation.value.id == "Optional":
            return _choices(module, annotation.slice)
    if isinstance(annotation, ast.Name) and annotation.id not in ("str", "int", "float", "bool", "Path"):
        try:
            where, node = _definition(module, annotation.id)
        except LookupError:
            return None
        if isinstance(node, ast.Assign):  # `TagDetector = Literal["apriltag", "opencv"]`
            return _choices(where, node.value)
    return None


def _comment(module: _Module, node: ast.AST) -> str | None:
    line = module.lines[node.end_lineno - 1]
    _, sep, comment = line.partition("  # ")
    return (comment.strip() or None) if sep else None


def _field_default(module: _Module, owner: str, value: ast.expr | None, field: str) -> tuple[Any, str | None]:
    """(the default, the options class a `default_factory` names or None) of a field's value."""
    where = f"{module.name}:{owner}.{field}"
    if value is None:
        return REQUIRED, None
    if isinstance(value, ast.Call) and isinstance(value.func, ast.Name) and value.func.id == "field":
        keywords = {k.arg: k.value for k in value.keywords}
        if "default" in keywords:
            return ast.literal_eval(keywords["default"]), None
        factory = keywords.get("default_factory")
        if isinstance(factory, ast.Name):
            if factory.id in ("list", "dict"):
                return [] if factory.id == "list" else {}, None
            return None, factory.id
        raise LookupError(f"{where}: a default_factory that is not a name")
    try:
        return ast.literal_eval(value), None
    except ValueError:
        raise LookupError(f"{where}: its default is not a literal: {ast.unparse(value)}") from None


def _parameter(module: _Module, function: ast.FunctionDef, name: str) -> tuple[Any, tuple[str, ...] | None]:
    """(the default, the choices) of `function`'s parameter `name`."""
    args = function.args
    positional = args.posonlyargs + args.args
    defaults = dict(zip([a.arg for a in positional[len(positional) - len(args.defaults):]], args.defaults))
    defaults |= {a.arg: d for a, d in zip(args.kwonlyargs, args.kw_defaults) if d is not None}
    annotation = {a.arg: a.annotation for a in positional + args.kwonlyargs}
    if name not in annotation:
        raise LookupError(f"{module.name}:{function.name}: has no parameter {name}")
    default, _ = _field_default(module, function.name, defaults.get(name), name)
    return default, _choices(module, annotation[name])


def read_field(ref: str) -> FieldSpec:
    """The default, choices and comment of the field (or keyword parameter) `ref` names:
    `"module:Owner.field"`, `"module:Owner.nested.field"`, `"module:function.parameter"`."""
    module_name, _, path = ref.partition(":")
    owner, *names = path.split(".")
    module, node = _definition(_module(module_name), owner)
    while names:
        name = names.pop(0)
        if isinstance(node, ast.FunctionDef):
            if names:
                raise LookupError(f"{ref}: a parameter has no fields")
            default, choices = _parameter(module, node, name)
            return FieldSpec(ref=ref, default=default, choices=choices, comment=None)
        if not isinstance(node, ast.ClassDef):
            raise LookupError(f"{ref}: {owner} is not a class or a function")
        method = next((n for n in node.body if isinstance(n, ast.FunctionDef) and n.name == name), None)
        if method is not None:
            node = method
            continue
        assignment = next(
            (n for n in node.body if isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name) and n.target.id == name),
            None,
        )
        if assignment is None:
            raise LookupError(f"{ref}: {node.name} has no field {name}")
        default, nested = _field_default(module, node.name, assignment.value, name)
        if nested is not None:
            if not names:
                raise LookupError(f"{ref}: {name} holds options ({nested}), not a value: name one of its fields")
            module, node = _definition(module, nested)
            continue
        if names:
            raise LookupError(f"{ref}: {name} is a value, not options")
        return FieldSpec(
            ref=ref, default=default, choices=_choices(module, assignment.annotation), comment=_comment(module, assignment)
        )
    raise LookupError(f"{ref}: names no field")


def field_option(
    ref: str, *flags: str, old: tuple[str, ...] = (), help: str | None = None, **typer_options: Any
) -> OptionInfo:
    """The `typer.Option` of the field `ref` (see `read_field`): its default (required when
    it has none), and its help unless `help` is given. The flag defaults to the field's name
    (`--max-num-features`); `old` spellings keep working, hidden (`old_spellings`). A Literal
    field's choices and the old spellings reach Typer through `from_options` on the command."""
    spec = read_field(ref)
    flags = flags or ("--" + ref.rsplit(".", 1)[-1].replace("_", "-"),)
    info = typer.Option(spec.default, *flags, help=help or spec.comment, **typer_options)
    info.options_field = spec  # read by `from_options` and the tests
    return old_spellings(info, *old)


def old_spellings(info: OptionInfo, *flags: str) -> OptionInfo:
    """Mark `flags` as earlier spellings of `info`'s option: `from_options` gives the command a
    hidden option of those flags whose value, when given, is the option's. A required option
    cannot have one (the command would still ask for the new spelling)."""
    if flags and info.default is REQUIRED:
        raise ValueError(f"{info.param_decls}: a required option cannot take old spellings {flags}")
    info.old_flags = flags
    return info


def options_field(info: object) -> FieldSpec | None:
    """The field a command's option was made from (`field_option`), or None."""
    return getattr(info, "options_field", None)


def from_options(command: Command) -> Command:
    """Give each `field_option` parameter of `command` whose field is a Literal that Literal
    as its annotation, so Typer offers and checks its choices; and each option with old
    spellings (`old_spellings`) a hidden twin, returning `command` wrapped to take its value."""
    signature = inspect.signature(command)
    for name, parameter in signature.parameters.items():
        spec = options_field(parameter.default)
        if spec is not None and spec.choices is not None:
            choice = Literal[spec.choices]  # type: ignore[valid-type]
            command.__annotations__[name] = Optional[choice] if spec.default is None else choice  # noqa: UP007
    twins = {name: f"{name}_old_spelling" for name, p in signature.parameters.items() if getattr(p.default, "old_flags", ())}
    if not twins:
        return command

    @functools.wraps(command)
    def with_old_spellings(*args: Any, **kwargs: Any) -> Any:
        for name, twin in twins.items():
            value = kwargs.pop(twin)
            if value is not None:
                kwargs[name] = value
        return command(*args, **kwargs)

    annotations = dict(command.__annotations__)
    parameters = list(signature.parameters.values())
    for name, twin in twins.items():
        info = copy.copy(signature.parameters[name].default)
        info.param_decls, info.default, info.hidden, info.help = info.old_flags, None, True, None
        del info.old_flags
        info.__dict__.pop("options_field", None)  # the twin sets no field of its own
        annotation = annotations[name]
        if isinstance(annotation, str):
            annotation = eval(annotation, command.__globals__)  # noqa: S307 (the command's own annotation)
        annotations[twin] = Optional[annotation]  # noqa: UP007
        parameters.append(inspect.Parameter(twin, inspect.Parameter.KEYWORD_ONLY, default=info, annotation=annotations[twin]))
    with_old_spellings.__annotations__ = annotations
    with_old_spellings.__signature__ = signature.replace(parameters=parameters)  # type: ignore[attr-defined]
    return with_old_spellings  # type: ignore[return-value]
