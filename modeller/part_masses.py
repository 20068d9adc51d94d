"""Masses of parts from what they are, not from their share of the model's volume.

Spread by volume, a fridge's thick insulated walls and doors made a 16 kg freezer drawer
and a jar's solid lid took half the jar. Here a door is a panel of its material, a drawer
a front panel and a thin box, a jar's lid a pressed shell; the rest of the spec's total
mass goes to the other links by volume (`modeller.blender_to_model`), so the total is kept.
"""

from __future__ import annotations

import math

from modeller.specs.cabinet_geometry import door_shelf_box_m, drawer_box_bounds_m
from modeller.specs.cabinets import CabinetSpec
from modeller.specs.containers import JarSpec

# Effective densities of a door or drawer front, kg/m³ of its outer volume: an appliance's
# front is a steel or glass skin round foam or air, far lighter than its solid volume
# (a 0.6 x 1.2 m fridge door weighs about 9 kg, an oven door 6 to 8 kg, a microwave's 2 kg).
_FRONT_DENSITY_KG_M3 = {"fridge": 250.0, "oven": 550.0, "dishwasher": 300.0, "washing_machine": 500.0, "microwave": 350.0}
# A drawer's box behind its front, and a fridge door's bins: sheets of this thickness and
# density. Furniture drawers are 12 mm board of the cabinet's material; appliances' are
# 3 mm polystyrene.
_FURNITURE_SHEET_M = 0.012
_APPLIANCE_SHEET_M = 0.003
_PLASTIC_DENSITY_KG_M3 = 1050.0
# A jar's lid: a pressed shell of the jar's material this thick over its top and rim.
_LID_SHELL_M = 0.002


def _open_box_area_m2(size_m) -> float:
    """Four walls and a floor of a box without its top."""
    x, y, z = size_m
    return x * y + 2 * (x + y) * z


def front_masses_kg(spec: CabinetSpec) -> dict[str, float]:
    """Each door's and drawer's mass, by link name."""
    appliance = spec.kind in _FRONT_DENSITY_KG_M3
    front_density = _FRONT_DENSITY_KG_M3.get(spec.kind, spec.density_kg_m3 or spec.default_density_kg_m3)
    sheet_m, sheet_density = (
        (_APPLIANCE_SHEET_M, _PLASTIC_DENSITY_KG_M3) if appliance else (_FURNITURE_SHEET_M, front_density)
    )
    masses = {}
    for i, door in enumerate(spec.doors):
        area = door.width_m * door.height_m * (math.pi / 4 if door.shape == "round" else 1.0)
        bins = sum(_open_box_area_m2(high - low) for low, high in (door_shelf_box_m(spec, door, s) for s in door.shelves))
        masses[f"door_{i}"] = area * spec.door_thickness_m * front_density + bins * sheet_m * sheet_density
    for i, drawer in enumerate(spec.drawers):
        y_min, y_max, z_min, z_max = drawer_box_bounds_m(spec, drawer)
        box = _open_box_area_m2((drawer.depth_m, y_max - y_min, z_max - z_min))
        front = drawer.width_m * drawer.height_m * spec.door_thickness_m * front_density
        masses[f"drawer_{i}"] = front + box * sheet_m * sheet_density
    return masses


def jar_lid_mass_kg(spec: JarSpec) -> float:
    """The lid as a shell over its top disc and round its rim (its knob is small beside it)."""
    radius = spec.lid_diameter_or_default_m / 2
    area = math.pi * radius**2 + 2 * math.pi * radius * spec.lid_thickness_m
    return area * _LID_SHELL_M * (spec.density_kg_m3 or spec.default_density_kg_m3)
