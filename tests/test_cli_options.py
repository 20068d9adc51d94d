"""The command line restates no option: every flag's default and choices are its options
field's, read from both sides (Click's parameters against the imported classes); and every
pipeline's entry keeps one result contract (`.summary` a ModelSummary, `map_entry`, one
model-name check)."""

from __future__ import annotations

import dataclasses
import functools
import importlib
import inspect
import re
import subprocess
import sys
import typing
from pathlib import Path
from typing import Any, Literal

import pytest
import typer
from typer.testing import CliRunner

from homemodel.cli import app
from homemodel.cli.option_fields import field_option, from_options, options_field, read_field
from homemodel.core.errors import InputError
from homemodel.core.model_summary import ModelSummary, read_summary

# Flags that set no options field: what to read and write, and map placement; their defaults
# are None, False or required, except these.
PLUMBING = {"--xyz", "--rpy", "--device"}


def _commands(typer_app: typer.Typer, path: tuple[str, ...] = ()):
    """(command path, the Python function) of every command under `typer_app`."""
    for info in typer_app.registered_commands:
        yield (*path, info.name or typer.main.get_command_name(info.callback.__name__)), info.callback
    for group in typer_app.registered_groups:
        yield from _commands(group.typer_instance, (*path, group.name))


@functools.cache
def _click_root():  # noqa: ANN202 (a Click group)
    return typer.main.get_command(app)


def _click_command(path: tuple[str, ...]):
    command = _click_root()
    for name in path:
        command = command.commands[name]
    return command


def _hint(annotation: Any, namespace: dict) -> Any:
    return eval(annotation, namespace) if isinstance(annotation, str) else annotation  # noqa: S307 (our own annotations)


def _literal(hint: Any) -> tuple | None:
    """The values of a `Literal[...]` hint, also inside `... | None`."""
    literal = next((h for h in (hint, *typing.get_args(hint)) if typing.get_origin(h) is Literal), None)
    return None if literal is None else typing.get_args(literal)


def _runtime_field(ref: str) -> tuple[Any, tuple | None]:
    """(default, Literal choices) of the field `ref` names, from the imported class or function."""
    module_name, _, path = ref.partition(":")
    owner_name, *names = path.split(".")
    value: Any = getattr(importlib.import_module(module_name), owner_name)
    for name in names:
        if inspect.isfunction(value):
            parameter = inspect.signature(value).parameters[name]
            return parameter.default, _literal(_hint(parameter.annotation, value.__globals__))
        if inspect.isclass(value) and inspect.isfunction(getattr(value, name, None)):
            value = getattr(value, name)  # a method
            continue
        field = next(f for f in dataclasses.fields(value) if f.name == name)  # of a class, or of nested options
        cls = value if inspect.isclass(value) else type(value)
        hint = _hint(field.type, vars(sys.modules[cls.__module__]))
        if not inspect.isclass(value):
            value = getattr(value, name)
        elif field.default is not dataclasses.MISSING:
            value = field.default
        else:
            value = field.default_factory() if field.default_factory is not dataclasses.MISSING else inspect.Parameter.empty
    return value, _literal(hint)


COMMANDS = sorted(_commands(app))


def test_every_command_is_walked() -> None:
    names = {" ".join(path) for path, _ in COMMANDS}
    assert {"turntable reconstruct", "photogrammetry reconstruct", "completion run", "db serve", "render"} <= names
    assert len(COMMANDS) >= 35


@pytest.mark.parametrize("path, function", COMMANDS, ids=[" ".join(p) for p, _ in COMMANDS])
def test_flags_take_default_and_choices_from_their_options_field(path: tuple[str, ...], function) -> None:
    command = _click_command(path)
    signature = inspect.signature(function)
    for param in command.params:
        if param.param_type_name != "option" or param.name == "help":
            continue
        spec = options_field(signature.parameters[param.name].default)
        if spec is None:
            assert param.required or param.default in (None, False, (), []) or param.opts[0] in PLUMBING, (
                f"{' '.join(path)} {param.opts[0]}: default {param.default!r} is not an options field's"
            )
            continue
        default, choices = _runtime_field(spec.ref)
        if param.required:  # a field without a default
            assert default is inspect.Parameter.empty, (path, param.opts, spec.ref)
        else:
            shown = tuple(param.default or ()) if param.multiple else param.default
            assert shown == (tuple(default) if param.multiple else default), (path, param.opts, spec.ref)
        assert param.help, (path, param.opts)
        if choices is not None:
            assert _literal(param.type_descriptor.annotation) == choices, (path, param.opts, spec.ref)


def test_one_quantity_has_one_flag_in_every_command() -> None:
    """The density and the texture size, set by three pipelines, are spelt as their fields."""
    flags: dict[str, set[str]] = {"density_kg_m3": set(), "texture_size_px": set()}
    for path, function in COMMANDS:
        for param in _click_command(path).params:
            spec = options_field(inspect.signature(function).parameters[param.name].default)
            quantity = spec and spec.ref.rsplit(":", 1)[1].split(".", 1)[1].replace("texture.size_px", "texture_size_px")
            if quantity in flags:
                flags[quantity].add(param.opts[0])
    assert flags == {"density_kg_m3": {"--density-kg-m3"}, "texture_size_px": {"--texture-size-px"}}


def test_most_flags_come_from_options_fields() -> None:
    linked = [
        name
        for _, function in COMMANDS
        for name, parameter in inspect.signature(function).parameters.items()
        if options_field(parameter.default) is not None
    ]
    assert len(linked) >= 60, linked


def test_the_command_line_does_not_import_the_pipelines_to_build_its_flags() -> None:
    code = (
        "import sys, typer; from homemodel.cli.commands import app; typer.main.get_command(app);"
        "print(sorted(m for m in ('numpy', 'trimesh', 'photogrammetry', 'turntable', 'shape_completion',"
        " 'tracking', 'modeller') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=60)
    assert out.stdout.strip() == "[]", out.stdout + out.stderr


SOURCE = '''
from dataclasses import dataclass, field
from typing import Literal

Colour = Literal["red", "green"]


@dataclass(kw_only=True)
class Inner:
    size_px: int = 2_048  # texture atlas size
    colour: Colour | None = None


@dataclass(kw_only=True)
class Outer:
    inner: Inner = field(default_factory=Inner)
    names: list[str] = field(default_factory=list)
    mode: Literal["fast", "slow"] = "fast"
    computed: float = 2 * 3.0


class Estimator:
    def __init__(self, *, n_views: int = 40) -> None:
        self.n_views = n_views


def run(*, samples: int = 100_000, seed: int = 0) -> None:
    pass
'''


@pytest.fixture
def options_module(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> str:
    (tmp_path / "fake_options.py").write_text(SOURCE)
    monkeypatch.syspath_prepend(str(tmp_path))
    return "fake_options"


def test_fields_are_read_from_the_source(options_module: str) -> None:
    inner = read_field(f"{options_module}:Outer.inner.size_px")
    assert (inner.default, inner.choices, inner.comment) == (2048, None, "texture atlas size")
    assert read_field(f"{options_module}:Outer.inner.colour").choices == ("red", "green")  # through the alias
    assert read_field(f"{options_module}:Outer.mode").choices == ("fast", "slow")
    assert read_field(f"{options_module}:Outer.names").default == []
    assert read_field(f"{options_module}:Estimator.__init__.n_views").default == 40
    assert read_field(f"{options_module}:run.samples").default == 100_000
    for ref, problem in [
        ("Outer.computed", "not a literal: 2 * 3.0"),
        ("Outer.inner", "holds options (Inner)"),
        ("Outer.missing", "Outer has no field missing"),
        ("Nothing.x", "defines no Nothing"),
    ]:
        with pytest.raises(LookupError, match=re.escape(problem)):
            read_field(f"{options_module}:{ref}")


def test_a_literal_field_becomes_a_checked_choice(options_module: str) -> None:
    demo = typer.Typer()

    @demo.command()
    @from_options
    def show(
        mode: str = field_option(f"{options_module}:Outer.mode"),
        size: int = field_option(f"{options_module}:Outer.inner.size_px", "--size"),
    ) -> None:
        typer.echo(f"{mode} {size}")

    runner = CliRunner()
    assert runner.invoke(demo, []).output.strip() == "fast 2048"
    assert runner.invoke(demo, ["--mode", "slow", "--size", "8"]).output.strip() == "slow 8"
    refused = runner.invoke(demo, ["--mode", "medium"])
    assert refused.exit_code == 2 and "fast" in refused.output and "slow" in refused.output
    assert "texture atlas size" in runner.invoke(demo, ["--help"]).output  # the field's comment


def test_choices_and_old_spellings_reach_the_pipeline(tmp_path: Path) -> None:
    runner = CliRunner()
    photos = tmp_path / "photos"
    photos.mkdir()
    refused = runner.invoke(app, ["photogrammetry", "reconstruct", str(photos), "--out", str(tmp_path / "o"), "--matching", "vocab"])
    assert refused.exit_code == 2 and "retrieval" in refused.output
    for flag in ("--texture-size-px", "--texture-px"):  # the options check names the field either way
        result = runner.invoke(app, ["photogrammetry", "reconstruct", str(photos), "--out", str(tmp_path / "o"), flag, "8"])
        assert result.exit_code == 2 and "texture.size_px" in result.output, result.output


# The four pipelines' entries, their options and result types.
ENTRIES = [
    ("modeller", "build"),
    ("turntable", "reconstruct"),
    ("photogrammetry", "reconstruct"),
    ("shape_completion", "complete"),
]


@pytest.mark.parametrize("package, entry", ENTRIES)
def test_every_entry_keeps_one_result_contract(package: str, entry: str) -> None:
    from homemodel.model_folder.map_entry import MapEntry, Registration
    from homemodel.model_folder.result import ModelResult

    function = getattr(importlib.import_module(package), entry)
    signature = inspect.signature(function)
    result_class = _hint(signature.return_annotation, function.__globals__)
    assert issubclass(result_class, ModelResult)  # one result type: summary, map_entry, registration
    options_class = _hint(signature.parameters["options"].annotation, function.__globals__)
    options_class = next(a for a in typing.get_args(options_class) if a is not type(None))

    def field_hint(cls: type, name: str) -> Any:
        """The field's annotation; names imported only for type checkers are the real classes."""
        annotation = next(f.type for f in dataclasses.fields(cls) if f.name == name)
        namespace = {**vars(sys.modules[cls.__module__]), "ModelSummary": ModelSummary, "Registration": Registration,
                     "MapEntry": MapEntry}  # fmt: skip
        return _hint(annotation, namespace)

    assert ModelSummary in (field_hint(result_class, "summary"), *typing.get_args(field_hint(result_class, "summary")))
    assert Registration in typing.get_args(field_hint(result_class, "registration"))
    assert MapEntry in typing.get_args(field_hint(options_class, "map_entry"))
    with pytest.raises(InputError, match=r"^name: 'a cup': use letters, digits and underscores$"):
        options_class(name="a cup").check()


def test_the_modeller_entry_registers_into_a_map(tmp_path: Path, house_file: Path, kitchen_dir: Path) -> None:
    from homemodel.exchange.map_xml import load_map
    from homemodel.model_folder.map_entry import MapEntry
    from modeller import BuildOptions, build

    entry = MapEntry(map_path=house_file, object_id="green_cup", parent_id="table")
    built = build(kitchen_dir / "blue_cup.yaml", tmp_path / "cup", BuildOptions(name="green_cup", map_entry=entry))
    assert isinstance(built.summary, ModelSummary) and built.summary == read_summary(tmp_path / "cup")
    assert built.map_entry is entry
    assert built.registration.path == ["house", "kitchen", "table", "green_cup"]
    assert load_map(house_file).parent("green_cup").id == "table"


def test_completion_refuses_a_bad_map_parent_before_any_work(tmp_path: Path, house_file: Path) -> None:
    out = tmp_path / "out"
    result = CliRunner().invoke(
        app,
        ["completion", "run", str(tmp_path / "model.npz"), str(tmp_path / "depth.png"), "--camera", str(tmp_path / "camera.yaml"),
         "--out", str(out), "--map", str(house_file), "--parent", "garden"],
    )  # fmt: skip
    assert result.exit_code == 2 and "garden" in result.output and not out.exists(), result.output
