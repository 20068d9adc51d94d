"""Measurement specs: what an installer measures with a tape, one pydantic model per kind.

The conventions (units, the model frame, left and right) are in `modeller.specs.common`.
Each family of kinds has its module; `SPEC_TYPES` maps a spec's `kind` field to its model.
"""

from __future__ import annotations

from modeller.specs.cabinets import CupboardSpec
from modeller.specs.common import (
    NAMED_COLOURS,
    Colour,
    ObjectSpec,
    colour_name,
    colour_rgb,
)
from modeller.specs.furniture import TableSpec
from modeller.specs.tableware import CupSpec

SPEC_TYPES: dict[str, type[ObjectSpec]] = {
    spec_type.model_fields["kind"].annotation.__args__[0]: spec_type
    for spec_type in (CupboardSpec, TableSpec, CupSpec)
}
Spec = ObjectSpec
"""Any kind's spec (every one has a `kind` field naming it)."""

__all__ = [
    "NAMED_COLOURS",
    "SPEC_TYPES",
    "Colour",
    "CupSpec",
    "CupboardSpec",
    "ObjectSpec",
    "Spec",
    "TableSpec",
    "colour_name",
    "colour_rgb",
]
