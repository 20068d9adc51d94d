"""A map prior as the robot would hold it: the kitchen's map with every large object off."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from homemodel.exchange.map_xml import load_map, save_map
from tracking.observe import rebase_model_refs


def write_prior_map(kitchen_map: Path, object_from_prior: np.ndarray, out: Path) -> Path:
    """Save the map with every large object moved by `object_from_prior` in its own frame."""
    smap = load_map(kitchen_map)
    for room in smap.apartment.rooms:
        for large in room.objects:
            large.world_from_object = large.world_from_object.from_matrix(large.world_from_object.matrix() @ object_from_prior)
    rebase_model_refs(smap, kitchen_map, out)
    save_map(smap, out)
    return out
