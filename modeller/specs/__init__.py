"""Measurement specs: what an installer measures with a tape, one pydantic model per kind.

The conventions (units, the model frame, left and right) are in `modeller.specs.common`.
Each family of kinds has its module; `modeller.kinds` maps a spec's `kind` field to its model and builder.
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

Spec = ObjectSpec
"""Any kind's spec (every one has a `kind` field naming it)."""

__all__ = [
    "NAMED_COLOURS",
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
