"""Measurement specs: what an installer measures with a tape, one pydantic model per kind.

The conventions (units, the model frame, left and right) are in `modeller.specs.common`.
Each family of kinds has its module; `SPEC_TYPES` maps a spec's `kind` field to its model.
"""

from __future__ import annotations

from modeller.specs.appliances import (
    DishwasherSpec,
    FridgeSpec,
    MicrowaveSpec,
    OvenSpec,
    WashingMachineSpec,
)
from modeller.specs.cabinets import CupboardSpec, WallCabinetSpec, WardrobeSpec
from modeller.specs.common import (
    NAMED_COLOURS,
    Colour,
    ObjectSpec,
    colour_name,
    colour_rgb,
)
from modeller.specs.containers import BottleSpec, BoxSpec, JarSpec, PillBoxSpec
from modeller.specs.cutlery import ForkSpec, KnifeSpec, SpoonSpec
from modeller.specs.devices import RemoteControlSpec
from modeller.specs.furniture import (
    BedSpec,
    ChairSpec,
    ShelvingSpec,
    SofaSpec,
    TableSpec,
)
from modeller.specs.tableware import BowlSpec, CupSpec, GlassSpec, MugSpec, PlateSpec
from modeller.specs.worktop import WorktopSpec

_FURNITURE_AND_SMALL_OBJECT_SPECS = (ChairSpec, SofaSpec, BedSpec, ShelvingSpec, WorktopSpec, MugSpec, GlassSpec, PlateSpec, BowlSpec, BottleSpec, BoxSpec, JarSpec, PillBoxSpec, SpoonSpec, ForkSpec, KnifeSpec, RemoteControlSpec)
_CABINET_AND_APPLIANCE_SPECS = (WallCabinetSpec, WardrobeSpec, FridgeSpec, OvenSpec, DishwasherSpec, WashingMachineSpec, MicrowaveSpec)
SPEC_TYPES: dict[str, type[ObjectSpec]] = {
    spec_type.model_fields["kind"].annotation.__args__[0]: spec_type
    for spec_type in (CupboardSpec, TableSpec, CupSpec, *_FURNITURE_AND_SMALL_OBJECT_SPECS, *_CABINET_AND_APPLIANCE_SPECS)
}
Spec = ObjectSpec
"""Any kind's spec (every one has a `kind` field naming it)."""

__all__ = [
    "NAMED_COLOURS",
    "SPEC_TYPES",
    "Colour",
    "CupSpec",
    "ChairSpec", "SofaSpec", "BedSpec", "ShelvingSpec", "MugSpec", "GlassSpec", "PlateSpec", "BowlSpec", "BottleSpec", "BoxSpec", "JarSpec", "PillBoxSpec", "SpoonSpec", "ForkSpec", "KnifeSpec", "RemoteControlSpec",
    "CupboardSpec",
    "WallCabinetSpec", "WardrobeSpec", "FridgeSpec", "OvenSpec", "DishwasherSpec", "WashingMachineSpec", "MicrowaveSpec",
    "ObjectSpec",
    "Spec",
    "TableSpec",
    "WorktopSpec",
    "colour_name",
    "colour_rgb",
]
