"""Load a YAML file into a pydantic model, with one-line errors naming the file and the field."""

from __future__ import annotations

from pathlib import Path
from typing import TypeVar

import pydantic
import yaml

from homemodel.core.atomic import write_text_atomic
from homemodel.core.errors import InputError, SpecError
from homemodel.core.input_files import read_bounded
from homemodel.core.limits import YAML_DEPTH, YAML_NODES

MAX_SPEC_BYTES = 4 * 1024 * 1024
SpecT = TypeVar("SpecT", bound=pydantic.BaseModel)
# libyaml's parser under PyYAML's safe constructor: the same data, 5-20 times less CPU than the
# pure-Python parser (a home of 2,000 objects: 1.77 -> 0.20 CPU-s for the check and the load).
FAST_SAFE_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class FieldError(ValueError):
    """A failed check in a model validator blaming the field at `loc`, relative to the model
    doing the check, so the message names `doors.0.width_m` and not just `doors`."""

    def __init__(self, loc: tuple[str | int, ...], message: str) -> None:
        super().__init__(message)
        self.loc = loc


def check_yaml_size(path: Path, text: str, loader: type = yaml.SafeLoader) -> None:
    """Refuse YAML that nests deeper than YAML_DEPTH or holds more than YAML_NODES nodes once
    its aliases are expanded (a few KB of aliases can stand for millions of objects, which
    every later step would copy). One pass over the parser's events, no recursion: PyYAML's
    composer recurses once per level, so this must run before it."""
    open_counts: list[int] = [0]  # nodes so far in each open collection, the document at the bottom
    open_anchors: list[str | None] = []
    anchored: dict[str, int] = {}
    depth_limit, node_limit = YAML_DEPTH.value, YAML_NODES.value
    for event in yaml.parse(text, Loader=loader):
        if isinstance(event, yaml.CollectionStartEvent):
            if len(open_anchors) + 1 > depth_limit:
                YAML_DEPTH.check(path, len(open_anchors) + 1)
            open_counts.append(1)
            open_anchors.append(event.anchor)
        elif isinstance(event, yaml.CollectionEndEvent):
            count = open_counts.pop()
            anchor = open_anchors.pop()
            if anchor is not None:
                anchored[anchor] = count
            open_counts[-1] += count
        elif isinstance(event, yaml.ScalarEvent):
            open_counts[-1] += 1
            if event.anchor is not None:
                anchored[event.anchor] = 1
        elif isinstance(event, yaml.AliasEvent):
            open_counts[-1] += anchored.get(event.anchor, 1)
        if open_counts[-1] > node_limit:
            YAML_NODES.check(path, sum(open_counts))


def read_yaml_mapping(path: Path) -> dict:
    """The top-level mapping of a YAML file (safe loader, size-bounded)."""
    path = Path(path)
    try:
        text = read_bounded(path, MAX_SPEC_BYTES).decode("utf-8")
    except InputError as exc:
        raise SpecError(str(exc)) from None
    except UnicodeDecodeError as exc:
        raise SpecError(f"{path}: not UTF-8 text: {exc.reason}") from None
    try:
        data = _safe_load(path, text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or type(exc).__name__
        raise SpecError(f"{path}: invalid YAML{where}: {problem}") from None
    if not isinstance(data, dict):
        raise SpecError(f"{path}: expected a mapping of fields, got {type(data).__name__}")
    return data


def _safe_load(path: Path, text: str) -> object:
    """The bounded, safe load: by libyaml, or where it refuses the text by the pure-Python
    parser, whose verdict and message stand (libyaml's scanner stops at its own 1000 levels of
    nesting, looking ahead before the size check sees them)."""
    try:
        check_yaml_size(path, text, FAST_SAFE_LOADER)
        return yaml.load(text, Loader=FAST_SAFE_LOADER)  # noqa: S506 (a safe loader)
    except yaml.YAMLError:
        check_yaml_size(path, text)
        return yaml.safe_load(text)


def validation_problems(error: pydantic.ValidationError) -> list[tuple[str, str]]:
    """(dotted field, message) of every problem, with a model validator's FieldError blaming
    its own field."""
    problems = []
    for item in error.errors():
        loc = tuple(item["loc"])
        cause = item.get("ctx", {}).get("error")
        if isinstance(cause, FieldError):
            loc += cause.loc
        message = str(cause) if isinstance(cause, ValueError) else item["msg"]
        problems.append((".".join(str(part) for part in loc) or "(top level)", message))
    return problems


def describe_validation_error(error: pydantic.ValidationError) -> str:
    """`dotted.field: message` of the first problem, with a count of the others."""
    problems = validation_problems(error)
    field, message = problems[0]
    more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
    return f"{field}: {message}{more}"


def validate_mapping(path: Path, data: dict, spec_type: type[SpecT]) -> SpecT:
    try:
        return spec_type.model_validate(data)
    except pydantic.ValidationError as exc:
        raise SpecError(f"{path}: {describe_validation_error(exc)}") from None


def load_yaml_spec(path: Path, spec_type: type[SpecT]) -> SpecT:
    return validate_mapping(Path(path), read_yaml_mapping(Path(path)), spec_type)


def write_yaml(path: Path, data: dict, *, flow_style: bool | None = False) -> None:
    """Write `data` as YAML, keys in their order, atomically; `flow_style=None` writes lists
    of scalars on one line (`[0.1, 0.2]`)."""
    write_text_atomic(Path(path), yaml.safe_dump(data, sort_keys=False, default_flow_style=flow_style))
