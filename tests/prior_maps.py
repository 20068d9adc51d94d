"""A map prior as the robot would hold it: the kitchen's map with every large object off."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from homemodel.exchange.map_xml import load_map, save_map
from tracking.observe import rebase_model_refs


def write_prior_map(kitchen_map: Path, object_from_prior: np.ndarray | Mapping[str, np.ndarray], out: Path) -> Path:
    """Save the map with every large object moved by `object_from_prior` in its own frame, or,
    given {id: transform}, the objects it names, each by its own."""
    smap = load_map(kitchen_map)
    for room in smap.apartment.rooms:
        for large in room.objects:
            off = object_from_prior.get(large.id) if isinstance(object_from_prior, Mapping) else object_from_prior
            if off is not None:
                large.world_from_object = large.world_from_object.from_matrix(large.world_from_object.matrix() @ off)
    rebase_model_refs(smap, kitchen_map, out)
    save_map(smap, out)
    return out
