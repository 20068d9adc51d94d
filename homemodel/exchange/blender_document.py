"""The Blender model document: the JSON the extension and the toolkit trade, and the custom
properties (`hm_*`) that carry it on a .blend's empties and, through Blender's glTF
exporter, on a glb's node extras.

The extension (`blender_addons/rig.py`) may not import homemodel, so it spells these out
again; tests/test_exchange.py checks that both sides agree. Transforms are 4x4 row-major
lists, lengths in metres, angles in radians.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from homemodel.core.errors import InputError
from homemodel.core.input_files import read_bounded

MODEL_FORMAT = "homemodel.blender-model/1"
# What a link made by hand in Blender says instead of an inertial.
FROM_MESHES = "from_meshes"
# A kitchen's largest model is a few MB as JSON; this bounds a hostile file.
MAX_DOCUMENT_BYTES = 512 * 1024 * 1024

# The custom properties; the names are the add-on's (rig.py) constant names.
MODEL = "hm_model"
SPEC = "hm_spec"
LINK = "hm_link"
COLLISIONS = "hm_collisions"
INERTIAL = "hm_inertial"
JOINT = "hm_joint"
JOINT_TYPE = "hm_joint_type"
AXIS = "hm_axis"
LOWER = "hm_lower"
UPPER = "hm_upper"
EFFORT = "hm_effort"
VELOCITY = "hm_velocity"
STATES = "hm_states"
DYNAMICS = "hm_dynamics"
POSITION = "hm_q"
GRASP = "hm_grasp"
GRASP_KIND = "hm_grasp_kind"


def matrix_list(a_from_b: np.ndarray) -> list[list[float]]:
    return np.asarray(a_from_b, dtype=np.float64).tolist()


def read_document(path: Path) -> dict:
    """A JSON document from `path`, size-bounded; InputError naming the file when it is not JSON."""
    path = Path(path)
    try:
        return json.loads(read_bounded(path, MAX_DOCUMENT_BYTES))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{path}: not a JSON document: {exc}") from None
