"""networkx loaded on first use: trimesh's import leaves it out (0.08 CPU-s of a completion
query), and trimesh's networkx functions load it when called."""

from __future__ import annotations

import json
import subprocess
import sys

from cli_promise import REPO

_PROBE = """
import json, sys
from homemodel.core.deferred_imports import defer_networkx
defer_networkx()
import trimesh
with_trimesh = sorted(m for m in sys.modules if m.split(".")[0] == "networkx" and m != "networkx")
mesh = trimesh.creation.box()
solid = [mesh.is_watertight, len(mesh.split()), round(float(mesh.convex_hull.volume), 9)]
graph = mesh.vertex_adjacency_graph  # trimesh's networkx use loads networkx here
import networkx
parts = trimesh.graph.connected_components(mesh.face_adjacency, engine="networkx")
print(json.dumps([with_trimesh, solid, isinstance(graph, networkx.Graph), graph.number_of_nodes(), len(parts)]))
"""


def test_trimesh_imports_without_networkx_and_loads_it_on_first_use() -> None:
    done = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True, cwd=REPO, timeout=120,
                          env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"})
    assert done.returncode == 0, done.stderr[-2000:]
    with_trimesh, solid, is_graph, nodes, parts = json.loads(done.stdout.splitlines()[-1])
    assert with_trimesh == []  # none of networkx's 285 modules
    assert solid == [True, 1, 1.0]
    assert is_graph and nodes == 8 and parts == 1
