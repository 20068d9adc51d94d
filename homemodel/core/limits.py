"""The bounds homemodel puts on every input where it enters, and how a user raises them.

A small file can ask for unbounded work (YAML aliases that expand to millions of objects, a
URDF of thousands of joints, a mesh of millions of triangles); each bound has a default that
fits a home's models on a 4 GiB machine, and an environment variable to raise it:
`HOMEMODEL_MAX_TRIANGLES=5000000 homemodel validate ...`.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

from homemodel.core.errors import InputError


@dataclass(frozen=True)
class Limit:
    name: str  # environment variable that overrides the default
    default: int
    what: str  # "triangles", "bytes", ...

    @property
    def value(self) -> int:
        text = os.environ.get(self.name)
        if text is None:
            return self.default
        try:
            value = int(text)
        except ValueError:
            raise InputError(f"{self.name}={text!r}: must be a whole number") from None
        if value < 1:
            raise InputError(f"{self.name}={text!r}: must be at least 1")
        return value

    def check(self, source: object, count: int) -> None:
        """Raise an InputError naming `source`, the count, the bound and how to raise it."""
        bound = self.value
        if count > bound:
            raise InputError(
                f"{source}: {count} {self.what} is over the limit of {bound} (set {self.name} to raise it)"
            )


YAML_NODES = Limit("HOMEMODEL_MAX_YAML_NODES", 200_000, "YAML nodes (aliases expanded)")
YAML_DEPTH = Limit("HOMEMODEL_MAX_YAML_DEPTH", 64, "levels of YAML nesting")
HOME_OBJECTS = Limit("HOMEMODEL_MAX_OBJECTS", 2_000, "objects")
URDF_LINKS = Limit("HOMEMODEL_MAX_LINKS", 1_000, "links")
URDF_JOINTS = Limit("HOMEMODEL_MAX_JOINTS", 1_000, "joints")
MESH_TRIANGLES = Limit("HOMEMODEL_MAX_TRIANGLES", 1_000_000, "triangles")
IMAGE_PIXELS = Limit("HOMEMODEL_MAX_PIXELS", 120_000_000, "pixels")  # a 100-megapixel camera's photos pass
RENDER_PIXELS = Limit("HOMEMODEL_MAX_RENDER_PIXELS", 4096 * 4096, "pixels per rendered frame")
SURFACE_SAMPLES = Limit("HOMEMODEL_MAX_SAMPLES", 10_000_000, "surface samples")
MODEL_BYTES = Limit("HOMEMODEL_MAX_MODEL_BYTES", 1024**3, "bytes of completion model arrays")
