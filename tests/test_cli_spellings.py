"""One spelling per option in `--help`; the earlier spellings (`--texture-px`, `--density`,
`--width`, `--height`, `--room`) keep working as hidden aliases that set the same value."""

from __future__ import annotations

import inspect

import pytest
import typer
from typer.testing import CliRunner

from homemodel.cli import app
from homemodel.cli.option_fields import field_option, from_options, old_spellings

# (command, old spelling, the spelling --help shows)
OLD_SPELLINGS = [
    (("photogrammetry", "reconstruct"), "--texture-px", "--texture-size-px"),
    (("completion", "run"), "--density", "--density-kg-m3"),
    (("turntable", "simulate"), "--width", "--width-px"),
    (("turntable", "simulate"), "--height", "--height-px"),
    (("turntable", "reconstruct"), "--room", "--parent"),
    (("photogrammetry", "reconstruct"), "--room", "--parent"),
    (("completion", "run"), "--room", "--parent"),
]


def _commands(group, path: tuple[str, ...] = ()):  # noqa: ANN001 (a Click group)
    for name, command in group.commands.items():
        if hasattr(command, "commands"):
            yield from _commands(command, (*path, name))
        else:
            yield (*path, name), command


COMMANDS = sorted(_commands(typer.main.get_command(app)), key=lambda c: c[0])


def test_every_visible_option_has_one_spelling() -> None:
    assert len(COMMANDS) >= 35
    for path, command in COMMANDS:
        for param in command.params:
            if param.param_type_name == "option" and not param.hidden:
                flags = [*param.opts, *param.secondary_opts]
                boolean_pair = param.is_flag and len(param.opts) == len(param.secondary_opts) == 1  # --x/--no-x
                assert len(flags) == 1 or boolean_pair, f"{' '.join(path)}: {flags}"


@pytest.mark.parametrize("path", sorted({p for p, _, _ in OLD_SPELLINGS}), ids=" ".join)
def test_help_shows_the_new_spelling_only(path: tuple[str, ...]) -> None:
    result = CliRunner().invoke(app, [*path, "--help"], env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    for _, old, new in (s for s in OLD_SPELLINGS if s[0] == path):
        assert new in result.output
        assert not any(word.strip("│,") == old for word in result.output.split()), f"{old} shown in {' '.join(path)} --help"


@pytest.mark.parametrize("path, old, new", OLD_SPELLINGS, ids=[f"{' '.join(p)} {o}" for p, o, _ in OLD_SPELLINGS])
def test_the_old_spelling_is_a_hidden_twin_of_the_new(path: tuple[str, ...], old: str, new: str) -> None:
    command = dict(COMMANDS)[path]
    by_flag = {flag: param for param in command.params for flag in param.opts}
    assert by_flag[old].hidden and not by_flag[new].hidden
    assert by_flag[old].name == f"{by_flag[new].name}_old_spelling"
    twin, option = by_flag[old], by_flag[new]
    assert twin.type_descriptor.annotation == option.type_descriptor.annotation  # the same type and bounds
    assert getattr(twin, "min", None) == getattr(option, "min", None) and getattr(twin, "max", None) == getattr(option, "max", None)


def test_an_old_spelling_sets_the_value_of_the_new() -> None:
    seen: list[int] = []
    toy = typer.Typer()

    @toy.command()
    @from_options
    def bake(
        size_px: int = field_option("photogrammetry.texturing:TextureBakingOptions.size_px", "--texture-size-px", old=("--texture-px",)),
        name: str = typer.Option("x", "--name"),
    ) -> None:
        seen.append(size_px)

    runner = CliRunner()
    for args in (["--texture-px", "512"], ["--texture-size-px", "1024"], [], ["--name", "y"]):
        assert runner.invoke(toy, args).exit_code == 0
    default = inspect.signature(bake.__wrapped__).parameters["size_px"].default.default
    assert seen == [512, 1024, default, default]
    help_text = runner.invoke(toy, ["--help"], env={"COLUMNS": "200"}).output
    assert "--texture-size-px" in help_text and "--texture-px " not in help_text


def test_the_old_spelling_is_bounded_as_the_new() -> None:
    """Both spellings of completion's density are refused below the flag's 1 kg/m^3."""
    runner = CliRunner()
    for flag in ("--density", "--density-kg-m3"):
        result = runner.invoke(app, ["completion", "run", "m.npz", "d.png", "--out", "o", flag, "0.5"], env={"COLUMNS": "200"})
        assert result.exit_code == 2 and f"'{flag}': Input should be greater than or equal to 1" in result.output, result.output


def test_a_required_option_cannot_take_an_old_spelling() -> None:
    with pytest.raises(ValueError, match="required"):
        old_spellings(typer.Option(..., "--out"), "--output")
