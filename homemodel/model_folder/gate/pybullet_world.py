"""One pybullet DIRECT client per thread, emptied for every use.

Connecting costs about 23 ms, most of it pybullet clearing its command buffers, and the gate
used four clients per model: over half its time on a cup. `resetSimulation` empties the world
(its bodies, and gravity back to zero) in about a millisecond. Each user sets what it needs
(gravity, time step) itself, as it did in a fresh client.
"""

from __future__ import annotations

import threading
from typing import Any

_local = threading.local()  # pybullet's calls name their client; a thread keeps its own


def empty_pybullet_client() -> int:
    """This thread's DIRECT client, emptied (the last model's bodies stay until then)."""
    import pybullet as pb

    client = getattr(_local, "client", None)
    if client is None or not pb.isConnected(physicsClientId=client):
        client = _local.client = pb.connect(pb.DIRECT)
    pb.resetSimulation(physicsClientId=client)
    return client


def declared_inertia_no_visuals(pb: Any) -> int:
    """`loadURDF`'s flags for the gate's pybullet and physics checks: the file's inertias, and the
    visual shapes not built. pybullet still parses every visual element (a missing mesh file or an
    unknown mesh type is refused either way); building the shapes only feeds its software renderer
    (a completion's 50,000-face visual: 0.064-0.069 CPU-s of a load, 0.009-0.010 without)."""
    return pb.URDF_USE_INERTIA_FROM_FILE | pb.URDF_IGNORE_VISUAL_SHAPES
