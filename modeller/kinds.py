"""Every kind of object the modeller builds, in one place: its spec (what the installer
measures) and its builder (what Blender makes of it). A new kind is one line here, with its
spec in `modeller.specs` and its builder in `modeller.builders`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from modeller.blender_to_model import Assembly
from modeller.builders.appliances import build_dishwasher, build_fridge, build_microwave, build_oven, build_washing_machine
from modeller.builders.bed import build_bed
from modeller.builders.boxes import build_box, build_pill_box
from modeller.builders.cup import build_cup
from modeller.builders.cupboard import build_cupboard, build_wall_cabinet, build_wardrobe
from modeller.builders.cutlery import build_fork, build_knife, build_spoon
from modeller.builders.remote_control import build_remote_control
from modeller.builders.seating import build_chair, build_sofa
from modeller.builders.shelving import build_shelving
from modeller.builders.table import build_table
from modeller.builders.vessels import build_bottle, build_bowl, build_glass, build_jar, build_plate
from modeller.builders.worktop import build_worktop
from modeller.specs import appliances, cabinets, containers, cutlery, devices, furniture, tableware, worktop
from modeller.specs.common import ObjectSpec


@dataclass(frozen=True)
class Kind:
    spec: type[ObjectSpec]
    # Makes the spec's objects in the (empty) Blender scene; called with (spec, model name).
    builder: Callable[..., Assembly]


KINDS: dict[str, Kind] = {
    "cupboard": Kind(spec=cabinets.CupboardSpec, builder=build_cupboard),
    "table": Kind(spec=furniture.TableSpec, builder=build_table),
    "cup": Kind(spec=tableware.CupSpec, builder=build_cup),
    "chair": Kind(spec=furniture.ChairSpec, builder=build_chair),
    "sofa": Kind(spec=furniture.SofaSpec, builder=build_sofa),
    "bed": Kind(spec=furniture.BedSpec, builder=build_bed),
    "shelving": Kind(spec=furniture.ShelvingSpec, builder=build_shelving),
    "worktop": Kind(spec=worktop.WorktopSpec, builder=build_worktop),
    "mug": Kind(spec=tableware.MugSpec, builder=build_cup),
    "glass": Kind(spec=tableware.GlassSpec, builder=build_glass),
    "plate": Kind(spec=tableware.PlateSpec, builder=build_plate),
    "bowl": Kind(spec=tableware.BowlSpec, builder=build_bowl),
    "bottle": Kind(spec=containers.BottleSpec, builder=build_bottle),
    "box": Kind(spec=containers.BoxSpec, builder=build_box),
    "jar": Kind(spec=containers.JarSpec, builder=build_jar),
    "pill_box": Kind(spec=containers.PillBoxSpec, builder=build_pill_box),
    "spoon": Kind(spec=cutlery.SpoonSpec, builder=build_spoon),
    "fork": Kind(spec=cutlery.ForkSpec, builder=build_fork),
    "knife": Kind(spec=cutlery.KnifeSpec, builder=build_knife),
    "remote_control": Kind(spec=devices.RemoteControlSpec, builder=build_remote_control),
    "wall_cabinet": Kind(spec=cabinets.WallCabinetSpec, builder=build_wall_cabinet),
    "wardrobe": Kind(spec=cabinets.WardrobeSpec, builder=build_wardrobe),
    "fridge": Kind(spec=appliances.FridgeSpec, builder=build_fridge),
    "oven": Kind(spec=appliances.OvenSpec, builder=build_oven),
    "dishwasher": Kind(spec=appliances.DishwasherSpec, builder=build_dishwasher),
    "washing_machine": Kind(spec=appliances.WashingMachineSpec, builder=build_washing_machine),
    "microwave": Kind(spec=appliances.MicrowaveSpec, builder=build_microwave),
}
# A spec's `kind` field selects its model type.
SPEC_TYPES: dict[str, type[ObjectSpec]] = {name: kind.spec for name, kind in KINDS.items()}
