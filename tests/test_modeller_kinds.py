"""The modeller's one registry: every kind's spec and builder found from `modeller.kinds`."""

from __future__ import annotations

from pathlib import Path

from modeller.kinds import KINDS, SPEC_TYPES

REPO = Path(__file__).resolve().parents[1]


def test_every_kind_names_its_spec_and_a_builder_of_the_builders_package() -> None:
    for name, kind in KINDS.items():
        assert kind.spec.model_fields["kind"].annotation.__args__ == (name,), name
        assert kind.builder.__module__.startswith("modeller.builders."), name
        assert kind.spec.__module__.startswith("modeller.specs."), name
    assert SPEC_TYPES == {name: kind.spec for name, kind in KINDS.items()}


def test_every_spec_class_with_a_kind_is_registered() -> None:
    """A spec written in modeller/specs but left out of the registry would never build."""
    import modeller.specs as specs

    kinds = {getattr(specs, name) for name in specs.__all__ if name.endswith("Spec")} - {specs.ObjectSpec}
    assert kinds <= set(SPEC_TYPES.values())
    assert len(SPEC_TYPES) == 27


def test_the_catalogue_has_an_example_of_most_kinds() -> None:
    examples = {path.stem for path in (REPO / "examples" / "catalogue").glob("*.yaml")}
    assert len(set(KINDS) & examples) >= 25
