"""Measurement specs, the parts every kind shares: what an installer measures with a tape, as pydantic models.

Lengths are metres (`_m`), angles degrees (`_deg`), masses kilograms. Colours are
`[r, g, b]` in 0..1 (linear, as Blender, URDF and glTF take them) or a name from
`NAMED_COLOURS`.

Every model's frame: origin at the centre of its footprint on the floor, +z up, +x out of
its front face, +y to the object's own left. An installer standing in front of it, facing
it, has -y on the left hand and +y on the right. "Left" and "right" in a spec (a door's
hinge side, `left_m` offsets) are always as that installer sees them.

Checks that need more than one field (a door wider than the cupboard, overlapping fronts,
...) raise `FieldError`, which carries the path of the field to blame below the model it
is checked in; `homemodel.core.yaml_specs` joins it to pydantic's location.
"""

from __future__ import annotations

from typing import Annotated, ClassVar

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, model_validator

from homemodel.core.yaml_specs import FieldError
from modeller.specs.photos import FacePhoto

# Below this, two lengths count as equal (floating point noise in YAML values).
_EPS_M = 1e-9

# No object in a home is larger: a bound keeps 1e300 from overflowing every later step.
MAX_LENGTH_M = 100.0
Length = Annotated[float, Field(gt=0, le=MAX_LENGTH_M)]
Offset = Annotated[float, Field(ge=0, le=MAX_LENGTH_M)]
Density = Annotated[float, Field(gt=0, le=100_000.0)]  # kg/m^3: osmium is 22,590
Mass = Annotated[float, Field(gt=0, le=10_000.0)]  # kg
_Unit = Annotated[float, Field(ge=0, le=1)]

NAMED_COLOURS: dict[str, tuple[float, float, float]] = {
    "white": (0.9, 0.9, 0.9),
    "black": (0.02, 0.02, 0.02),
    "grey": (0.35, 0.35, 0.35),
    "gray": (0.35, 0.35, 0.35),
    "silver": (0.6, 0.6, 0.62),
    "red": (0.75, 0.05, 0.05),
    "green": (0.1, 0.5, 0.1),
    "blue": (0.05, 0.15, 0.7),
    "yellow": (0.85, 0.7, 0.05),
    "orange": (0.9, 0.35, 0.02),
    "brown": (0.3, 0.15, 0.06),
    "beige": (0.75, 0.65, 0.5),
    "oak": (0.55, 0.36, 0.18),
    "pink": (0.9, 0.4, 0.55),
    "purple": (0.35, 0.08, 0.5),
}


def _known_colour(value: str | tuple[float, float, float]) -> str | tuple[float, float, float]:
    if isinstance(value, str):
        name = value.strip().lower()
        if name not in NAMED_COLOURS:
            raise ValueError(f"unknown colour {value!r}; give [r, g, b] or one of {', '.join(NAMED_COLOURS)}")
        return name
    return value


Colour = Annotated[str | tuple[_Unit, _Unit, _Unit], AfterValidator(_known_colour)]


def colour_rgb(colour: Colour) -> tuple[float, float, float]:
    return NAMED_COLOURS[colour] if isinstance(colour, str) else tuple(colour)


def colour_name(colour: Colour) -> str:
    """The colour's name, or `rgb_rrggbb` for a colour given as numbers."""
    if isinstance(colour, str):
        return colour
    return "rgb_" + "".join(f"{round(c * 255):02x}" for c in colour)


class _Spec(BaseModel):
    # A misspelt field must not be silently ignored: the default it leaves is a wrong model.
    # YAML reads .nan and .inf as numbers; no measurement is either.
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class ObjectSpec(_Spec):
    """Fields every kind of model has."""

    default_density_kg_m3: ClassVar[float]

    name: str | None = Field(None, description="model name; default: the spec file's name without .yaml")
    density_kg_m3: Density | None = None
    mass_kg: Mass | None = Field(None, description="total mass, spread uniformly over the volume")
    photos: list[FacePhoto] = Field(
        [], description="photos put on faces of the built parts (see modeller.specs.photos); without, a colour per part"
    )

    @model_validator(mode="after")
    def _one_mass(self) -> ObjectSpec:
        if self.density_kg_m3 is not None and self.mass_kg is not None:
            raise FieldError(("mass_kg",), "give density_kg_m3 or mass_kg, not both")
        return self

    @property
    def density_or_default_kg_m3(self) -> float | None:
        """The density to use, or None when `mass_kg` decides."""
        if self.mass_kg is not None:
            return None
        return self.density_kg_m3 if self.density_kg_m3 is not None else self.default_density_kg_m3
