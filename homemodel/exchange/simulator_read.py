"""Read a scene, or one model, back from a simulator's file: the one entry the commands call
(`simulator` writes them). The format follows the file's suffix."""

from __future__ import annotations

from pathlib import Path

from articulation.model import Model
from articulation.scene import Scene
from homemodel.core.errors import InputError

MJCF_SUFFIXES = (".xml", ".mjcf")
SDF_SUFFIXES = (".sdf", ".world")
USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")
SCENE_FILE_SUFFIXES = (*MJCF_SUFFIXES, *SDF_SUFFIXES, *USD_SUFFIXES)


def read_scene(path: Path) -> Scene:
    """The scene of an MJCF (.xml), SDFormat (.sdf, .world) or USD (.usd, .usda, .usdc, .usdz)
    file; InputError naming the file otherwise."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in MJCF_SUFFIXES:
        from homemodel.exchange.mjcf_read import read_mjcf

        return read_mjcf(path)
    if suffix in SDF_SUFFIXES:
        from homemodel.exchange.sdf_read import read_sdf

        return read_sdf(path)
    if suffix in USD_SUFFIXES:
        from homemodel.exchange.usd_read import read_usd

        return read_usd(path)
    raise InputError(f"{path}: expected a scene file ({', '.join(SCENE_FILE_SUFFIXES)})")


def read_model(path: Path) -> Model:
    """The one model of a scene file (what `homemodel export` writes); InputError when the
    file holds several objects or none."""
    scene = read_scene(path)
    if len(scene.objects) != 1:
        ids = ", ".join(o.id for o in scene.objects)
        raise InputError(f"{path}: holds {len(scene.objects)} objects ({ids}); expected one model")
    return scene.objects[0].model
