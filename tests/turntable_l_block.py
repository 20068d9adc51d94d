"""A simulated turntable capture of a concave L block, made once per content of this file and
of the turntable package (fixture_cache) and shared: the scan-meshes test reconstructs it in
the test's process, the extension's window test as the background job an installer starts.
It is the suite's Cycles capture (the others are ray cast, for speed): its tag corners are held
against the truth and against the ray caster's in test_turntable_accuracy.py."""

from __future__ import annotations

from pathlib import Path

import trimesh
from fixture_cache import cached_folder, content_key

L_BLOCK_CAPTURE = dict(frames=12, width_px=320, height_px=240, renderer="cycles", samples=2, camera_distance_m=0.3,
                       camera_height_m=0.55, tag_size_m=0.04)  # fmt: skip


def l_block() -> trimesh.Trimesh:
    """An L of two 4 cm thick blocks, 12 cm long and 10 cm high: its hull fills the inner corner."""
    base = trimesh.creation.box((0.12, 0.08, 0.04)).apply_translation((0, 0, 0.02))
    upright = trimesh.creation.box((0.04, 0.08, 0.1)).apply_translation((-0.04, 0, 0.05))
    return base.union(upright)


def l_block_capture() -> Path:
    """The capture folder (camera.yaml, board.yaml, color/, depth/): read-only, shared by runs."""
    from turntable.simulate import SimulationOptions, simulate_capture

    def simulate(root: Path) -> None:
        l_block().export(root / "l_block.ply")
        simulate_capture(root / "l_block.ply", root / "capture", SimulationOptions(**L_BLOCK_CAPTURE))

    key = content_key(
        inputs=[Path(__file__)], packages=("turntable",), settings=repr(L_BLOCK_CAPTURE)
    )
    return cached_folder("turntable_l_block", key, simulate) / "capture"
